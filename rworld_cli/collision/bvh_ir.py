"""The box trees' walks as LLVM IR text (compiled by :mod:`rworld_cli.collision.compiled_bvh`):
the separating-axis bound of node pairs, the descent to a leaf pair, the collision-only walk,
and the walk with its leaves measured by GJK.

Each kernel is a :class:`~rworld_cli.collision.kernel_ir.Kernel` of the signature named beside
it (the same tuple gives the caller's ctypes prototype); the walks share its counted loops, its
stack of node pairs (:class:`~rworld_cli.collision.kernel_ir.PairStack`) and the bound
(:meth:`~rworld_cli.collision.kernel_ir.Emit.gap`).
"""

from __future__ import annotations

import numpy as np

from .compiled import GJK_LOCAL
from .kernel_ir import DPTR, F64, I64, IPTR, LEAVES, TREE, Kernel, PairStack

# (Q, a, b, k, (tree a:) centre, half, axes, (tree b:) the same, R, t, out)
BOX_GAP = (I64, IPTR, IPTR, IPTR) + (DPTR,) * 9
# (Q, k, a, b, R, t, tree a, tree b)
DESCEND = (I64, IPTR, IPTR, IPTR, DPTR, DPTR) + TREE + TREE
# (K, limit, R, t, tree a, tree b, capacity, out_k, out_a, out_b, count)
TOUCHING = (I64, F64, DPTR, DPTR) + TREE + TREE + (I64, IPTR, IPTR, IPTR, IPTR)
# (K, limits, deep, R, t, tree a, tree b, leaves a, leaves b, max_iterations, status,
# nearest, witness)
CONTACTS = (I64, DPTR, F64, DPTR, DPTR) + TREE + TREE + LEAVES + LEAVES + (I64, IPTR, DPTR, DPTR)

BOX_BOUND_LEAVES = 8  # the walk bounds a hull against a node's box above this many leaves
WITNESS = 9  # doubles per state of contacts' witness: points (6), leaves (2), shallow depth
DIRECTIONS = 18  # convex.candidate_depth's: 3 + 3 axes, their 9 crosses, the centres, 2 normals


def box_gap_ir(symbol: str) -> str:
    """The LLVM IR text of :data:`BOX_GAP`: for each node pair q, the bound of nodes ``a[q]``
    of tree a and ``b[q]`` of tree b at state ``k[q]`` (``R`` (K, 9), ``t`` (K, 3):
    ``T_a_b``) into ``out[q]``."""
    k = Kernel("box_gap", symbol, BOX_GAP, noalias=True)
    Q, ia, ib, ik = k.args[:4]
    A, B = k.args[4:7], k.args[7:10]
    Rp, tp, out = k.args[10:]
    b = k.b
    done = k.block("done")
    q_slot, step = k.for_each(Q, "q", done)
    q = b.load(q_slot)
    Ua, hA, cA = k.node(A, k.load(ia, q))
    Ub, hB, cB = k.node(B, k.load(ib, q))
    R, t = k.state(Rp, tp, k.load(ik, q))
    b.store(k.gap(Ua, Ub, hA, hB, cA, cB, R, t), b.gep(out, [q]))
    b.branch(step)
    b.position_at_end(done)
    b.ret_void()
    return k.text()


def descend_ir(symbol: str) -> str:
    """The LLVM IR text of :data:`DESCEND`, the descent of :func:`rworld_cli.collision.bvh.
    candidates`: each row's node pair (``a[q]``, ``b[q]``, overwritten) is followed down to a
    leaf pair, always into the more promising child pair: the lower bound clamped at 0, ties
    broken by the nearer box centres (the first child pair on a full tie), as the numpy
    descent does."""
    k = Kernel("descend", symbol, DESCEND)
    Q, ik, ia, ib, Rp, tp = k.args[:6]
    A, B = k.args[6:12], k.args[12:18]
    b = k.b
    na_slot, nb_slot = k.slot(I64, "na"), k.slot(I64, "nb")
    finished = k.block("finished")
    q_slot, row_next = k.for_each(Q, "row", finished)
    q = b.load(q_slot)
    b.store(k.load(ia, q), na_slot)
    b.store(k.load(ib, q), nb_slot)
    step, split, row_done = k.block("step"), k.block("split"), k.block("row_done")
    b.branch(step)
    b.position_at_end(step)
    na, nb = b.load(na_slot), b.load(nb_slot)
    _, leaf_a = k.is_leaf(A, na)
    _, leaf_b = k.is_leaf(B, nb)
    b.cbranch(b.and_(leaf_a, leaf_b), row_done, split)
    b.position_at_end(split)
    R, t = k.state(Rp, tp, k.load(ik, q))
    _, hA, _ = k.node(A, na)
    _, hB, _ = k.node(B, nb)
    children = []
    for ca, cb in k.children(A, B, na, nb, leaf_a, leaf_b, hA, hB):
        Ua, ha, cA = k.node(A, ca)
        Ub, hb, cB = k.node(B, cb)
        gap = k.maximum(k.gap(Ua, Ub, ha, hb, cA, cB, R, t), k.c(0.0))
        near = k.length([b.fsub(x, cA[r]) for r, x in enumerate(k.apply(R, t, cB))])
        children.append((ca, cb, gap, near))
    (a1, b1, g1, c1), (a2, b2, g2, c2) = children
    first = b.or_(
        b.fcmp_ordered("<", g1, g2),
        b.and_(b.fcmp_ordered("==", g1, g2), b.fcmp_ordered("<=", c1, c2)),
    )
    b.store(b.select(first, a1, a2), na_slot)
    b.store(b.select(first, b1, b2), nb_slot)
    b.branch(step)
    b.position_at_end(row_done)
    b.store(b.load(na_slot), b.gep(ia, [q]))
    b.store(b.load(nb_slot), b.gep(ib, [q]))
    b.branch(row_next)
    b.position_at_end(finished)
    b.ret_void()
    return k.text()


def touching_ir(symbol: str) -> str:
    """The LLVM IR text of :data:`TOUCHING`, the collision-only traversal: for each state k,
    depth first from the roots: a node pair whose bound is above ``limit`` is dropped; a leaf
    pair is written (k, its items) while there is room, and counted in any case; an inner pair
    is split as :func:`rworld_cli.collision.bvh._split` splits it.  ``count`` -1: a tree
    deeper than the stack."""
    k = Kernel("touching", symbol, TOUCHING)
    K, limit, Rp, tp = k.args[:4]
    A, B = k.args[4:10], k.args[10:16]
    capacity, out_k, out_a, out_b, count_out = k.args[16:]
    b, i = k.b, k.i
    stack = PairStack(k)
    count_slot = k.slot(I64, "count", i(0))
    finished = k.block("finished")
    k_slot, state_next = k.for_each(K, "state", finished)
    stack.start()
    na, nb, _ = stack.pop(state_next)
    state = b.load(k_slot)
    Ua, hA, cA = k.node(A, na)
    Ub, hB, cB = k.node(B, nb)
    R, t = k.state(Rp, tp, state)
    near = k.block("near")
    gap = k.gap(Ua, Ub, hA, hB, cA, cB, R, t)
    b.cbranch(b.fcmp_ordered("<=", gap, limit), near, stack.next)  # NaN: dropped
    b.position_at_end(near)
    item_a, leaf_a = k.is_leaf(A, na)
    item_b, leaf_b = k.is_leaf(B, nb)
    emit, split = k.block("emit"), k.block("split")
    b.cbranch(b.and_(leaf_a, leaf_b), emit, split)
    # a leaf pair: written while there is room, counted always
    b.position_at_end(emit)
    count = b.load(count_slot)
    room, counted = k.block("room"), k.block("counted")
    b.cbranch(b.icmp_signed("<", count, capacity), room, counted)
    b.position_at_end(room)
    for out, value in ((out_k, state), (out_a, item_a), (out_b, item_b)):
        b.store(value, b.gep(out, [count]))
    b.branch(counted)
    b.position_at_end(counted)
    b.store(b.add(count, i(1)), count_slot)
    b.branch(stack.next)
    # an inner pair: the larger node's children (or the one that is not a leaf), left first
    b.position_at_end(split)
    first, second = k.children(A, B, na, nb, leaf_a, leaf_b, hA, hB)

    def overflow():  # the count marks the answer unusable
        b.store(i(-1), count_out)
        b.ret_void()

    stack.push_two(first, second, overflow)
    b.position_at_end(finished)
    b.store(b.load(count_slot), count_out)
    b.ret_void()
    return k.text()


def _polytope_depth(k: Kernel, a: tuple, b: tuple):
    """The depth of :func:`rworld_cli.collision.convex.candidate_depth` for two rows of leaf
    tables (exact for boxes and triangles, whose axes are complete): the least of ``hi_a -
    lo_b`` and ``hi_b - lo_a`` over the unit directions of each piece's three axes, their nine
    cross products, the centres' difference and each piece's first two axes crossed, those no
    shorter than 1e-9.  A side is (vertices table, V, row, pose (12 doubles: R's rows, then
    t), axes table (3 rows of 3 a row), centres table); the builder is left at the end of the
    emitted code, and the estimate returned."""
    b_, c, i = k.b, k.c, k.i

    def placed_side(side):
        table, V, row, pose, axes, centres = side
        Rt = [k.load(pose, i(j)) for j in range(12)]
        R, t = Rt[:9], Rt[9:]
        rows = [
            [k.load(axes, b_.add(b_.mul(row, i(9)), i(3 * r + m))) for m in range(3)]
            for r in range(3)
        ]
        turned = [k.rotate(R, x) for x in rows]
        local = [k.load(centres, b_.add(b_.mul(row, i(3)), i(m))) for m in range(3)]
        return turned, k.apply(R, t, local), R, t

    def cross(x, y):
        return [
            b_.fsub(b_.fmul(x[1], y[2]), b_.fmul(x[2], y[1])),
            b_.fsub(b_.fmul(x[2], y[0]), b_.fmul(x[0], y[2])),
            b_.fsub(b_.fmul(x[0], y[1]), b_.fmul(x[1], y[0])),
        ]

    def dot(x, y):
        return k.add(*[b_.fmul(x[j], y[j]) for j in range(3)])

    axes_a, centre_a, Ra, ta = placed_side(a)
    axes_b, centre_b, Rb, tb = placed_side(b)
    candidates = axes_a + axes_b + [cross(x, y) for x in axes_a for y in axes_b]
    candidates.append([b_.fsub(centre_b[j], centre_a[j]) for j in range(3)])
    # a triangle's normal: its first two edges crossed (a box: its third axis again)
    candidates += [cross(axes_a[0], axes_a[1]), cross(axes_b[0], axes_b[1])]
    units, goods = [], []
    for d in candidates:
        length = k.length(d)
        good = b_.fcmp_ordered(">", length, c(1e-9))
        units.append([b_.fdiv(x, b_.select(good, length, c(1.0))) for x in d])
        goods.append(good)
    extents = []
    for side, R, t in ((a, Ra, ta), (b, Rb, tb)):
        table, V, row, _, _, _ = side
        hi = k.array(F64, DIRECTIONS, "hi", [-np.inf] * DIRECTIONS)
        lo = k.array(F64, DIRECTIONS, "lo", [np.inf] * DIRECTIONS)
        done = k.block("extent_done")
        m_slot, step = k.for_each(V, "extent", done)
        m = b_.load(m_slot)
        base = b_.mul(b_.add(b_.mul(row, V), m), i(3))
        v = k.apply(R, t, [k.load(table, b_.add(base, i(j))) for j in range(3)])
        for j, unit in enumerate(units):
            value = dot(unit, v)
            h_ptr, l_ptr = k.cell(hi, j), k.cell(lo, j)
            b_.store(k.maximum(value, b_.load(h_ptr)), h_ptr)
            b_.store(k.minimum(value, b_.load(l_ptr)), l_ptr)
        b_.branch(step)
        b_.position_at_end(done)
        extents.append((hi, lo))
    (hi_a, lo_a), (hi_b, lo_b) = extents
    best = c(np.inf)
    for j in range(DIRECTIONS):
        ha, la = b_.load(k.cell(hi_a, j)), b_.load(k.cell(lo_a, j))
        hb, lb = b_.load(k.cell(hi_b, j)), b_.load(k.cell(lo_b, j))
        least = k.minimum(b_.fsub(hb, la), b_.fsub(ha, lb))
        least = b_.select(goods[j], least, c(np.inf))
        best = k.minimum(least, best)
    return best


def contacts_ir(symbol: str, gjk_symbol: str) -> str:
    """The LLVM IR text of :data:`CONTACTS`, the collision-only walk with its leaves measured in
    place.

    For each state k (``T_a_b`` = ``R[k]``, ``t[k]``), the walk of :func:`touching_ir` with the
    bound ``min(limit[k], the nearest distance measured so far)`` (branch and bound); each
    leaf pair it reaches is measured by ``gjk_symbol`` (:func:`rworld_cli.collision.compiled.
    gjk_ir` with ``local``, called for one pair): leaf ``item`` of a side is row ``item`` of its
    table (V vertices in the side's own frame, placed by its fixed ``pose``, 12 doubles, and for
    b then by the state's ``T_a_b``), climbed by its neighbours (D per vertex; 0: scanned).
    ``status[k]``: 0 no leaf pair overlaps, 1 one overlaps deeper than ``deep`` by GJK's depth
    bound or, where the bound says less and both leaves carry their axes (``estimate`` 1: rows
    of ``axes`` (3 x 3) and ``centres`` (3) in the table's frame: triangles and boxes, whose
    depths these make exact; 2: the leaf is a cylinder, measured by GJK's own support, with no
    depth here), by the depth of :func:`rworld_cli.collision.convex.candidate_depth`
    (:func:`_polytope_depth`; the walk of that state stops there), 2 some overlap is not known
    to be that deep (from the first overlap on, only leaf pairs whose boxes meet are walked: the
    state's distance is 0); ``nearest[k]``: the least distance of the leaf pairs measured that
    do not overlap (inf: none), exact for every pair within ``limit``; for status 1, minus that
    depth; for status 2, 0; ``witness[k]`` (:data:`WITNESS` doubles): that nearest pair's
    (status 2: the deepest overlap's) closest points in a's frame (6), its two leaf items (as
    doubles), then for status 2 the deepest overlap's depth estimate when every overlapping pair
    carries one (the depth the exact query reports), else NaN.  ``status[0]`` -1: a tree deeper
    than the stack (the caller falls back).

    An inner node's ``item`` is minus the number of leaves below it (:func:`rworld_cli.
    collision.compiled_bvh.walk_side`): a node of at least :data:`BOX_BOUND_LEAVES` met by a
    hull of more than 8 vertices is bounded by GJK between the hull and the node's box (8
    corners) before it is split - the two boxes' gap is loose where the hull's box stands off
    the hull (a round flange over a plate of many triangles: the walks of the TX2-60's tour 82
    -> 39 ms, the iiwa's 88 -> 62 ms), and below a few leaves the extra GJK costs more than it
    spares.
    """
    k = Kernel("contacts", symbol, CONTACTS)
    gjk = k.declare(gjk_symbol, GJK_LOCAL)
    K, limit, deep, Rp, tp = k.args[:5]
    A, B = k.args[5:11], k.args[11:17]
    VA, table_a, nbr_a, DA, pose_a, estimate_a, axes_a, centres_a = k.args[17:25]
    VB, table_b, nbr_b, DB, fixed_b, estimate_b, axes_b, centres_b = k.args[25:33]
    max_it, status_out, nearest_out, witness_out = k.args[33:]
    b, i, c = k.b, k.i, k.c
    stack = PairStack(k, bounds=True)
    status_slot = k.slot(I64, "status")
    nearest_slot = k.slot(F64, "nearest")
    row_a, row_b = k.slot(I64, "row_a"), k.slot(I64, "row_b")
    pose_b = k.array(F64, 12, "pose_b")
    depth_slot = k.slot(F64, "depth")
    shallow_slot = k.slot(F64, "shallow")  # the deepest shallow overlap's estimate
    # polytopes for GJK: no cylinder flag, axis z, no radius; the centres (1-3) per pair
    shape_a = k.array(F64, 9, "shape_a", (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0))
    shape_b = k.array(F64, 9, "shape_b", (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0))
    out = k.array(F64, 12, "out")
    # a node's box as a table of one row (8 corners, scanned) for the leaf-against-box bound,
    # with the poses that place it: a's frame (identity) or the state's T_a_b
    box_table = k.array(F64, 24, "box_table")
    box_row = k.slot(I64, "box_row", i(0))
    no_neighbours = k.slot(I64, "no_neighbours", i(-2))
    identity = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
    pose_identity = k.array(F64, 12, "pose_identity", identity)
    pose_state = k.array(F64, 12, "pose_state")
    finished, settled, state_done = k.block("finished"), k.block("settled"), k.block("state_done")
    k_slot, state_next = k.for_each(K, "state", finished)
    # a state: b's leaves placed by T_a_b o its fixed pose, the walk from the roots
    state = b.load(k_slot)
    R, t = k.state(Rp, tp, state)
    fixed = k.row(fixed_b, i(0), 12)
    Rf, tf = fixed[:9], fixed[9:]
    for col in range(3):
        column = k.rotate(R, [Rf[3 * m + col] for m in range(3)])
        for r in range(3):
            b.store(column[r], k.cell(pose_b, 3 * r + col))
    for r, value in enumerate(k.apply(R, t, tf)):
        b.store(value, k.cell(pose_b, 9 + r))
    for j, value in enumerate(R + t):
        b.store(value, k.cell(pose_state, j))
    b.store(i(0), status_slot)
    b.store(c(np.inf), nearest_slot)
    b.store(c(-1.0), shallow_slot)
    (Ua0, hA0, cA0), (Ub0, hB0, cB0) = k.node(A, i(0)), k.node(B, i(0))
    stack.start(k.gap(Ua0, Ub0, hA0, hB0, cA0, cB0, R, t))
    na, nb, gap = stack.pop(state_done)
    state = b.load(k_slot)
    near = k.block("near")
    # a pair farther than asked, or than a leaf pair already measured, cannot matter: the
    # nearest kept is exact up to the limit, and an overlap's box gap is at most 0
    bound = k.minimum(b.load(nearest_slot), k.load(limit, state))
    b.cbranch(b.fcmp_ordered("<=", gap, bound), near, stack.next)  # NaN: dropped
    b.position_at_end(near)
    UA, hA, cA = k.node(A, na)
    UB, hB, cB = k.node(B, nb)
    R, t = k.state(Rp, tp, state)
    item_a, leaf_a = k.is_leaf(A, na)
    item_b, leaf_b = k.is_leaf(B, nb)
    measure, split, inner = k.block("measure"), k.block("split"), k.block("inner")
    b.cbranch(b.and_(leaf_a, leaf_b), measure, inner)
    # a leaf against an inner node: GJK's lower bound between the leaf and the node's box (its
    # leaves lie in the box, so none is nearer) - much tighter than the two boxes' gap when the
    # leaf is a large hull whose box stands off it (a flange over a plate of many triangles);
    # a pair above the bound is dropped without descending
    b.position_at_end(inner)
    one_leaf, box_on_a, box_on_b = k.block("one_leaf"), k.block("box_on_a"), k.block("box_on_b")
    b.cbranch(b.xor(leaf_a, leaf_b), one_leaf, split)
    b.position_at_end(one_leaf)
    # only a hull's box stands off it (a triangle's or a box's is the leaf itself)
    many = i(-BOX_BOUND_LEAVES)
    hull_b = b.and_(b.icmp_signed(">", VB, i(8)), b.icmp_signed("<=", item_a, many))
    hull_a = b.and_(b.icmp_signed(">", VA, i(8)), b.icmp_signed("<=", item_b, many))
    hull_b, hull_a = b.and_(leaf_b, hull_b), b.and_(leaf_a, hull_a)
    pick = k.block("pick")
    b.cbranch(b.or_(hull_a, hull_b), pick, split)
    b.position_at_end(pick)
    b.cbranch(leaf_b, box_on_a, box_on_b)

    def centres_for_gjk():  # the boxes' centres, a's and b's placed: GJK's first direction
        for j, value in enumerate(k.apply(R, t, cB)):
            b.store(cA[j], k.cell(shape_a, 1 + j))
            b.store(value, k.cell(shape_b, 1 + j))

    def call_gjk(side_a, side_b, cylinders=(None, None)):
        """GJK of one leaf against one leaf (or a node's box): a side whose ``cylinders`` entry
        is given (its flag, table, pose) is a cylinder where that flag is set - GJK then takes
        its support from the shape row (centre, axis: the pose's z, radius, half length) -
        and a polytope of its table row elsewhere."""
        for shape, cylinder in zip((shape_a, shape_b), cylinders):
            if cylinder is None:
                b.store(c(0.0), k.cell(shape, 0))
                continue
            flag, table, pose = cylinder
            b.store(b.select(flag, c(1.0), c(0.0)), k.cell(shape, 0))
            placed = [k.load(pose, i(j)) for j in range(12)]
            old_centre = [b.load(k.cell(shape, 1 + j)) for j in range(3)]
            for j in range(3):  # the centre: the pose's origin; the axis: its z
                b.store(b.select(flag, placed[9 + j], old_centre[j]), k.cell(shape, 1 + j))
                b.store(
                    b.select(flag, placed[3 * j + 2], c(1.0 if j == 2 else 0.0)),
                    k.cell(shape, 4 + j),
                )
            for j in range(2):  # radius, half length: the table's one row
                b.store(b.select(flag, k.load(table, i(j)), c(0.0)), k.cell(shape, 7 + j))
        (Va, ta, ra, na_, da, pa), (Vb, tb, rb, nb_, db, pb) = side_a, side_b
        shapes = [k.first(shape_a, DPTR), k.first(shape_b, DPTR), k.first(out, DPTR)]
        b.call(gjk, [i(1), Va, Vb, ta, tb, *shapes, max_it, ra, rb, pa, pb, na_, nb_, da, db])

    def leaf_against_box(U, h, centre, box_side_a: bool):
        for corner in range(8):
            signs = [1.0 if corner >> axis & 1 else -1.0 for axis in range(3)]
            for j in range(3):
                value = k.add(
                    centre[j], *[b.fmul(c(signs[m]), b.fmul(h[m], U[3 * m + j])) for m in range(3)]
                )
                b.store(value, k.cell(box_table, 3 * corner + j))
        centres_for_gjk()
        box = (i(8), k.first(box_table, DPTR), box_row, no_neighbours, i(0))
        if box_side_a:
            b.store(item_b, row_b)
            side_a = box + (k.first(pose_identity, DPTR),)
            side_b = (VB, table_b, row_b, nbr_b, DB, k.first(pose_b, DPTR))
        else:
            b.store(item_a, row_a)
            side_a = (VA, table_a, row_a, nbr_a, DA, pose_a)
            side_b = box + (k.first(pose_state, DPTR),)
        call_gjk(side_a, side_b)
        apart = b.fcmp_ordered("==", b.load(k.cell(out, 7)), c(0.0))
        lower = b.load(k.cell(out, 9))  # GJK's last lower bound (NaN: none, the pair is kept)
        far = b.and_(apart, b.fcmp_ordered(">", lower, bound))
        b.cbranch(far, stack.next, split)

    b.position_at_end(box_on_a)
    leaf_against_box(UA, hA, cA, True)
    b.position_at_end(box_on_b)
    leaf_against_box(UB, hB, cB, False)
    # a leaf pair: GJK on the two rows, a's in its frame, b's placed
    b.position_at_end(measure)
    b.store(item_a, row_a)
    b.store(item_b, row_b)
    centres_for_gjk()
    call_gjk(
        (VA, table_a, row_a, nbr_a, DA, pose_a),
        (VB, table_b, row_b, nbr_b, DB, k.first(pose_b, DPTR)),
        (
            (b.icmp_signed("==", estimate_a, i(2)), table_a, pose_a),
            (b.icmp_signed("==", estimate_b, i(2)), table_b, k.first(pose_b, DPTR)),
        ),
    )
    overlap = b.fcmp_ordered("!=", b.load(k.cell(out, 7)), c(0.0))
    unfinished = b.fcmp_ordered("!=", b.load(k.cell(out, 10)), c(0.0))
    distance = b.select(unfinished, b.load(k.cell(out, 9)), b.load(k.cell(out, 0)))
    bound_depth = b.load(k.cell(out, 11))
    deeper = b.and_(overlap, b.fcmp_ordered(">", bound_depth, deep))
    collided, measured = k.block("collided"), k.block("measured")
    estimating = k.block("estimating")
    b.store(bound_depth, depth_slot)
    # an overlap GJK's simplex bounds too little (two crossing triangles leave it little
    # volume): where both leaves carry their axes (triangles, boxes), the depth of
    # convex.candidate_depth (the least overlap over the pieces' axes, their cross products,
    # their normals and the centres' difference: exact for them) decides, as the exact query
    # would
    both = b.and_(b.icmp_signed("==", estimate_a, i(1)), b.icmp_signed("==", estimate_b, i(1)))
    shallow = b.and_(b.and_(overlap, b.not_(deeper)), both)
    b.cbranch(deeper, collided, measured)
    b.position_at_end(measured)
    b.cbranch(shallow, estimating, settled)
    b.position_at_end(estimating)
    estimate = _polytope_depth(
        k,
        (table_a, VA, item_a, pose_a, axes_a, centres_a),
        (table_b, VB, item_b, k.first(pose_b, DPTR), axes_b, centres_b),
    )
    b.store(estimate, depth_slot)
    b.cbranch(b.fcmp_ordered(">", estimate, deep), collided, settled)
    b.position_at_end(collided)
    b.store(i(1), status_slot)
    b.store(b.fneg(b.load(depth_slot)), nearest_slot)
    b.branch(state_done)
    b.position_at_end(settled)
    b.store(b.select(overlap, i(2), b.load(status_slot)), status_slot)
    kept = b.load(nearest_slot)
    nearer = b.and_(b.not_(overlap), b.fcmp_ordered("<", distance, kept))
    record, overlapped = k.block("record"), k.block("overlapped")
    not_overlapped = k.block("not_overlapped")
    b.cbranch(overlap, overlapped, not_overlapped)
    b.position_at_end(not_overlapped)
    b.cbranch(nearer, record, stack.next)

    def keep_witness():
        base = b.mul(b.load(k_slot), i(WITNESS))
        for j in range(6):
            b.store(b.load(k.cell(out, 1 + j)), b.gep(witness_out, [b.add(base, i(j))]))
        b.store(b.sitofp(b.load(row_a), k.D), b.gep(witness_out, [b.add(base, i(6))]))
        b.store(b.sitofp(b.load(row_b), k.D), b.gep(witness_out, [b.add(base, i(7))]))
        b.branch(stack.next)

    # the nearest so far: its distance, closest points and leaves
    b.position_at_end(record)
    b.store(distance, nearest_slot)
    keep_witness()
    # an overlap not deeper than asked: the state's distance is 0, so only the pairs whose
    # boxes meet can matter from here (the bound drops to 0); the deepest of them by the
    # estimate is kept with its points (NaN once one has no estimate: the exact query decides)
    b.position_at_end(overlapped)
    b.store(c(0.0), nearest_slot)
    depth_here = b.load(depth_slot)
    so_far = b.load(shallow_slot)
    undecided = b.fcmp_unordered("uno", so_far, so_far)
    deepest = b.and_(b.and_(both, b.not_(undecided)), b.fcmp_ordered(">", depth_here, so_far))
    b.store(b.select(both, b.select(deepest, depth_here, so_far), c(np.nan)), shallow_slot)
    record_overlap = k.block("record_overlap")
    b.cbranch(deepest, record_overlap, stack.next)
    b.position_at_end(record_overlap)
    keep_witness()
    # an inner pair: split as the collision-only walk does; both child pairs' bounds, the
    # nearer looked at first (the nearest found early prunes more; the left one on a tie)
    b.position_at_end(split)
    children = []
    for ca, cb in k.children(A, B, na, nb, leaf_a, leaf_b, hA, hB):
        Ua2, ha2, ca2 = k.node(A, ca)
        Ub2, hb2, cb2 = k.node(B, cb)
        children.append((ca, cb, k.gap(Ua2, Ub2, ha2, hb2, ca2, cb2, R, t)))
    one, two = children
    first_near = b.fcmp_ordered("<=", one[2], two[2])
    first = [b.select(first_near, x, y) for x, y in zip(one, two)]
    second = [b.select(first_near, y, x) for x, y in zip(one, two)]

    def overflow():
        b.store(i(-1), status_out)
        b.ret_void()

    stack.push_two(first, second, overflow)
    b.position_at_end(state_done)
    state = b.load(k_slot)
    b.store(b.load(status_slot), b.gep(status_out, [state]))
    b.store(b.load(nearest_slot), b.gep(nearest_out, [state]))
    b.store(b.load(shallow_slot), b.gep(witness_out, [b.add(b.mul(state, i(WITNESS)), i(8))]))
    b.branch(state_next)
    b.position_at_end(finished)
    b.ret_void()
    return k.text()
