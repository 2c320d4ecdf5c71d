"""GJK compiled to machine code: :func:`rworld_cli.collision.convex.distance`, one pair at a time.

Why: the numpy GJK runs each iteration as a few hundred array operations over the pairs still
running, and each operation costs numpy about a microsecond whatever its size, so small batches
(the sweep's refinements, the probing planner's checks) pay mostly overhead, and large ones a
brute-force pass over every face of every simplex.  Here the same algorithm is one LLVM
function: a loop over the pairs, GJK's loop inside, every value in a register, the simplex on the
stack.  It is compiled through :func:`rworld_cli.kernels.compile_ir` (llvmlite, already loaded
for device physics; cached on disk; ``RWORLD_KERNELS=numpy`` or a failed compile fall back to
the numpy GJK).

The function mirrors the numpy code step for step - the same support points (a polytope's first
vertex of largest dot product; a cylinder's closed form), the same stopping rules and the same
nearest-point search over the simplex's faces that contain its newest point (each face's affine
projection, kept when its barycentric weights are all non-negative, the nearest kept one wins) -
so the two agree to rounding (tested).

Layout, per pair k (rows of float64 arrays):

* ``vertices_a`` (P, VA, 3), ``vertices_b`` (P, VB, 3): polytope vertices (cylinders: ignored);
* ``shape_a``, ``shape_b`` (P, 9): ``[cylinder, centre xyz, axis xyz, radius, half length]``;
* ``out`` (P, 12): ``[core distance, point on a xyz, point on b xyz, overlap, iterations,
  lower bound, unfinished, depth bound]`` - the cores' nearest points (margins are applied by
  the caller); for cores that overlap with the origin inside the final tetrahedron, the
  distance from the origin to its nearest face (the tetrahedron lies in the Minkowski
  difference, so the penetration depth is at least that), else 0.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from .. import kernels
from . import kernel_ir
from .kernel_ir import DPTR, I64, IPTR, prototype
from .simplex import ABSOLUTE_TOLERANCE, RELATIVE_TOLERANCE
from .simplex import FACES as _FACES

# (P, VA, VB, vertices a, vertices b, shape a, shape b, out, max_iterations)
GJK = (I64, I64, I64, DPTR, DPTR, DPTR, DPTR, DPTR, I64)
# and, local: (rows a, rows b, pose a, pose b, neighbours a, neighbours b, DA, DB)
GJK_LOCAL = GJK + (IPTR, IPTR, DPTR, DPTR, IPTR, IPTR, I64, I64)

SHAPE_COLUMNS = 9
OUT_COLUMNS = 12


def gjk_ir(symbol: str, local: bool = False) -> str:
    """The LLVM IR text of the function ``symbol`` (see the module docstring for the layout):

    ``void f(i64 P, i64 VA, i64 VB, ptr vertices_a, ptr vertices_b, ptr shape_a, ptr shape_b,
    ptr out, i64 max_iterations)``

    ``local``: the polytopes are rows of tables in their own frames, placed per pair, with
    their vertices' neighbours (:func:`gjk_local`); the function takes six more arguments,
    ``ptr rows_a, ptr rows_b, ptr pose_a, ptr pose_b, ptr neighbours_a, ptr neighbours_b``
    and two counts ``i64 DA, i64 DB`` (neighbours per vertex).
    """
    import llvmlite.ir as ir

    from .kernel_ir import F64, Kernel

    kernel = Kernel("collision", symbol, GJK_LOCAL if local else GJK)
    fn, b, c, i, sqrt, fabs = kernel.fn, kernel.b, kernel.c, kernel.i, kernel.sqrt, kernel.fabs
    P, VA, VB, verts_a, verts_b, shape_a, shape_b, out, max_it = fn.args[:9]
    for arg in (verts_a, verts_b, shape_a, shape_b, out):
        arg.add_attribute("noalias")
    if local:
        rows_a, rows_b, pose_a, pose_b, nbr_a, nbr_b, DA, DB = fn.args[9:]
    D, I1 = kernel.D, ir.IntType(1)

    # ------------------------------------------------------------------ stack slots
    def slots(count: int, name: str):
        return kernel.array(F64, count, name)

    simplex, from_a, from_b = slots(12, "W"), slots(12, "SA"), slots(12, "SB")
    weights, v_slot = slots(4, "weights"), slots(3, "v")
    sa_slot, sb_slot = slots(3, "sa"), slots(3, "sb")
    scratch = [slots(12, f"tmp{j}") for j in range(3)]  # compaction buffers
    scratch_w = slots(4, "tmpw")
    count_slot, it_slot = kernel.slot(I64, "count"), kernel.slot(I64, "it")
    lower_slot, overlap_slot = kernel.slot(F64, "lower"), kernel.slot(F64, "overlap")
    unfinished_slot, best_slot = kernel.slot(F64, "unfinished"), kernel.slot(F64, "best")
    iterations_slot = kernel.slot(I64, "iterations")
    start_slots = [kernel.slot(I64, "start_a"), kernel.slot(I64, "start_b")]
    cur_slot, best_index_slot = kernel.slot(I64, "cur"), kernel.slot(I64, "best_index")

    def at(array, index):
        return b.gep(array, [i(0), index if not isinstance(index, int) else i(index)])

    def load(array, index):
        return b.load(at(array, index))

    def store(value, array, index):
        b.store(value, at(array, index))

    def row(pointer, index):
        return b.load(b.gep(pointer, [index]))

    def dot(x, y):
        return b.fadd(b.fadd(b.fmul(x[0], y[0]), b.fmul(x[1], y[1])), b.fmul(x[2], y[2]))

    def sub(x, y):
        return [b.fsub(x[j], y[j]) for j in range(3)]

    def cross(x, y):
        return [
            b.fsub(b.fmul(x[1], y[2]), b.fmul(x[2], y[1])),
            b.fsub(b.fmul(x[2], y[0]), b.fmul(x[0], y[2])),
            b.fsub(b.fmul(x[0], y[1]), b.fmul(x[1], y[0])),
        ]

    def select(cond, x, y):
        return b.select(cond, x, y)

    def point(array, slot):
        return [load(array, slot * 3 + j) for j in range(3)]

    # ------------------------------------------------------------------ the pair loop
    done_all = fn.append_basic_block("done_all")
    k_slot, pair_next = kernel.for_each(P, "pair", done_all)
    k = b.load(k_slot)

    def shape(pointer):
        base = b.mul(k, i(SHAPE_COLUMNS))
        values = [row(pointer, b.add(base, i(j))) for j in range(SHAPE_COLUMNS)]
        return {
            "cylinder": b.fcmp_ordered("!=", values[0], c(0.0)),
            "center": values[1:4],
            "axis": values[4:7],
            "radius": values[7],
            "half": values[8],
        }

    A, B = shape(shape_a), shape(shape_b)
    if local:
        A.update(rows=rows_a, pose=pose_a, nbr=nbr_a, degree=DA, start=start_slots[0])
        B.update(rows=rows_b, pose=pose_b, nbr=nbr_b, degree=DB, start=start_slots[1])
        for slot in start_slots:  # hill climbing starts at the first vertex, then the last found
            b.store(i(0), slot)

    def local_polytope(piece, vertices, V, d, target, merge):
        """A polytope of a table in its own frame, placed by the pair's pose: the direction
        taken into its frame, the farthest vertex found by climbing its neighbours from the last
        one found (a linear function has no other local maximum on a convex polytope's edge
        graph), or by scanning every vertex when the row is flagged (-2: no neighbours known),
        placed back in world."""
        row_index = b.load(b.gep(piece["rows"], [k]))
        base = b.mul(b.mul(row_index, V), i(3))
        pose = [row(piece["pose"], b.add(b.mul(k, i(12)), i(j))) for j in range(12)]
        Rm, tv = pose[:9], pose[9:]
        dl = [
            b.fadd(b.fadd(b.fmul(Rm[j], d[0]), b.fmul(Rm[3 + j], d[1])), b.fmul(Rm[6 + j], d[2]))
            for j in range(3)
        ]  # R^T d

        def vertex(index):
            offset = b.add(base, b.mul(index, i(3)))
            return [row(vertices, b.add(offset, i(j))) for j in range(3)]

        degree = piece["degree"]
        nbr = piece["nbr"]

        def neighbour(vertex_index, m):
            flat = b.add(b.mul(b.add(b.mul(row_index, V), vertex_index), degree), m)
            return b.load(b.gep(nbr, [flat]))

        place = fn.append_basic_block("place")
        climb_head = fn.append_basic_block("climb_head")
        scan_all = fn.append_basic_block("scan_all")
        flag = neighbour(i(0), i(0))
        scan = b.or_(b.icmp_signed("==", degree, i(0)), b.icmp_signed("==", flag, i(-2)))
        b.store(b.load(piece["start"]), cur_slot)
        b.cbranch(scan, scan_all, climb_head)
        # every vertex, the first of largest d.x (as the world scan)
        b.position_at_end(scan_all)
        b.store(i(0), cur_slot)
        b.store(dot(vertex(i(0)), dl), best_slot)
        m_slot, all_next = kernel.for_each(V, "all", place, start=1)
        m = b.load(m_slot)
        value = dot(vertex(m), dl)
        better = b.fcmp_ordered(">", value, b.load(best_slot))
        b.store(select(better, value, b.load(best_slot)), best_slot)
        b.store(b.select(better, m, b.load(cur_slot)), cur_slot)
        b.branch(all_next)
        # climbing: to the best neighbour while it is better
        b.position_at_end(climb_head)
        cur = b.load(cur_slot)
        b.store(dot(vertex(cur), dl), best_slot)
        b.store(cur, best_index_slot)
        nb_done = fn.append_basic_block("nb_done")
        m_slot, nb_next = kernel.for_each(degree, "nb", nb_done)
        n = neighbour(cur, b.load(m_slot))
        nb_work = fn.append_basic_block("nb_work")
        b.cbranch(b.icmp_signed(">=", n, i(0)), nb_work, nb_done)  # -1: the list has ended
        b.position_at_end(nb_work)
        value = dot(vertex(n), dl)
        better = b.fcmp_ordered(">", value, b.load(best_slot))
        b.store(select(better, value, b.load(best_slot)), best_slot)
        b.store(b.select(better, n, b.load(best_index_slot)), best_index_slot)
        b.branch(nb_next)
        b.position_at_end(nb_done)
        moved = b.icmp_signed("!=", b.load(best_index_slot), cur)
        b.store(b.load(best_index_slot), cur_slot)
        b.cbranch(moved, climb_head, place)
        # the vertex found, in world
        b.position_at_end(place)
        found = b.load(cur_slot)
        b.store(found, piece["start"])
        x = vertex(found)
        for j in range(3):
            value = b.fadd(
                b.fadd(
                    b.fadd(b.fmul(Rm[3 * j], x[0]), b.fmul(Rm[3 * j + 1], x[1])),
                    b.fmul(Rm[3 * j + 2], x[2]),
                ),
                tv[j],
            )
            store(value, target, j)
        b.branch(merge)

    def support(piece, vertices, V, d, target):
        """The core's farthest point along d into ``target`` (the numpy code's Pieces.support)."""
        cyl_block = fn.append_basic_block("cyl")
        poly_block = fn.append_basic_block("poly")
        merge = fn.append_basic_block("support_done")
        b.cbranch(piece["cylinder"], cyl_block, poly_block)
        # cylinder: centre + sign(d.a) h a + r radial/|radial|
        b.position_at_end(cyl_block)
        a = piece["axis"]
        along = dot(d, a)
        radial = [b.fsub(d[j], b.fmul(along, a[j])) for j in range(3)]
        again = dot(radial, a)
        radial = [b.fsub(radial[j], b.fmul(again, a[j])) for j in range(3)]
        norm = b.call(sqrt, [dot(radial, radial)])
        tiny = b.fcmp_ordered("<=", norm, b.fmul(c(1e-12), b.call(sqrt, [dot(d, d)])))
        scale = select(tiny, c(0.0), b.fdiv(piece["radius"], select(tiny, c(1.0), norm)))
        sign = select(b.fcmp_ordered(">=", along, c(0.0)), c(1.0), c(-1.0))
        axial = b.fmul(sign, piece["half"])
        for j in range(3):
            value = b.fadd(
                b.fadd(piece["center"][j], b.fmul(axial, a[j])), b.fmul(scale, radial[j])
            )
            store(value, target, j)
        b.branch(merge)
        # polytope: the first vertex of largest d.x
        b.position_at_end(poly_block)
        if local:
            local_polytope(piece, vertices, V, d, target, merge)
            b.position_at_end(merge)
            return
        base = b.mul(b.mul(k, V), i(3))
        first = [row(vertices, b.add(base, i(j))) for j in range(3)]
        b.store(dot(first, d), best_slot)
        for j in range(3):
            store(first[j], target, j)
        scan_slot, scan_next = kernel.for_each(V, "scan", merge, start=1)
        m = b.load(scan_slot)
        offset = b.add(base, b.mul(m, i(3)))
        x = [row(vertices, b.add(offset, i(j))) for j in range(3)]
        value = dot(x, d)
        better = b.fcmp_ordered(">", value, b.load(best_slot))
        b.store(select(better, value, b.load(best_slot)), best_slot)
        for j in range(3):
            store(select(better, x[j], load(target, j)), target, j)
        b.branch(scan_next)
        b.position_at_end(merge)

    # ------------------------------------------------------------------ one pair's GJK
    v0 = sub(A["center"], B["center"])
    small = b.fcmp_ordered("<", dot(v0, v0), c(1e-24))
    v0 = [select(small, c(1.0 if j == 0 else 0.0), v0[j]) for j in range(3)]
    for j in range(3):
        store(v0[j], v_slot, j)
    for j in range(4):
        store(c(0.0), weights, j)
    # every simplex slot defined before a pair's first iteration: a slot not yet written is
    # read with a zero weight (0 x garbage is NaN when the garbage is NaN or inf, which made
    # a pair's distance NaN depending on what the stack held before: found 2026-11-27)
    for array in (simplex, from_a, from_b, *scratch):
        for j in range(12):
            store(c(0.0), array, j)
    for j in range(4):
        store(c(0.0), scratch_w, j)
    b.store(i(0), count_slot)
    b.store(i(0), it_slot)
    b.store(i(0), iterations_slot)
    b.store(c(float("nan")), lower_slot)
    b.store(c(0.0), overlap_slot)
    b.store(c(0.0), unfinished_slot)

    loop_head = fn.append_basic_block("gjk_head")
    loop_body = fn.append_basic_block("gjk_body")
    finish = fn.append_basic_block("finish")
    ran_out = fn.append_basic_block("ran_out")
    b.branch(loop_head)
    b.position_at_end(loop_head)
    it = b.load(it_slot)
    b.cbranch(b.icmp_signed("<", it, max_it), loop_body, ran_out)

    b.position_at_end(loop_body)
    v = [load(v_slot, j) for j in range(3)]
    support(A, verts_a, VA, [b.fneg(x) for x in v], sa_slot)
    support(B, verts_b, VB, v, sb_slot)
    sa = [load(sa_slot, j) for j in range(3)]
    sb = [load(sb_slot, j) for j in range(3)]
    w = sub(sa, sb)
    b.store(b.add(b.load(iterations_slot), i(1)), iterations_slot)
    count = b.load(count_slot)
    # the convergence test from the second iteration on
    test_block = fn.append_basic_block("test")
    append_block = fn.append_basic_block("append")
    b.cbranch(b.icmp_signed(">", it, i(0)), test_block, append_block)
    b.position_at_end(test_block)
    vv, vw = dot(v, v), dot(v, w)
    gap = b.fsub(vv, vw)
    norm_v = b.call(sqrt, [vv])
    b.store(
        b.fdiv(vw, select(b.fcmp_ordered(">", norm_v, c(1e-300)), norm_v, c(1e-300))), lower_slot
    )
    scale = b.fmul(norm_v, b.fadd(norm_v, b.call(sqrt, [dot(w, w)])))
    done = b.or_(
        b.fcmp_ordered("<=", gap, b.fmul(c(RELATIVE_TOLERANCE), scale)),
        b.fcmp_ordered("<=", gap, b.fmul(c(ABSOLUTE_TOLERANCE), norm_v)),
    )
    tolerance = b.fmul(c(1e-15), b.fadd(c(1.0), scale))
    for slot in range(4):
        p = point(simplex, slot)
        diff = [b.call(fabs, [b.fsub(p[j], w[j])]) for j in range(3)]
        same = b.and_(
            b.and_(
                b.fcmp_ordered("<=", diff[0], tolerance), b.fcmp_ordered("<=", diff[1], tolerance)
            ),
            b.fcmp_ordered("<=", diff[2], tolerance),
        )
        done = b.or_(done, b.and_(b.icmp_signed("<", i(slot), count), same))
    b.cbranch(done, finish, append_block)

    # append w, then the nearest point of the simplex to the origin
    b.position_at_end(append_block)
    # a full simplex always ends the loop (the origin is inside); the clamp only keeps the
    # writes below inside the stack arrays whatever the input (NaN poses)
    count = b.select(b.icmp_signed(">", count, i(3)), i(3), count)
    for j in range(3):
        store(w[j], simplex, b.add(b.mul(count, i(3)), i(j)))
        store(sa[j], from_a, b.add(b.mul(count, i(3)), i(j)))
        store(sb[j], from_b, b.add(b.mul(count, i(3)), i(j)))
    count = b.add(count, i(1))
    b.store(count, count_slot)
    nearest_done = fn.append_basic_block("nearest_done")
    cases = {n: fn.append_basic_block(f"simplex{n}") for n in (1, 2, 3, 4)}
    switch = b.switch(count, cases[4])
    for n in (1, 2, 3):
        switch.add_case(i(n), cases[n])
    for n, block in cases.items():
        b.position_at_end(block)
        Y = [point(simplex, slot) for slot in range(n)]
        best = c(float("inf"))
        lam_best = [c(0.0)] * 4
        near_best = [c(0.0)] * 3
        inside = ir.Constant(I1, 0)
        for face in _FACES[n]:
            # the faces that contain the newest point, in the numpy code's order
            lam, valid = _affine_nearest(b, c, [Y[s] for s in face], dot, sub, cross, select)
            pt = [c(0.0)] * 3
            for weight, s in zip(lam, face):
                pt = [b.fadd(pt[j], b.fmul(weight, Y[s][j])) for j in range(3)]
            d2 = dot(pt, pt)
            better = b.and_(valid, b.fcmp_ordered("<", d2, best))
            best = select(better, d2, best)
            near_best = [select(better, pt[j], near_best[j]) for j in range(3)]
            face_lam = [c(0.0)] * 4
            for weight, s in zip(lam, face):
                face_lam[s] = weight
            lam_best = [select(better, face_lam[s], lam_best[s]) for s in range(4)]
            if len(face) == 4:
                inside = b.or_(inside, better)
        for s in range(4):
            store(lam_best[s], weights, s)
        for j in range(3):
            store(near_best[j], v_slot, j)
        b.store(b.select(inside, c(1.0), c(0.0)), overlap_slot)
        b.branch(nearest_done)
    b.position_at_end(nearest_done)
    # compact: the points with positive weight first, in order (numpy's stable argsort)
    kept = i(0)
    for s in range(4):
        weight = load(weights, s)
        positive = b.fcmp_ordered(">", weight, c(0.0))
        target = select(positive, kept, i(3))  # a point left out lands in slot 3, overwritten
        for array, buffer in zip((simplex, from_a, from_b), scratch):
            for j in range(3):
                store(load(array, s * 3 + j), buffer, b.add(b.mul(target, i(3)), i(j)))
        store(weight, scratch_w, target)
        kept = b.add(kept, b.zext(positive, kernel.I64))
    for array, buffer in zip((simplex, from_a, from_b), scratch):
        for j in range(12):
            store(load(buffer, j), array, j)
    for s in range(4):
        # slots from ``kept`` on hold no point: weight 0
        store(select(b.icmp_signed("<", i(s), kept), load(scratch_w, s), c(0.0)), weights, s)
    b.store(kept, count_slot)
    v = [load(v_slot, j) for j in range(3)]
    hit = b.or_(
        b.fcmp_ordered("!=", b.load(overlap_slot), c(0.0)),
        b.fcmp_ordered("<=", dot(v, v), c(1e-30)),
    )
    b.store(b.select(hit, c(1.0), c(0.0)), overlap_slot)
    b.store(b.add(it, i(1)), it_slot)
    b.cbranch(hit, finish, loop_head)

    b.position_at_end(ran_out)
    b.store(c(1.0), unfinished_slot)
    b.branch(finish)

    # ------------------------------------------------------------------ write the pair's answer
    b.position_at_end(finish)
    pa, pb = [c(0.0)] * 3, [c(0.0)] * 3
    for s in range(4):
        weight = load(weights, s)
        qa, qb = point(from_a, s), point(from_b, s)
        pa = [b.fadd(pa[j], b.fmul(weight, qa[j])) for j in range(3)]
        pb = [b.fadd(pb[j], b.fmul(weight, qb[j])) for j in range(3)]
    gap = sub(pa, pb)
    base = b.mul(k, i(OUT_COLUMNS))
    values = [b.call(sqrt, [dot(gap, gap)])] + pa + pb
    iterations = b.uitofp(b.load(iterations_slot), D)
    values += [b.load(overlap_slot), iterations, b.load(lower_slot), b.load(unfinished_slot)]
    # the depth bound: the origin's distance to the nearest face plane of a full simplex
    Y = [point(simplex, s) for s in range(4)]
    nearest_face = c(float("inf"))
    for face in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)):
        p0, p1, p2 = (Y[s] for s in face)
        normal = cross(sub(p1, p0), sub(p2, p0))
        size = b.call(sqrt, [dot(normal, normal)])
        height = b.fdiv(
            b.call(fabs, [dot(normal, p0)]),
            select(b.fcmp_ordered(">", size, c(1e-300)), size, c(1.0)),
        )
        height = select(b.fcmp_ordered(">", size, c(1e-300)), height, c(0.0))
        nearest_face = select(b.fcmp_ordered("<", height, nearest_face), height, nearest_face)
    full = b.and_(
        b.fcmp_ordered("!=", b.load(overlap_slot), c(0.0)),
        b.icmp_signed("==", b.load(count_slot), i(4)),
    )
    values.append(select(full, nearest_face, c(0.0)))
    for j, value in enumerate(values):
        b.store(value, b.gep(out, [b.add(base, i(j))]))
    b.branch(pair_next)

    b.position_at_end(done_all)
    b.ret_void()
    return kernel.text()


def _affine_nearest(b, c, pts, dot, sub, cross, select):
    """Barycentric weights of the origin's projection on the affine hull of the points, and
    whether they are all non-negative with a non-degenerate hull (the numpy code's
    ``_affine_nearest``, one face)."""
    import llvmlite.ir as ir

    k = len(pts)
    if k == 1:
        return [c(1.0)], ir.Constant(ir.IntType(1), 1)
    p0 = pts[0]
    E = [sub(p, p0) for p in pts[1:]]
    neg_p0 = [b.fneg(x) for x in p0]
    rhs = [dot(e, neg_p0) for e in E]
    if k == 2:
        det = dot(E[0], E[0])
        positive = b.fcmp_ordered(">", det, c(0.0))
        mu = [b.fdiv(rhs[0], select(positive, det, c(1.0)))]
        valid = positive
    elif k == 3:
        a, bb, cc = dot(E[0], E[0]), dot(E[0], E[1]), dot(E[1], E[1])
        det = b.fsub(b.fmul(a, cc), b.fmul(bb, bb))
        size = b.fmul(a, cc)
        safe = select(b.fcmp_ordered(">", det, c(0.0)), det, c(1.0))
        mu = [
            b.fdiv(b.fsub(b.fmul(cc, rhs[0]), b.fmul(bb, rhs[1])), safe),
            b.fdiv(b.fsub(b.fmul(a, rhs[1]), b.fmul(bb, rhs[0])), safe),
        ]
        floor = select(b.fcmp_ordered(">", size, c(1e-300)), size, c(1e-300))
        valid = b.fcmp_ordered(">", det, b.fmul(c(1e-24), floor))
    else:
        cof = [cross(E[1], E[2]), cross(E[2], E[0]), cross(E[0], E[1])]
        vol = dot(E[0], cof[0])
        det = b.fmul(vol, vol)
        size = b.fmul(b.fmul(dot(E[0], E[0]), dot(E[1], E[1])), dot(E[2], E[2]))
        nonzero = b.fcmp_ordered("!=", vol, c(0.0))  # numpy: |vol| > 0 (false for nan)
        safe = select(nonzero, vol, c(1.0))
        mu = [b.fdiv(dot(cof[j], neg_p0), safe) for j in range(3)]
        floor = select(b.fcmp_ordered(">", size, c(1e-300)), size, c(1e-300))
        valid = b.fcmp_ordered(">", det, b.fmul(c(1e-24), floor))
    total = mu[0]
    for m in mu[1:]:
        total = b.fadd(total, m)
    lam = [b.fsub(c(1.0), total)] + mu
    for weight in lam:
        valid = b.and_(valid, b.fcmp_ordered(">=", weight, c(0.0)))
    return lam, valid


_FUNCTIONS: dict[bool, object] = {}  # local -> ctypes function or None, built once per process


def _compiled_gjk(local: bool):
    """The compiled GJK (``local``: :func:`gjk_ir`'s local-frame variant) as a ctypes function,
    or None (kernels off, or the compile failed)."""
    if local not in _FUNCTIONS:
        # what the IR depends on: the files that write it and the tolerances it reads
        # (building the IR costs about 80 ms, so a cached kernel is looked up by these, not
        # by its IR)
        text = Path(__file__).read_text() + Path(kernel_ir.__file__).read_text()
        source = f"{text}|{RELATIVE_TOLERANCE!r}|{ABSOLUTE_TOLERANCE!r}|{'local' if local else ''}"
        name = "rworld_gjk_local" if local else "rworld_gjk"
        symbol = f"{name}_{hashlib.sha256(source.encode()).hexdigest()[:20]}"
        addresses = kernels.compile_ir(
            "GJK (local)" if local else "GJK", lambda: gjk_ir(symbol, local), [symbol], source
        )
        signature = GJK_LOCAL if local else GJK
        _FUNCTIONS[local] = None if addresses is None else prototype(signature)(addresses[0])
    return _FUNCTIONS[local]


def gjk_function():
    """The compiled GJK as a ctypes function, or None (kernels off, or the compile failed)."""
    return _compiled_gjk(False)


def gjk_local_function():
    """The compiled local-frame GJK (``gjk_ir(..., local=True)``) as a ctypes function, or None."""
    return _compiled_gjk(True)


def gjk_local(table_a, table_b, shape_a, shape_b, max_iterations: int) -> np.ndarray | None:
    """The cores' GJK for pairs of polytopes given as rows of tables in their own frames:
    (P, 12) rows as :func:`gjk`, or None when no compiled kernel is available.

    ``table_a`` = (vertices (R, V, 3) in the row's frame; neighbours (R, V, D) int64, each
    vertex's neighbours on the hull, -1 padded, row r's vertex 0 holding -2 first to scan
    every vertex, or None to scan every row; rows (P,) int64, each pair's row; poses (P, 12),
    R's rows then t, placing it in world).  ``shape_a`` (P, 9) as :func:`shape_rows` (a
    cylinder's own support is used where it is flagged).
    """
    if kernels.backend() != "llvm":
        return None
    function = gjk_local_function()
    if function is None:
        return None
    P = len(shape_a)
    out = np.empty((P, OUT_COLUMNS))
    if not P:
        return out

    # every array is held by a name until the call returns: the kernel reads raw addresses;
    # a table without neighbours is scanned (its count 0, one flag entry to read)
    def table(t):
        vertices, neighbours, rows, poses = t
        if neighbours is None:
            neighbours = np.full((1, 1, 1), -2, dtype=np.int64)
            return vertices, neighbours, rows, poses, 0
        return vertices, neighbours, rows, poses, np.shape(neighbours)[2]

    *a_arrays, degree_a = table(table_a)
    *b_arrays, degree_b = table(table_b)
    va, na, ra, pa = (np.ascontiguousarray(x) for x in a_arrays)
    vb, nb, rb, pb = (np.ascontiguousarray(x) for x in b_arrays)
    va, vb, pa, pb = (np.ascontiguousarray(x, dtype=float) for x in (va, vb, pa, pb))
    na, nb, ra, rb = (np.ascontiguousarray(x, dtype=np.int64) for x in (na, nb, ra, rb))
    sa = np.ascontiguousarray(shape_a, dtype=float)
    sb = np.ascontiguousarray(shape_b, dtype=float)
    function(
        P,
        va.shape[1],
        vb.shape[1],
        va.ctypes.data,
        vb.ctypes.data,
        sa.ctypes.data,
        sb.ctypes.data,
        out.ctypes.data,
        int(max_iterations),
        ra.ctypes.data,
        rb.ctypes.data,
        pa.ctypes.data,
        pb.ctypes.data,
        na.ctypes.data,
        nb.ctypes.data,
        degree_a,
        degree_b,
    )
    return out


def shape_rows(pieces) -> np.ndarray:
    """(P, 9) rows ``[cylinder, centre, axis, radius, half length]`` of :class:`Pieces`."""
    return np.column_stack(
        [
            pieces.cylinder.astype(float),
            pieces.center,
            pieces.axis,
            pieces.radius,
            pieces.half_length,
        ]
    )


def gjk(a, b, max_iterations: int) -> np.ndarray | None:
    """The cores' GJK for pairs ``a[k]``, ``b[k]``: (P, 11) rows (module docstring), or None
    when no compiled kernel is available."""
    if kernels.backend() != "llvm":  # RWORLD_KERNELS=numpy, or no llvmlite
        return None
    function = gjk_function()
    if function is None:
        return None
    P = len(a)
    out = np.empty((P, OUT_COLUMNS))
    if not P:
        return out
    arrays = [
        np.ascontiguousarray(a.vertices, dtype=float),
        np.ascontiguousarray(b.vertices, dtype=float),
        shape_rows(a),
        shape_rows(b),
    ]
    function(
        P,
        arrays[0].shape[1],
        arrays[1].shape[1],
        *[x.ctypes.data for x in arrays],
        out.ctypes.data,
        int(max_iterations),
    )
    return out
