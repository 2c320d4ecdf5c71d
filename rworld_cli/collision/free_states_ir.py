"""A configuration check of many pairs of bodies at many states as LLVM IR text (compiled by
:mod:`rworld_cli.collision.compiled_bvh`): each pair's bounding spheres first, then the walk of
:func:`rworld_cli.collision.bvh_ir.contacts_ir` for one state, in one call for all states."""

from __future__ import annotations

import numpy as np

from .bvh_ir import CONTACTS
from .kernel_ir import DPTR, F64, I64, IPTR, LEAVES, TREE, Kernel, llvm_type

BODY_WORDS = 14  # a body's row of the table free_states reads: 6 tree arrays, 8 leaf fields
# (N, P, pairs, B, poses, bodies, spheres, boxes, limit, deep, max_iterations, status,
# nearest, witness)
FREE_STATES = (I64, I64, IPTR, I64, DPTR, IPTR, DPTR, DPTR, F64, F64, I64, IPTR, DPTR, DPTR)
# (R, rows, B, poses, bodies, spheres, boxes, limits, deep, max_iterations, status, nearest,
# witness)
PAIR_ROWS = (I64, IPTR, I64, DPTR, IPTR, DPTR, DPTR, DPTR, F64, I64, IPTR, DPTR, DPTR)


def free_states_ir(symbol: str, contacts_symbol: str, rows: bool = False) -> str:
    """The LLVM IR text of :data:`FREE_STATES`, a configuration check of many pairs of bodies at
    N states.

    ``pairs`` (P, 2) int64 body indices, in the order to try them; ``poses`` (N, B, 12) each
    body's frame in world (R's rows, then t); ``bodies`` (B, :data:`BODY_WORDS`) int64: the
    addresses of its tree's six arrays, then its leaf table's V, table address, neighbours
    address, D, pose address, estimate flag, axes and centres addresses (:func:`rworld_cli.
    collision.compiled_bvh.walk_side`); ``spheres`` (B, 4): each body's bounding sphere
    (centre in its frame, radius); ``boxes`` (B, 9): a closed mesh's box in its frame (least
    and greatest corner; +inf and -inf for other bodies) and each body's witness point
    (:attr:`~rworld_cli.collision.bodies.Body.first_point`).  For each state, pair after pair:
    a pair whose bounding spheres are farther apart than ``limit`` is 3 with inf; another is
    walked by ``contacts_symbol`` (:func:`rworld_cli.collision.bvh_ir.contacts_ir`, one state)
    and its status and nearest written (``nearest`` (N, P), ``status`` (N, P): 0, 1, 2 as
    there, -1 a tree too deep); after a pair of status 1 the state's other pairs are skipped
    (status -2); a pair of status 0 one of whose witness points lies in the other's
    closed-mesh box is 4 (the caller's winding number decides whether it is buried).
    ``witness``: :data:`~rworld_cli.collision.bvh_ir.WITNESS` doubles of scratch.

    ``rows`` (:data:`PAIR_ROWS`): the same for R rows of their own (what a segment check asks:
    each pair at its own state, exact up to its own limit), no row skipped: ``rows`` (R, 3)
    int64: the state (a row of ``poses``) and the two bodies; ``limits`` (R,); ``status`` and
    ``nearest`` (R,).
    """
    k = Kernel("free_states", symbol, PAIR_ROWS if rows else FREE_STATES)
    contacts = k.declare(contacts_symbol, CONTACTS)
    if rows:
        R, row_table, B, poses, bodies, spheres, boxes, limits, deep, max_it = k.args[:10]
    else:
        N, P, pairs, B, poses, bodies, spheres, boxes, limit, deep, max_it = k.args[:11]
    status_out, nearest_out, witness = k.args[-3:]
    b, i, c = k.b, k.i, k.c
    hit_slot = k.slot(I64, "hit", i(0))
    limit_slot = k.slot(F64, "limit")
    R_slot, t_slot = k.array(F64, 9, "R"), k.array(F64, 3, "t")
    st_slot, near_slot = k.slot(I64, "status"), k.slot(F64, "nearest")
    finished = k.block("finished")
    if rows:  # one loop over the rows, each its own state, bodies and limit
        r_slot, pair_next = k.for_each(R, "row", finished)
        r = b.load(r_slot)
        n, ia, ib = k.row(row_table, b.mul(r, i(3)), 3)
        out_index = r
        b.store(k.load(limits, r), limit_slot)
    else:  # states, and in each the pairs until one collides
        b.store(limit, limit_slot)
        n_slot, state_next = k.for_each(N, "state", finished)
        b.store(i(0), hit_slot)
        p_slot, pair_next = k.for_each(P, "pair", state_next)
        n, p = b.load(n_slot), b.load(p_slot)
        out_index = b.add(b.mul(n, P), p)
        skipped, looked = k.block("skipped"), k.block("looked")
        b.cbranch(b.icmp_signed("!=", b.load(hit_slot), i(0)), skipped, looked)
        b.position_at_end(skipped)  # the state collides already: the rest is not asked
        b.store(i(-2), b.gep(status_out, [out_index]))
        b.store(c(np.inf), b.gep(nearest_out, [out_index]))
        b.branch(pair_next)
        b.position_at_end(looked)
        ia, ib = k.row(pairs, b.mul(p, i(2)), 2)
    limit_here = b.load(limit_slot)
    pose_a = k.row(poses, b.mul(b.add(b.mul(n, B), ia), i(12)), 12)
    pose_b = k.row(poses, b.mul(b.add(b.mul(n, B), ib), i(12)), 12)
    Ra, ta, Rb, tb = pose_a[:9], pose_a[9:], pose_b[:9], pose_b[9:]
    sa = k.row(spheres, b.mul(ia, i(4)), 4)
    sb = k.row(spheres, b.mul(ib, i(4)), 4)
    ca, cb = k.apply(Ra, ta, sa[:3]), k.apply(Rb, tb, sb[:3])
    apart = b.fsub(k.length([b.fsub(ca[r], cb[r]) for r in range(3)]), b.fadd(sa[3], sb[3]))
    far, walk = k.block("far"), k.block("walk")
    b.cbranch(b.fcmp_ordered(">", apart, limit_here), far, walk)
    b.position_at_end(far)
    b.store(i(3), b.gep(status_out, [out_index]))
    b.store(c(np.inf), b.gep(nearest_out, [out_index]))
    b.branch(pair_next)
    # T_a_b = inv(Ta) Tb: R = Ra^T Rb, t = Ra^T (tb - ta)
    b.position_at_end(walk)
    Ra_T = [Ra[3 * m + r] for r in range(3) for m in range(3)]
    for col in range(3):
        for r, value in enumerate(k.rotate(Ra_T, [Rb[3 * m + col] for m in range(3)])):
            b.store(value, k.cell(R_slot, 3 * r + col))
    for r, value in enumerate(k.rotate(Ra_T, [b.fsub(tb[m], ta[m]) for m in range(3)])):
        b.store(value, k.cell(t_slot, r))

    def word(body, j):
        return k.load(bodies, b.add(b.mul(body, i(BODY_WORDS)), i(j)))

    def side(body):
        # the words in the order of TREE, then LEAVES: addresses made pointers, counts as they are
        typed = [
            word(body, j) if kind == I64 else b.inttoptr(word(body, j), llvm_type(kind))
            for j, kind in enumerate(TREE + LEAVES)
        ]
        return typed[:6], typed[6:]

    tree_a, leaf_a = side(ia)
    tree_b, leaf_b = side(ib)
    head = [i(1), limit_slot, deep, k.cell(R_slot, 0), k.cell(t_slot, 0)]
    tail = [max_it, st_slot, near_slot, witness]
    b.call(contacts, head + tree_a + tree_b + leaf_a + leaf_b + tail)
    status = b.load(st_slot)
    # clear of each other's surfaces: a witness point in the other's closed-mesh box?
    Rr = [b.load(k.cell(R_slot, j)) for j in range(9)]
    t = [b.load(k.cell(t_slot, j)) for j in range(3)]
    box_a = k.row(boxes, b.mul(ia, i(9)), 9)
    box_b = k.row(boxes, b.mul(ib, i(9)), 9)

    def inside(point, box):
        flags = [
            b.and_(
                b.fcmp_ordered(">=", point[j], box[j]), b.fcmp_ordered("<=", point[j], box[3 + j])
            )
            for j in range(3)
        ]
        return b.and_(b.and_(flags[0], flags[1]), flags[2])

    in_a = k.apply(Rr, t, box_b[6:9])  # b's witness in a's frame: R w + t
    w_a = box_a[6:9]  # a's witness in b's frame: R^T (w - t)
    Rr_T = [Rr[3 * m + r] for r in range(3) for m in range(3)]
    in_b = k.rotate(Rr_T, [b.fsub(w_a[m], t[m]) for m in range(3)])
    boxed = b.or_(inside(in_a, box_a), inside(in_b, box_b))
    status = b.select(b.and_(b.icmp_signed("==", status, i(0)), boxed), i(4), status)
    b.store(status, b.gep(status_out, [out_index]))
    b.store(b.load(near_slot), b.gep(nearest_out, [out_index]))
    if not rows:
        b.store(b.zext(b.icmp_signed("==", status, i(1)), k.I64), hit_slot)
    b.branch(pair_next)
    b.position_at_end(finished)
    b.ret_void()
    return k.text()
