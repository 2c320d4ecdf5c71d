"""The box trees' separating-axis bound compiled to machine code: :func:`rworld_cli.collision.
bvh.box_gap` for a batch of node pairs in one call.

Why: the numpy bound makes some fifty temporary arrays of the batch's size (3 x 3 products,
the nine edge axes), so a node pair costs about a microsecond; the search of a vendor's link
against a fixture visits thousands per state.  Here the same arithmetic is one LLVM function:
a loop over the node pairs, each node's box and the state's pose read by index, every value in
a register.  Compiled through :func:`rworld_cli.kernels.compile_ir` (llvmlite; cached on disk;
``RWORLD_KERNELS=numpy`` or a failed compile fall back to the numpy bound, which it equals to
rounding: ``tests/collision/test_bvh.py``).

Arguments, per node pair q: ``a[q]``, ``b[q]`` the nodes (int64), ``k[q]`` the state (int64);
per node: ``centre`` (N, 3), ``half`` (N, 3), ``axes`` (N, 9: the rows of its box axes); per
state: ``R`` (K, 9) and ``t`` (K, 3), ``T_a_b``; out (Q,).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from .. import kernels


class _Emit:
    """Scalar arithmetic on an llvmlite IR builder: what the bound is written with."""

    def __init__(self, b, module):
        import llvmlite.ir as ir

        self.b, self.ir = b, ir
        D = ir.DoubleType()
        self.sqrt = module.declare_intrinsic("llvm.sqrt", [D])
        self.fabs = module.declare_intrinsic("llvm.fabs", [D])
        self.D, self.I64 = D, ir.IntType(64)

    def c(self, x: float):
        return self.ir.Constant(self.D, float(x))

    def i(self, x: int):
        return self.ir.Constant(self.I64, int(x))

    def row(self, pointer, base, count):
        b = self.b
        return [b.load(b.gep(pointer, [b.add(base, self.i(j))])) for j in range(count)]

    def add(self, *xs):
        total = xs[0]
        for x in xs[1:]:
            total = self.b.fadd(total, x)
        return total

    def maximum(self, x, y):
        return self.b.select(self.b.fcmp_ordered(">", x, y), x, y)

    def gap(self, Ua, Ub, hA, hB, cA, cB, R, t):
        """The bound of :func:`rworld_cli.collision.bvh.box_gap` for one node pair: a's box
        axes ``Ua`` (9, rows), half extents ``hA`` and centre ``cA``; the same of b; ``R`` (9)
        and ``t`` (3), b's frame in a's."""
        b, c, add, maximum = self.b, self.c, self.add, self.maximum
        mul, sub = b.fmul, b.fsub

        def absolute(x):
            return b.call(self.fabs, [x])

        # W = R Ub^T (3 x 3): W[i][j] = sum_l R[i][l] Ub[j][l]; M = Ua W
        W = [
            [add(*[mul(R[3 * i + m], Ub[3 * j + m]) for m in range(3)]) for j in range(3)]
            for i in range(3)
        ]
        M = [
            [add(*[mul(Ua[3 * i + m], W[m][j]) for m in range(3)]) for j in range(3)]
            for i in range(3)
        ]
        # p = Ua (R cB + t - cA)
        world = [
            sub(add(*[mul(R[3 * i + m], cB[m]) for m in range(3)], t[i]), cA[i]) for i in range(3)
        ]
        p = [add(*[mul(Ua[3 * i + m], world[m]) for m in range(3)]) for i in range(3)]
        absM = [[absolute(M[i][j]) for j in range(3)] for i in range(3)]
        along_a = [
            sub(sub(absolute(p[i]), hA[i]), add(*[mul(absM[i][j], hB[j]) for j in range(3)]))
            for i in range(3)
        ]
        along_b = [
            sub(
                sub(absolute(add(*[mul(p[i], M[i][j]) for i in range(3)])), hB[j]),
                add(*[mul(hA[i], absM[i][j]) for i in range(3)]),
            )
            for j in range(3)
        ]

        def apart(values):
            clipped = [maximum(v, c(0.0)) for v in values]
            return b.call(self.sqrt, [add(*[mul(x, x) for x in clipped])])

        apart_a, apart_b = apart(along_a), apart(along_b)
        # the nine edge-edge axes, as in bvh.box_gap
        i1, i2 = [1, 2, 0], [2, 0, 1]
        absE = [[b.fadd(absM[i][j], c(1e-12)) for j in range(3)] for i in range(3)]
        edge = c(-np.inf)
        for i in range(3):
            for j in range(3):
                reach_a = add(mul(hA[i1[i]], absE[i2[i]][j]), mul(hA[i2[i]], absE[i1[i]][j]))
                reach_b = add(mul(hB[i1[j]], absE[i][i2[j]]), mul(hB[i2[j]], absE[i][i1[j]]))
                across = absolute(sub(mul(p[i2[i]], M[i1[i]][j]), mul(p[i1[i]], M[i2[i]][j])))
                length = b.call(self.sqrt, [maximum(sub(c(1.0), mul(M[i][j], M[i][j])), c(0.0))])
                gap = b.fdiv(sub(sub(across, reach_a), reach_b), maximum(length, c(1e-6)))
                gap = b.select(b.fcmp_ordered(">", length, c(1e-6)), gap, c(-np.inf))
                edge = maximum(edge, gap)
        inside = maximum(
            maximum(maximum(*along_a[:2]), along_a[2]), maximum(maximum(*along_b[:2]), along_b[2])
        )
        inside = maximum(inside, edge)
        return b.select(
            b.fcmp_ordered(">", inside, c(0.0)), maximum(maximum(apart_a, apart_b), edge), inside
        )

    def node(self, centre, half, axes, index):
        """A node's (axes (9), half extents (3), centre (3))."""
        b = self.b
        return (
            self.row(axes, b.mul(index, self.i(9)), 9),
            self.row(half, b.mul(index, self.i(3)), 3),
            self.row(centre, b.mul(index, self.i(3)), 3),
        )


def box_gap_ir(symbol: str) -> str:
    """The LLVM IR text of ``void f(i64 Q, ptr a, ptr b, ptr k, ptr centre_a, ptr half_a, ptr
    axes_a, ptr centre_b, ptr half_b, ptr axes_b, ptr R, ptr t, ptr out)``."""
    import llvmlite.ir as ir

    D, I64 = ir.DoubleType(), ir.IntType(64)
    dptr, iptr = ir.PointerType(D), ir.PointerType(I64)
    module = ir.Module(name="box_gap")
    fn = ir.Function(
        module,
        ir.FunctionType(ir.VoidType(), [I64, iptr, iptr, iptr] + [dptr] * 9),
        name=symbol,
    )
    Q, ia, ib, ik, ca, ha, ua, cb, hb, ub, Rp, tp, out = fn.args
    for arg in fn.args[1:]:
        arg.add_attribute("noalias")
    entry = fn.append_basic_block("entry")
    head = fn.append_basic_block("head")
    body = fn.append_basic_block("body")
    done = fn.append_basic_block("done")
    b = ir.IRBuilder(entry)
    e = _Emit(b, module)
    b.branch(head)
    b.position_at_end(head)
    q = b.phi(I64, name="q")
    q.add_incoming(e.i(0), entry)
    b.cbranch(b.icmp_signed("<", q, Q), body, done)
    b.position_at_end(body)
    a = b.load(b.gep(ia, [q]))
    bb = b.load(b.gep(ib, [q]))
    k = b.load(b.gep(ik, [q]))
    Ua, hA, cA = e.node(ca, ha, ua, a)
    Ub, hB, cB = e.node(cb, hb, ub, bb)
    R = e.row(Rp, b.mul(k, e.i(9)), 9)
    t = e.row(tp, b.mul(k, e.i(3)), 3)
    b.store(e.gap(Ua, Ub, hA, hB, cA, cB, R, t), b.gep(out, [q]))
    q.add_incoming(b.add(q, e.i(1)), b.block)
    b.branch(head)
    b.position_at_end(done)
    b.ret_void()
    return str(module)


def descend_ir(symbol: str) -> str:
    """The LLVM IR text of the descent of :func:`rworld_cli.collision.bvh.candidates`:

    ``void f(i64 Q, ptr k, ptr a, ptr b, ptr R, ptr t, (tree a:) ptr centre, ptr half,
    ptr axes, ptr left, ptr right, ptr item, (tree b: the same six))``

    Each row's node pair (``a[q]``, ``b[q]``, overwritten) is followed down to a leaf pair,
    always into the more promising child pair: the lower bound clamped at 0, ties broken by
    the nearer box centres (the first child pair on a full tie), as the numpy descent does.
    """
    import llvmlite.ir as ir

    D, I64 = ir.DoubleType(), ir.IntType(64)
    dptr, iptr = ir.PointerType(D), ir.PointerType(I64)
    module = ir.Module(name="descend")
    tree = [dptr, dptr, dptr, iptr, iptr, iptr]
    fn = ir.Function(
        module,
        ir.FunctionType(ir.VoidType(), [I64, iptr, iptr, iptr, dptr, dptr] + tree + tree),
        name=symbol,
    )
    Q, ik, ia, ib, Rp, tp = fn.args[:6]
    A, B = fn.args[6:12], fn.args[12:18]
    entry = fn.append_basic_block("entry")
    b = ir.IRBuilder(entry)
    e = _Emit(b, module)
    i = e.i
    q_slot, na_slot, nb_slot = (b.alloca(I64, name=n) for n in ("q", "na", "nb"))
    b.store(i(0), q_slot)
    row_head = fn.append_basic_block("row_head")
    row_body = fn.append_basic_block("row_body")
    step = fn.append_basic_block("step")
    split = fn.append_basic_block("split")
    row_done = fn.append_basic_block("row_done")
    finished = fn.append_basic_block("finished")
    b.branch(row_head)
    b.position_at_end(row_head)
    q = b.load(q_slot)
    b.cbranch(b.icmp_signed("<", q, Q), row_body, finished)
    b.position_at_end(row_body)
    b.store(b.load(b.gep(ia, [q])), na_slot)
    b.store(b.load(b.gep(ib, [q])), nb_slot)
    b.branch(step)
    b.position_at_end(step)
    q = b.load(q_slot)
    na, nb = b.load(na_slot), b.load(nb_slot)
    leaf_a = b.icmp_signed(">=", b.load(b.gep(A[5], [na])), i(0))
    leaf_b = b.icmp_signed(">=", b.load(b.gep(B[5], [nb])), i(0))
    b.cbranch(b.and_(leaf_a, leaf_b), row_done, split)
    b.position_at_end(split)
    k = b.load(b.gep(ik, [q]))
    R = e.row(Rp, b.mul(k, i(9)), 9)
    t = e.row(tp, b.mul(k, i(3)), 3)
    _, hA, _ = e.node(A[0], A[1], A[2], na)
    _, hB, _ = e.node(B[0], B[1], B[2], nb)
    split_a = b.and_(b.not_(leaf_a), b.or_(leaf_b, b.fcmp_ordered(">=", e.add(*hA), e.add(*hB))))
    children = []
    for side in (3, 4):  # left, then right
        ca = b.select(split_a, b.load(b.gep(A[side], [na])), na)
        cb = b.select(split_a, nb, b.load(b.gep(B[side], [nb])))
        Ua, ha, cA = e.node(A[0], A[1], A[2], ca)
        Ub, hb, cB = e.node(B[0], B[1], B[2], cb)
        gap = e.maximum(e.gap(Ua, Ub, ha, hb, cA, cB, R, t), e.c(0.0))
        placed = [
            b.fsub(e.add(*[b.fmul(R[3 * r + m], cB[m]) for m in range(3)], t[r]), cA[r])
            for r in range(3)
        ]
        near = b.call(e.sqrt, [e.add(*[b.fmul(x, x) for x in placed])])
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
    q = b.load(q_slot)
    b.store(b.load(na_slot), b.gep(ia, [q]))
    b.store(b.load(nb_slot), b.gep(ib, [q]))
    b.store(b.add(q, i(1)), q_slot)
    b.branch(row_head)
    b.position_at_end(finished)
    b.ret_void()
    return str(module)


BOX_BOUND_LEAVES = 8  # the walk bounds a hull against a node's box above this many leaves
WITNESS = 9  # doubles per state of contacts' witness: points (6), leaves (2), shallow depth
STACK = 512  # node pairs pending in the traversal: depth of both trees at the most, with room


def touching_ir(symbol: str) -> str:
    """The LLVM IR text of the collision-only traversal:

    ``void f(i64 K, double limit, ptr R, ptr t, (tree a:) ptr centre, ptr half, ptr axes,
    ptr left, ptr right, ptr item, (tree b: the same six), i64 capacity, ptr out_k, ptr
    out_a, ptr out_b, ptr count)``

    For each state k, depth first from the roots: a node pair whose bound is above ``limit``
    is dropped; a leaf pair is written (k, its items) while there is room, and counted in any
    case; an inner pair is split as :func:`rworld_cli.collision.bvh._split` splits it (the
    node with the larger box, or the one that is not a leaf).
    """
    import llvmlite.ir as ir

    D, I64 = ir.DoubleType(), ir.IntType(64)
    dptr, iptr = ir.PointerType(D), ir.PointerType(I64)
    module = ir.Module(name="touching")
    tree = [dptr, dptr, dptr, iptr, iptr, iptr]
    fn = ir.Function(
        module,
        ir.FunctionType(
            ir.VoidType(), [I64, D, dptr, dptr] + tree + tree + [I64, iptr, iptr, iptr, iptr]
        ),
        name=symbol,
    )
    K, limit, Rp, tp = fn.args[:4]
    A = fn.args[4:10]
    B = fn.args[10:16]
    capacity, out_k, out_a, out_b, count_out = fn.args[16:]
    entry = fn.append_basic_block("entry")
    b = ir.IRBuilder(entry)
    e = _Emit(b, module)
    i = e.i
    stack_a = b.alloca(ir.ArrayType(I64, STACK), name="stack_a")
    stack_b = b.alloca(ir.ArrayType(I64, STACK), name="stack_b")
    top_slot = b.alloca(I64, name="top")
    count_slot = b.alloca(I64, name="count")
    k_slot = b.alloca(I64, name="k")
    b.store(i(0), count_slot)
    b.store(i(0), k_slot)
    state_head = fn.append_basic_block("state_head")
    state_body = fn.append_basic_block("state_body")
    pop_head = fn.append_basic_block("pop_head")
    pop_body = fn.append_basic_block("pop_body")
    state_next = fn.append_basic_block("state_next")
    finished = fn.append_basic_block("finished")
    b.branch(state_head)
    b.position_at_end(state_head)
    k = b.load(k_slot)
    b.cbranch(b.icmp_signed("<", k, K), state_body, finished)
    b.position_at_end(state_body)
    b.store(i(0), b.gep(stack_a, [i(0), i(0)]))
    b.store(i(0), b.gep(stack_b, [i(0), i(0)]))
    b.store(i(1), top_slot)
    b.branch(pop_head)
    b.position_at_end(pop_head)
    top = b.load(top_slot)
    b.cbranch(b.icmp_signed(">", top, i(0)), pop_body, state_next)
    b.position_at_end(pop_body)
    k = b.load(k_slot)
    top = b.sub(b.load(top_slot), i(1))
    b.store(top, top_slot)
    na = b.load(b.gep(stack_a, [i(0), top]))
    nb = b.load(b.gep(stack_b, [i(0), top]))
    Ua, hA, cA = e.node(A[0], A[1], A[2], na)
    Ub, hB, cB = e.node(B[0], B[1], B[2], nb)
    R = e.row(Rp, b.mul(k, i(9)), 9)
    t = e.row(tp, b.mul(k, i(3)), 3)
    gap = e.gap(Ua, Ub, hA, hB, cA, cB, R, t)
    near = fn.append_basic_block("near")
    b.cbranch(b.fcmp_ordered("<=", gap, limit), near, pop_head)  # NaN: dropped
    b.position_at_end(near)
    item_a = b.load(b.gep(A[5], [na]))
    item_b = b.load(b.gep(B[5], [nb]))
    leaf_a = b.icmp_signed(">=", item_a, i(0))
    leaf_b = b.icmp_signed(">=", item_b, i(0))
    emit = fn.append_basic_block("emit")
    split = fn.append_basic_block("split")
    b.cbranch(b.and_(leaf_a, leaf_b), emit, split)
    # a leaf pair: written while there is room, counted always
    b.position_at_end(emit)
    count = b.load(count_slot)
    room = fn.append_basic_block("room")
    counted = fn.append_basic_block("counted")
    b.cbranch(b.icmp_signed("<", count, capacity), room, counted)
    b.position_at_end(room)
    b.store(k, b.gep(out_k, [count]))
    b.store(item_a, b.gep(out_a, [count]))
    b.store(item_b, b.gep(out_b, [count]))
    b.branch(counted)
    b.position_at_end(counted)
    b.store(b.add(count, i(1)), count_slot)
    b.branch(pop_head)
    # an inner pair: the larger node's children (or the one that is not a leaf)
    b.position_at_end(split)
    size_a = e.add(*hA)
    size_b = e.add(*hB)
    split_a = b.and_(b.not_(leaf_a), b.or_(leaf_b, b.fcmp_ordered(">=", size_a, size_b)))
    left_a, right_a = b.load(b.gep(A[3], [na])), b.load(b.gep(A[4], [na]))
    left_b, right_b = b.load(b.gep(B[3], [nb])), b.load(b.gep(B[4], [nb]))
    first_a = b.select(split_a, left_a, na)
    second_a = b.select(split_a, right_a, na)
    first_b = b.select(split_a, nb, left_b)
    second_b = b.select(split_a, nb, right_b)
    top = b.load(top_slot)
    room_for_two = b.icmp_signed("<=", b.add(top, i(2)), i(STACK))
    push = fn.append_basic_block("push")
    overflow = fn.append_basic_block("overflow")
    b.cbranch(room_for_two, push, overflow)
    b.position_at_end(push)
    # the second child pair below the first: the first is looked at first
    b.store(second_a, b.gep(stack_a, [i(0), top]))
    b.store(second_b, b.gep(stack_b, [i(0), top]))
    b.store(first_a, b.gep(stack_a, [i(0), b.add(top, i(1))]))
    b.store(first_b, b.gep(stack_b, [i(0), b.add(top, i(1))]))
    b.store(b.add(top, i(2)), top_slot)
    b.branch(pop_head)
    # no room (a tree far deeper than it should be): the count marks the answer unusable
    b.position_at_end(overflow)
    b.store(i(-1), count_out)
    b.ret_void()
    b.position_at_end(state_next)
    b.store(b.add(b.load(k_slot), i(1)), k_slot)
    b.branch(state_head)
    b.position_at_end(finished)
    b.store(b.load(count_slot), count_out)
    b.ret_void()
    return str(module)


DIRECTIONS = 16  # convex.penetration's candidates: 3 + 3 axes, their 9 crosses, the centres


def _polytope_depth(e: _Emit, fn, a: tuple, b: tuple):
    """The depth estimate of :func:`rworld_cli.collision.convex.penetration` for two rows of
    leaf tables: the least of ``hi_a - lo_b`` and ``hi_b - lo_a`` over the unit directions of
    each piece's three axes, their nine cross products and the centres' difference, those no
    shorter than 1e-9.  A side is (vertices table, V, row, pose (12 doubles: R's rows, then
    t), axes table (3 rows of 3 a row), centres table); the builder is left at the end of the
    emitted code, and the estimate returned."""
    import llvmlite.ir as ir

    b_, c, i = e.b, e.c, e.i
    D = ir.DoubleType()

    def load(pointer, index):
        return b_.load(b_.gep(pointer, [index]))

    def placed_side(side):
        table, V, row, pose, axes, centres = side
        Rt = [load(pose, i(j)) for j in range(12)]
        R, t = Rt[:9], Rt[9:]
        rows = [
            [load(axes, b_.add(b_.mul(row, i(9)), i(3 * r + m))) for m in range(3)]
            for r in range(3)
        ]
        turned = [
            [e.add(*[b_.fmul(R[3 * j + m], x[m]) for m in range(3)]) for j in range(3)]
            for x in rows
        ]
        local = [load(centres, b_.add(b_.mul(row, i(3)), i(m))) for m in range(3)]
        centre = [
            e.add(*[b_.fmul(R[3 * j + m], local[m]) for m in range(3)], t[j]) for j in range(3)
        ]
        return turned, centre, R, t

    def cross(x, y):
        return [
            b_.fsub(b_.fmul(x[1], y[2]), b_.fmul(x[2], y[1])),
            b_.fsub(b_.fmul(x[2], y[0]), b_.fmul(x[0], y[2])),
            b_.fsub(b_.fmul(x[0], y[1]), b_.fmul(x[1], y[0])),
        ]

    def dot(x, y):
        return e.add(*[b_.fmul(x[j], y[j]) for j in range(3)])

    axes_a, centre_a, Ra, ta = placed_side(a)
    axes_b, centre_b, Rb, tb = placed_side(b)
    candidates = axes_a + axes_b + [cross(x, y) for x in axes_a for y in axes_b]
    candidates.append([b_.fsub(centre_b[j], centre_a[j]) for j in range(3)])
    units, goods = [], []
    for d in candidates:
        length = b_.call(e.sqrt, [dot(d, d)])
        good = b_.fcmp_ordered(">", length, c(1e-9))
        units.append([b_.fdiv(x, b_.select(good, length, c(1.0))) for x in d])
        goods.append(good)
    # the accumulators on the function's stack frame, allocated once in its entry block (an
    # alloca where the walk loops would grow the stack at every leaf pair)
    here = b_.block
    b_.position_at_start(fn.entry_basic_block)
    slots = [
        (
            b_.alloca(ir.ArrayType(D, DIRECTIONS)),
            b_.alloca(ir.ArrayType(D, DIRECTIONS)),
            b_.alloca(ir.IntType(64)),
        )
        for _ in range(2)
    ]
    b_.position_at_end(here)
    extents = []
    for (side, R, t), (hi, lo, m_slot) in zip(((a, Ra, ta), (b, Rb, tb)), slots):
        table, V, row, _, _, _ = side
        for k in range(DIRECTIONS):
            b_.store(c(-np.inf), b_.gep(hi, [i(0), i(k)]))
            b_.store(c(np.inf), b_.gep(lo, [i(0), i(k)]))
        b_.store(i(0), m_slot)
        head = fn.append_basic_block("extent_head")
        body = fn.append_basic_block("extent_body")
        done = fn.append_basic_block("extent_done")
        b_.branch(head)
        b_.position_at_end(head)
        m = b_.load(m_slot)
        b_.cbranch(b_.icmp_signed("<", m, V), body, done)
        b_.position_at_end(body)
        base = b_.mul(b_.add(b_.mul(row, V), m), i(3))
        x = [load(table, b_.add(base, i(j))) for j in range(3)]
        v = [e.add(*[b_.fmul(R[3 * j + n], x[n]) for n in range(3)], t[j]) for j in range(3)]
        for k, unit in enumerate(units):
            value = dot(unit, v)
            h_ptr, l_ptr = b_.gep(hi, [i(0), i(k)]), b_.gep(lo, [i(0), i(k)])
            b_.store(e.maximum(value, b_.load(h_ptr)), h_ptr)
            low = b_.load(l_ptr)
            b_.store(b_.select(b_.fcmp_ordered("<", value, low), value, low), l_ptr)
        b_.store(b_.add(m, i(1)), m_slot)
        b_.branch(head)
        b_.position_at_end(done)
        extents.append((hi, lo))
    (hi_a, lo_a), (hi_b, lo_b) = extents
    best = c(np.inf)
    for k in range(DIRECTIONS):
        ha, la = b_.load(b_.gep(hi_a, [i(0), i(k)])), b_.load(b_.gep(lo_a, [i(0), i(k)]))
        hb, lb = b_.load(b_.gep(hi_b, [i(0), i(k)])), b_.load(b_.gep(lo_b, [i(0), i(k)]))
        least = b_.fsub(ha, lb)
        other = b_.fsub(hb, la)
        least = b_.select(b_.fcmp_ordered("<", other, least), other, least)
        least = b_.select(goods[k], least, c(np.inf))
        best = b_.select(b_.fcmp_ordered("<", least, best), least, best)
    return best


def contacts_ir(symbol: str, gjk_symbol: str) -> str:
    """The LLVM IR text of the collision-only walk with its leaves measured in place:

    ``void f(i64 K, ptr limit, double deep, ptr R, ptr t, (tree a:) ptr centre, ptr half,
    ptr axes, ptr left, ptr right, ptr item, (tree b: the same six), (leaves a:) i64 V,
    ptr table, ptr neighbours, i64 D, ptr pose, i64 estimate, ptr axes, ptr centres, (leaves
    b: the same eight), i64 max_iterations, ptr status, ptr nearest, ptr witness)``

    For each state k (``T_a_b`` = ``R[k]``, ``t[k]``), the walk of :func:`touching_ir` with the
    bound ``min(limit[k], the nearest distance measured so far)`` (branch and bound); each
    leaf pair it reaches is measured by ``gjk_symbol`` (:func:`rworld_cli.collision.compiled.
    gjk_ir` with ``local``, called for one pair): leaf ``item`` of a side is row ``item`` of its
    table (V vertices in the side's own frame, placed by its fixed ``pose``, 12 doubles, and for
    b then by the state's ``T_a_b``), climbed by its neighbours (D per vertex; 0: scanned).
    ``status[k]``: 0 no leaf pair overlaps, 1 one overlaps deeper than ``deep`` by GJK's
    depth bound or, where the bound says less and both leaves carry their axes (``estimate``
    not 0: rows of ``axes`` (3 x 3) and ``centres`` (3) in the table's frame), by the depth
    estimate of :func:`rworld_cli.collision.convex.penetration` (:func:`_polytope_depth`;
    the walk of that state stops there), 2 some overlap is not known to be that deep (from
    the first overlap on, only leaf pairs whose boxes meet are walked: the state's distance is
    0); ``nearest[k]``: the least distance of the leaf pairs measured that do not overlap (inf:
    none), exact for every pair within ``limit``; for status 1, minus that depth; for status 2,
    0; ``witness[k]`` (:data:`WITNESS` doubles): that nearest pair's (status 2: the deepest
    overlap's) closest points in a's frame (6), its two leaf items (as doubles), then for
    status 2 the deepest overlap's depth estimate when every overlapping pair carries one (the
    depth the exact query reports), else NaN.  ``status[0]`` -1: a tree deeper than the stack
    (the caller falls back).

    An inner node's ``item`` is minus the number of leaves below it (:func:`walk_side`): a
    node of at least :data:`BOX_BOUND_LEAVES` met by a hull of more than 8 vertices is
    bounded by GJK between the hull and the node's box (8 corners) before it is split - the
    two boxes' gap is loose where the hull's box stands off the hull (a round flange over a
    plate of many triangles: the walks of the TX2-60's tour 82 -> 39 ms, the iiwa's 88 -> 62
    ms), and below a few leaves the extra GJK costs more than it spares.
    """
    import llvmlite.ir as ir

    D, I64 = ir.DoubleType(), ir.IntType(64)
    dptr, iptr = ir.PointerType(D), ir.PointerType(I64)
    module = ir.Module(name="contacts")
    gjk = ir.Function(
        module,
        ir.FunctionType(
            ir.VoidType(),
            [I64, I64, I64, dptr, dptr, dptr, dptr, dptr, I64]
            + [iptr, iptr, dptr, dptr, iptr, iptr, I64, I64],
        ),
        name=gjk_symbol,
    )
    tree = [dptr, dptr, dptr, iptr, iptr, iptr]
    leaves = [I64, dptr, iptr, I64, dptr, I64, dptr, dptr]
    fn = ir.Function(
        module,
        ir.FunctionType(
            ir.VoidType(),
            [I64, dptr, D, dptr, dptr] + tree + tree + leaves + leaves + [I64, iptr, dptr, dptr],
        ),
        name=symbol,
    )
    K, limit, deep, Rp, tp = fn.args[:5]
    A, B = fn.args[5:11], fn.args[11:17]
    VA, table_a, nbr_a, DA, pose_a, estimate_a, axes_a, centres_a = fn.args[17:25]
    VB, table_b, nbr_b, DB, fixed_b, estimate_b, axes_b, centres_b = fn.args[25:33]
    max_it, status_out, nearest_out, witness_out = fn.args[33:]
    entry = fn.append_basic_block("entry")
    b = ir.IRBuilder(entry)
    e = _Emit(b, module)
    i, c = e.i, e.c
    stack_a = b.alloca(ir.ArrayType(I64, STACK), name="stack_a")
    stack_b = b.alloca(ir.ArrayType(I64, STACK), name="stack_b")
    stack_g = b.alloca(ir.ArrayType(D, STACK), name="stack_g")  # each pending pair's bound
    top_slot = b.alloca(I64, name="top")
    k_slot = b.alloca(I64, name="k")
    status_slot = b.alloca(I64, name="status")
    nearest_slot = b.alloca(D, name="nearest")
    row_a = b.alloca(I64, name="row_a")
    row_b = b.alloca(I64, name="row_b")
    pose_b = b.alloca(ir.ArrayType(D, 12), name="pose_b")
    depth_slot = b.alloca(D, name="depth")
    shallow_slot = b.alloca(D, name="shallow")  # the deepest shallow overlap's estimate
    shape_a = b.alloca(ir.ArrayType(D, 9), name="shape_a")
    shape_b = b.alloca(ir.ArrayType(D, 9), name="shape_b")
    out = b.alloca(ir.ArrayType(D, 12), name="out")
    # a node's box as a table of one row (8 corners, scanned) for the leaf-against-box bound,
    # with the poses that place it: a's frame (identity) or the state's T_a_b
    box_table = b.alloca(ir.ArrayType(D, 24), name="box_table")
    box_row = b.alloca(I64, name="box_row")
    no_neighbours = b.alloca(I64, name="no_neighbours")
    pose_identity = b.alloca(ir.ArrayType(D, 12), name="pose_identity")
    pose_state = b.alloca(ir.ArrayType(D, 12), name="pose_state")
    b.store(i(0), box_row)
    b.store(i(-2), no_neighbours)
    for j, one in enumerate((1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)):
        b.store(c(one), b.gep(pose_identity, [i(0), i(j)]))

    def cell(array, j):
        return b.gep(array, [i(0), i(j)])

    def first(array, kind):
        return b.bitcast(b.gep(array, [i(0), i(0)]), kind)

    for shape in (shape_a, shape_b):  # polytopes: no cylinder flag, axis z, no radius
        for j, value in enumerate((0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0)):
            b.store(c(value), cell(shape, j))
    b.store(i(0), k_slot)
    state_head = fn.append_basic_block("state_head")
    state_body = fn.append_basic_block("state_body")
    pop_head = fn.append_basic_block("pop_head")
    pop_body = fn.append_basic_block("pop_body")
    state_next = fn.append_basic_block("state_next")
    finished = fn.append_basic_block("finished")
    settled = fn.append_basic_block("settled")
    b.branch(state_head)
    b.position_at_end(state_head)
    k = b.load(k_slot)
    b.cbranch(b.icmp_signed("<", k, K), state_body, finished)
    # a state: b's leaves placed by T_a_b o its fixed pose, the walk from the roots
    b.position_at_end(state_body)
    R = e.row(Rp, b.mul(k, i(9)), 9)
    t = e.row(tp, b.mul(k, i(3)), 3)
    fixed = e.row(fixed_b, i(0), 12)
    Rf, tf = fixed[:9], fixed[9:]
    for r in range(3):
        for col in range(3):
            value = e.add(*[b.fmul(R[3 * r + m], Rf[3 * m + col]) for m in range(3)])
            b.store(value, cell(pose_b, 3 * r + col))
        value = e.add(*[b.fmul(R[3 * r + m], tf[m]) for m in range(3)], t[r])
        b.store(value, cell(pose_b, 9 + r))
    for j in range(9):
        b.store(R[j], cell(pose_state, j))
    for j in range(3):
        b.store(t[j], cell(pose_state, 9 + j))
    b.store(i(0), status_slot)
    b.store(c(np.inf), nearest_slot)
    b.store(c(-1.0), shallow_slot)
    b.store(i(0), b.gep(stack_a, [i(0), i(0)]))
    b.store(i(0), b.gep(stack_b, [i(0), i(0)]))
    root_a, root_b = e.node(A[0], A[1], A[2], i(0)), e.node(B[0], B[1], B[2], i(0))
    (Ua0, hA0, cA0), (Ub0, hB0, cB0) = root_a, root_b
    b.store(e.gap(Ua0, Ub0, hA0, hB0, cA0, cB0, R, t), cell(stack_g, 0))
    b.store(i(1), top_slot)
    b.branch(pop_head)
    b.position_at_end(pop_head)
    top = b.load(top_slot)
    b.cbranch(b.icmp_signed(">", top, i(0)), pop_body, state_next)
    b.position_at_end(pop_body)
    k = b.load(k_slot)
    top = b.sub(b.load(top_slot), i(1))
    b.store(top, top_slot)
    na = b.load(b.gep(stack_a, [i(0), top]))
    nb = b.load(b.gep(stack_b, [i(0), top]))
    gap = b.load(b.gep(stack_g, [i(0), top]))
    near = fn.append_basic_block("near")
    # a pair farther than asked, or than a leaf pair already measured, cannot matter: the
    # nearest kept is exact up to the limit, and an overlap's box gap is at most 0
    bound = b.load(b.gep(limit, [k]))
    kept = b.load(nearest_slot)
    bound = b.select(b.fcmp_ordered("<", kept, bound), kept, bound)
    b.cbranch(b.fcmp_ordered("<=", gap, bound), near, pop_head)  # NaN: dropped
    b.position_at_end(near)
    UA, hA, cA = e.node(A[0], A[1], A[2], na)
    UB, hB, cB = e.node(B[0], B[1], B[2], nb)
    R = e.row(Rp, b.mul(k, i(9)), 9)
    t = e.row(tp, b.mul(k, i(3)), 3)
    item_a = b.load(b.gep(A[5], [na]))
    item_b = b.load(b.gep(B[5], [nb]))
    leaf_a = b.icmp_signed(">=", item_a, i(0))
    leaf_b = b.icmp_signed(">=", item_b, i(0))
    measure = fn.append_basic_block("measure")
    split = fn.append_basic_block("split")
    inner = fn.append_basic_block("inner")
    b.cbranch(b.and_(leaf_a, leaf_b), measure, inner)
    # a leaf against an inner node: GJK's lower bound between the leaf and the node's box (its
    # leaves lie in the box, so none is nearer) - much tighter than the two boxes' gap when the
    # leaf is a large hull whose box stands off it (a flange over a plate of many triangles);
    # a pair above the bound is dropped without descending
    b.position_at_end(inner)
    one_leaf = fn.append_basic_block("one_leaf")
    box_on_a = fn.append_basic_block("box_on_a")
    box_on_b = fn.append_basic_block("box_on_b")
    b.cbranch(b.xor(leaf_a, leaf_b), one_leaf, split)
    b.position_at_end(one_leaf)
    # only a hull's box stands off it (a triangle's or a box's is the leaf itself)
    many = i(-BOX_BOUND_LEAVES)
    hull_b = b.and_(b.icmp_signed(">", VB, i(8)), b.icmp_signed("<=", item_a, many))
    hull_a = b.and_(b.icmp_signed(">", VA, i(8)), b.icmp_signed("<=", item_b, many))
    hull_b, hull_a = b.and_(leaf_b, hull_b), b.and_(leaf_a, hull_a)
    pick = fn.append_basic_block("pick")
    b.cbranch(b.or_(hull_a, hull_b), pick, split)
    b.position_at_end(pick)
    b.cbranch(leaf_b, box_on_a, box_on_b)

    def leaf_against_box(U, h, centre, box_side_a: bool):
        for corner in range(8):
            signs = [1.0 if corner >> axis & 1 else -1.0 for axis in range(3)]
            for j in range(3):
                value = e.add(
                    centre[j], *[b.fmul(c(signs[m]), b.fmul(h[m], U[3 * m + j])) for m in range(3)]
                )
                b.store(value, cell(box_table, 3 * corner + j))
        placed_b = [e.add(*[b.fmul(R[3 * j + m], cB[m]) for m in range(3)], t[j]) for j in range(3)]
        for j in range(3):
            b.store(cA[j], cell(shape_a, 1 + j))
            b.store(placed_b[j], cell(shape_b, 1 + j))
        box = (i(8), first(box_table, dptr), box_row, no_neighbours, i(0))
        if box_side_a:
            b.store(item_b, row_b)
            side_a = box + (first(pose_identity, dptr),)
            side_b = (VB, table_b, row_b, nbr_b, DB, first(pose_b, dptr))
        else:
            b.store(item_a, row_a)
            side_a = (VA, table_a, row_a, nbr_a, DA, pose_a)
            side_b = box + (first(pose_state, dptr),)
        (Va, ta, ra, na_, da, pa), (Vb, tb, rb, nb_, db, pb) = side_a, side_b
        b.call(
            gjk,
            [i(1), Va, Vb, ta, tb, first(shape_a, dptr), first(shape_b, dptr), first(out, dptr)]
            + [max_it, ra, rb, pa, pb, na_, nb_, da, db],
        )
        apart = b.fcmp_ordered("==", b.load(cell(out, 7)), c(0.0))
        lower = b.load(cell(out, 9))  # GJK's last lower bound (NaN: none, the pair is kept)
        far = b.and_(apart, b.fcmp_ordered(">", lower, bound))
        b.cbranch(far, pop_head, split)

    b.position_at_end(box_on_a)
    leaf_against_box(UA, hA, cA, True)
    b.position_at_end(box_on_b)
    leaf_against_box(UB, hB, cB, False)
    # a leaf pair: GJK on the two rows, a's in its frame, b's placed; the boxes' centres as
    # GJK's first direction
    b.position_at_end(measure)
    b.store(item_a, row_a)
    b.store(item_b, row_b)
    for j in range(3):
        b.store(cA[j], cell(shape_a, 1 + j))
        placed = e.add(*[b.fmul(R[3 * j + m], cB[m]) for m in range(3)], t[j])
        b.store(placed, cell(shape_b, 1 + j))
    b.call(
        gjk,
        [
            i(1),
            VA,
            VB,
            table_a,
            table_b,
            first(shape_a, dptr),
            first(shape_b, dptr),
            first(out, dptr),
            max_it,
            row_a,
            row_b,
            pose_a,
            first(pose_b, dptr),
            nbr_a,
            nbr_b,
            DA,
            DB,
        ],
    )
    overlap = b.fcmp_ordered("!=", b.load(cell(out, 7)), c(0.0))
    unfinished = b.fcmp_ordered("!=", b.load(cell(out, 10)), c(0.0))
    distance = b.select(unfinished, b.load(cell(out, 9)), b.load(cell(out, 0)))
    bound_depth = b.load(cell(out, 11))
    deeper = b.and_(overlap, b.fcmp_ordered(">", bound_depth, deep))
    collided = fn.append_basic_block("collided")
    measured = fn.append_basic_block("measured")
    estimating = fn.append_basic_block("estimating")
    b.store(bound_depth, depth_slot)
    # an overlap GJK's simplex bounds too little (two crossing triangles leave it little
    # volume): where both leaves carry their axes, the depth estimate of convex.penetration
    # (the least overlap over the pieces' axes, their cross products and the centres'
    # difference) decides, as the exact query would
    both = b.and_(b.icmp_signed("!=", estimate_a, i(0)), b.icmp_signed("!=", estimate_b, i(0)))
    shallow = b.and_(b.and_(overlap, b.not_(deeper)), both)
    b.cbranch(deeper, collided, measured)
    b.position_at_end(measured)
    b.cbranch(shallow, estimating, settled)
    b.position_at_end(estimating)
    estimate = _polytope_depth(
        e,
        fn,
        (table_a, VA, item_a, pose_a, axes_a, centres_a),
        (table_b, VB, item_b, first(pose_b, dptr), axes_b, centres_b),
    )
    b.store(estimate, depth_slot)
    b.cbranch(b.fcmp_ordered(">", estimate, deep), collided, settled)
    b.position_at_end(collided)
    b.store(i(1), status_slot)
    b.store(b.fneg(b.load(depth_slot)), nearest_slot)
    b.branch(state_next)
    b.position_at_end(settled)
    b.store(b.select(overlap, i(2), b.load(status_slot)), status_slot)
    kept = b.load(nearest_slot)
    nearer = b.and_(b.not_(overlap), b.fcmp_ordered("<", distance, kept))
    record = fn.append_basic_block("record")
    overlapped = fn.append_basic_block("overlapped")
    not_overlapped = fn.append_basic_block("not_overlapped")
    b.cbranch(overlap, overlapped, not_overlapped)
    b.position_at_end(not_overlapped)
    b.cbranch(nearer, record, pop_head)

    def keep_witness():
        base = b.mul(b.load(k_slot), i(WITNESS))
        for j in range(6):
            b.store(b.load(cell(out, 1 + j)), b.gep(witness_out, [b.add(base, i(j))]))
        b.store(b.sitofp(b.load(row_a), D), b.gep(witness_out, [b.add(base, i(6))]))
        b.store(b.sitofp(b.load(row_b), D), b.gep(witness_out, [b.add(base, i(7))]))
        b.branch(pop_head)

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
    record_overlap = fn.append_basic_block("record_overlap")
    b.cbranch(deepest, record_overlap, pop_head)
    b.position_at_end(record_overlap)
    keep_witness()
    # an inner pair: split as the collision-only walk does
    b.position_at_end(split)
    split_a = b.and_(b.not_(leaf_a), b.or_(leaf_b, b.fcmp_ordered(">=", e.add(*hA), e.add(*hB))))
    left_a, right_a = b.load(b.gep(A[3], [na])), b.load(b.gep(A[4], [na]))
    left_b, right_b = b.load(b.gep(B[3], [nb])), b.load(b.gep(B[4], [nb]))
    top = b.load(top_slot)
    push = fn.append_basic_block("push")
    overflow = fn.append_basic_block("overflow")
    b.cbranch(b.icmp_signed("<=", b.add(top, i(2)), i(STACK)), push, overflow)
    b.position_at_end(push)
    # both child pairs' bounds; the nearer is pushed last, so looked at first (the nearest
    # found early prunes more)
    children = []
    for first_a, first_b in ((left_a, left_b), (right_a, right_b)):
        ca = b.select(split_a, first_a, na)
        cb = b.select(split_a, nb, first_b)
        Ua2, ha2, ca2 = e.node(A[0], A[1], A[2], ca)
        Ub2, hb2, cb2 = e.node(B[0], B[1], B[2], cb)
        children.append((ca, cb, e.gap(Ua2, Ub2, ha2, hb2, ca2, cb2, R, t)))
    (a1, b1, g1), (a2, b2, g2) = children
    first_near = b.fcmp_ordered("<=", g1, g2)  # the left one on a tie, as before
    b.store(b.select(first_near, a2, a1), b.gep(stack_a, [i(0), top]))
    b.store(b.select(first_near, b2, b1), b.gep(stack_b, [i(0), top]))
    b.store(b.select(first_near, g2, g1), b.gep(stack_g, [i(0), top]))
    up = b.add(top, i(1))
    b.store(b.select(first_near, a1, a2), b.gep(stack_a, [i(0), up]))
    b.store(b.select(first_near, b1, b2), b.gep(stack_b, [i(0), up]))
    b.store(b.select(first_near, g1, g2), b.gep(stack_g, [i(0), up]))
    b.store(b.add(top, i(2)), top_slot)
    b.branch(pop_head)
    b.position_at_end(overflow)
    b.store(i(-1), status_out)
    b.ret_void()
    b.position_at_end(state_next)
    k = b.load(k_slot)
    b.store(b.load(status_slot), b.gep(status_out, [k]))
    b.store(b.load(nearest_slot), b.gep(nearest_out, [k]))
    b.store(b.load(shallow_slot), b.gep(witness_out, [b.add(b.mul(k, i(WITNESS)), i(8))]))
    b.store(b.add(k, i(1)), k_slot)
    b.branch(state_head)
    b.position_at_end(finished)
    b.ret_void()
    return str(module)


BODY_WORDS = 14  # a body's row of the table free_states reads: 6 tree arrays, 8 leaf fields


def free_states_ir(symbol: str, contacts_symbol: str, rows: bool = False) -> str:
    """The LLVM IR text of a configuration check of many pairs of bodies at N states:

    ``void f(i64 N, i64 P, ptr pairs, i64 B, ptr poses, ptr bodies, ptr spheres, ptr boxes,
    double limit, double deep, i64 max_iterations, ptr status, ptr nearest, ptr witness)``

    ``pairs`` (P, 2) int64 body indices, in the order to try them; ``poses`` (N, B, 12) each
    body's frame in world (R's rows, then t); ``bodies`` (B, :data:`BODY_WORDS`) int64: the
    addresses of its tree's six arrays, then its leaf table's V, table address, neighbours
    address, D, pose address, estimate flag, axes and centres addresses (:func:`walk_side`);
    ``spheres`` (B, 4): each body's bounding sphere (centre in its frame, radius); ``boxes``
    (B, 9): a closed mesh's box in its frame (least and greatest corner; +inf and -inf for
    other bodies) and each body's witness point (:attr:`~rworld_cli.collision.bodies.Body.
    first_point`).  For each state, pair after pair: a pair whose bounding spheres are
    farther apart than ``limit`` is 3 with inf; another is walked by ``contacts_symbol``
    (:func:`contacts_ir`, one state) and its status and nearest written (``nearest`` (N, P),
    ``status`` (N, P): 0, 1, 2 as there, -1 a tree too deep); after a pair of status 1 the
    state's other pairs are skipped (status -2); a pair of status 0 one of whose witness
    points lies in the other's closed-mesh box is 4 (the caller's winding number decides
    whether it is buried).  ``witness``: :data:`WITNESS` doubles of scratch.

    ``rows``: the same for R rows of their own (what a segment check asks: each pair at its
    own state, exact up to its own limit), no row skipped -

    ``void f(i64 R, ptr rows, i64 B, ptr poses, ptr bodies, ptr spheres, ptr boxes, ptr
    limits, double deep, i64 max_iterations, ptr status, ptr nearest, ptr witness)``

    ``rows`` (R, 3) int64: the state (a row of ``poses``) and the two bodies; ``limits``
    (R,); ``status`` and ``nearest`` (R,).
    """
    import llvmlite.ir as ir

    D, I64 = ir.DoubleType(), ir.IntType(64)
    dptr, iptr = ir.PointerType(D), ir.PointerType(I64)
    module = ir.Module(name="free_states")
    tree = [dptr, dptr, dptr, iptr, iptr, iptr]
    leaves = [I64, dptr, iptr, I64, dptr, I64, dptr, dptr]
    contacts = ir.Function(
        module,
        ir.FunctionType(
            ir.VoidType(),
            [I64, dptr, D, dptr, dptr] + tree + tree + leaves + leaves + [I64, iptr, dptr, dptr],
        ),
        name=contacts_symbol,
    )
    head = [I64, iptr, I64] if rows else [I64, I64, iptr, I64]
    fn = ir.Function(
        module,
        ir.FunctionType(
            ir.VoidType(),
            head + [dptr, iptr, dptr, dptr, dptr if rows else D, D, I64, iptr, dptr, dptr],
        ),
        name=symbol,
    )
    if rows:
        R, row_table, B, poses, bodies, spheres, boxes, limits, deep, max_it = fn.args[:10]
    else:
        N, P, pairs, B, poses, bodies, spheres, boxes, limit, deep, max_it = fn.args[:11]
    status_out, nearest_out, witness = fn.args[-3:]
    entry = fn.append_basic_block("entry")
    b = ir.IRBuilder(entry)
    e = _Emit(b, module)
    i, c = e.i, e.c
    n_slot, p_slot = b.alloca(I64, name="n"), b.alloca(I64, name="p")
    hit_slot = b.alloca(I64, name="hit")
    limit_slot = b.alloca(D, name="limit")
    R_slot = b.alloca(ir.ArrayType(D, 9), name="R")
    t_slot = b.alloca(ir.ArrayType(D, 3), name="t")
    st_slot = b.alloca(I64, name="status")
    near_slot = b.alloca(D, name="nearest")
    b.store(i(0), n_slot)
    b.store(i(0), hit_slot)
    finished = fn.append_basic_block("finished")
    pair_next = fn.append_basic_block("pair_next")
    if rows:  # one loop over the rows, each its own state, bodies and limit
        row_head = fn.append_basic_block("row_head")
        row_body = fn.append_basic_block("row_body")
        b.branch(row_head)
        b.position_at_end(row_head)
        b.cbranch(b.icmp_signed("<", b.load(n_slot), R), row_body, finished)
        b.position_at_end(row_body)
        r = b.load(n_slot)
        n = b.load(b.gep(row_table, [b.mul(r, i(3))]))
        ia = b.load(b.gep(row_table, [b.add(b.mul(r, i(3)), i(1))]))
        ib = b.load(b.gep(row_table, [b.add(b.mul(r, i(3)), i(2))]))
        out_index = r
        b.store(b.load(b.gep(limits, [r])), limit_slot)
    else:  # states, and in each the pairs until one collides
        b.store(limit, limit_slot)
        state_head = fn.append_basic_block("state_head")
        state_body = fn.append_basic_block("state_body")
        pair_head = fn.append_basic_block("pair_head")
        pair_body = fn.append_basic_block("pair_body")
        state_next = fn.append_basic_block("state_next")
        b.branch(state_head)
        b.position_at_end(state_head)
        b.cbranch(b.icmp_signed("<", b.load(n_slot), N), state_body, finished)
        b.position_at_end(state_body)
        b.store(i(0), p_slot)
        b.store(i(0), hit_slot)
        b.branch(pair_head)
        b.position_at_end(pair_head)
        b.cbranch(b.icmp_signed("<", b.load(p_slot), P), pair_body, state_next)
        b.position_at_end(pair_body)
        n, p = b.load(n_slot), b.load(p_slot)
        out_index = b.add(b.mul(n, P), p)
        skipped = fn.append_basic_block("skipped")
        looked = fn.append_basic_block("looked")
        b.cbranch(b.icmp_signed("!=", b.load(hit_slot), i(0)), skipped, looked)
        b.position_at_end(skipped)  # the state collides already: the rest is not asked
        b.store(i(-2), b.gep(status_out, [out_index]))
        b.store(c(np.inf), b.gep(nearest_out, [out_index]))
        b.branch(pair_next)
        b.position_at_end(looked)
        ia = b.load(b.gep(pairs, [b.mul(p, i(2))]))
        ib = b.load(b.gep(pairs, [b.add(b.mul(p, i(2)), i(1))]))
    limit_here = b.load(limit_slot)
    pose_a = e.row(poses, b.mul(b.add(b.mul(n, B), ia), i(12)), 12)
    pose_b = e.row(poses, b.mul(b.add(b.mul(n, B), ib), i(12)), 12)
    Ra, ta, Rb, tb = pose_a[:9], pose_a[9:], pose_b[:9], pose_b[9:]
    sa = e.row(spheres, b.mul(ia, i(4)), 4)
    sb = e.row(spheres, b.mul(ib, i(4)), 4)
    ca = [e.add(*[b.fmul(Ra[3 * r + m], sa[m]) for m in range(3)], ta[r]) for r in range(3)]
    cb = [e.add(*[b.fmul(Rb[3 * r + m], sb[m]) for m in range(3)], tb[r]) for r in range(3)]
    gap = [b.fsub(ca[r], cb[r]) for r in range(3)]
    apart = b.fsub(b.call(e.sqrt, [e.add(*[b.fmul(g, g) for g in gap])]), b.fadd(sa[3], sb[3]))
    far = fn.append_basic_block("far")
    walk = fn.append_basic_block("walk")
    b.cbranch(b.fcmp_ordered(">", apart, limit_here), far, walk)
    b.position_at_end(far)
    b.store(i(3), b.gep(status_out, [out_index]))
    b.store(c(np.inf), b.gep(nearest_out, [out_index]))
    b.branch(pair_next)
    # T_a_b = inv(Ta) Tb: R = Ra^T Rb, t = Ra^T (tb - ta)
    b.position_at_end(walk)
    for r in range(3):
        for col in range(3):
            value = e.add(*[b.fmul(Ra[3 * m + r], Rb[3 * m + col]) for m in range(3)])
            b.store(value, b.gep(R_slot, [i(0), i(3 * r + col)]))
        value = e.add(*[b.fmul(Ra[3 * m + r], b.fsub(tb[m], ta[m])) for m in range(3)])
        b.store(value, b.gep(t_slot, [i(0), i(r)]))

    def word(body, j):
        return b.load(b.gep(bodies, [b.add(b.mul(body, i(BODY_WORDS)), i(j))]))

    def side(body):
        tree_args = [
            b.inttoptr(word(body, j), kind)
            for j, kind in enumerate([dptr, dptr, dptr, iptr, iptr, iptr])
        ]
        leaf_args = [
            word(body, 6),
            b.inttoptr(word(body, 7), dptr),
            b.inttoptr(word(body, 8), iptr),
            word(body, 9),
            b.inttoptr(word(body, 10), dptr),
            word(body, 11),
            b.inttoptr(word(body, 12), dptr),
            b.inttoptr(word(body, 13), dptr),
        ]
        return tree_args, leaf_args

    tree_a, leaf_a = side(ia)
    tree_b, leaf_b = side(ib)
    b.call(
        contacts,
        [
            i(1),
            limit_slot,
            deep,
            b.gep(R_slot, [i(0), i(0)]),
            b.gep(t_slot, [i(0), i(0)]),
            *tree_a,
            *tree_b,
            *leaf_a,
            *leaf_b,
            max_it,
            st_slot,
            near_slot,
            witness,
        ],
    )
    status = b.load(st_slot)
    # clear of each other's surfaces: a witness point in the other's closed-mesh box?
    Rr = [b.load(b.gep(R_slot, [i(0), i(j)])) for j in range(9)]
    t = [b.load(b.gep(t_slot, [i(0), i(j)])) for j in range(3)]
    box_a = e.row(boxes, b.mul(ia, i(9)), 9)
    box_b = e.row(boxes, b.mul(ib, i(9)), 9)

    def inside(point, box):
        flags = [
            b.and_(
                b.fcmp_ordered(">=", point[j], box[j]), b.fcmp_ordered("<=", point[j], box[3 + j])
            )
            for j in range(3)
        ]
        return b.and_(b.and_(flags[0], flags[1]), flags[2])

    w_b = box_b[6:9]  # b's witness in a's frame: R w + t
    in_a = [e.add(*[b.fmul(Rr[3 * r + m], w_b[m]) for m in range(3)], t[r]) for r in range(3)]
    w_a = box_a[6:9]  # a's witness in b's frame: R^T (w - t)
    in_b = [
        e.add(*[b.fmul(Rr[3 * m + r], b.fsub(w_a[m], t[m])) for m in range(3)]) for r in range(3)
    ]
    boxed = b.or_(inside(in_a, box_a), inside(in_b, box_b))
    status = b.select(b.and_(b.icmp_signed("==", status, i(0)), boxed), i(4), status)
    b.store(status, b.gep(status_out, [out_index]))
    b.store(b.load(near_slot), b.gep(nearest_out, [out_index]))
    if not rows:
        b.store(b.zext(b.icmp_signed("==", status, i(1)), I64), hit_slot)
    b.branch(pair_next)
    b.position_at_end(pair_next)
    if rows:
        b.store(b.add(b.load(n_slot), i(1)), n_slot)
        b.branch(row_head)
    else:
        b.store(b.add(b.load(p_slot), i(1)), p_slot)
        b.branch(pair_head)
        b.position_at_end(state_next)
        b.store(b.add(b.load(n_slot), i(1)), n_slot)
        b.branch(state_head)
    b.position_at_end(finished)
    b.ret_void()
    return str(module)


_FUNCTION: list = []  # [ctypes function or None], built once per process


def _functions():
    """The module's ctypes functions - the bound, the collision-only walk, the descent, the
    walk with its leaves measured, the free-only check, the same for rows of their own - or
    six Nones (kernels off, or the compile failed); one module, compiled once per process and
    cached on disk."""
    if not _FUNCTION:
        import ctypes

        from . import compiled

        # the leaves' GJK is compiled.py's: both files make the module
        source = Path(__file__).read_text() + Path(compiled.__file__).read_text()
        digest = hashlib.sha256(source.encode()).hexdigest()[:20]
        gap_symbol, walk_symbol = f"rworld_box_gap_{digest}", f"rworld_touching_{digest}"
        descend_symbol = f"rworld_descend_{digest}"
        contacts_symbol = f"rworld_contacts_{digest}"
        gjk_symbol = f"rworld_contacts_gjk_{digest}"
        free_symbol = f"rworld_free_states_{digest}"
        rows_symbol = f"rworld_pair_rows_{digest}"

        def build() -> str:
            import llvmlite.binding as llvm

            module = llvm.parse_assembly(box_gap_ir(gap_symbol))
            module.link_in(llvm.parse_assembly(touching_ir(walk_symbol)))
            module.link_in(llvm.parse_assembly(descend_ir(descend_symbol)))
            module.link_in(llvm.parse_assembly(compiled.gjk_ir(gjk_symbol, local=True)))
            module.link_in(llvm.parse_assembly(contacts_ir(contacts_symbol, gjk_symbol)))
            module.link_in(llvm.parse_assembly(free_states_ir(free_symbol, contacts_symbol)))
            module.link_in(
                llvm.parse_assembly(free_states_ir(rows_symbol, contacts_symbol, rows=True))
            )
            return str(module)

        addresses = kernels.compile_ir(
            "box trees",
            build,
            [gap_symbol, walk_symbol, descend_symbol, contacts_symbol, free_symbol, rows_symbol],
            source,
        )
        if addresses is None:
            _FUNCTION.extend([None] * 6)
        else:
            _FUNCTION.append(
                ctypes.CFUNCTYPE(None, ctypes.c_int64, *[ctypes.c_void_p] * 12)(addresses[0])
            )
            _FUNCTION.append(
                ctypes.CFUNCTYPE(
                    None,
                    ctypes.c_int64,
                    ctypes.c_double,
                    *[ctypes.c_void_p] * 14,
                    ctypes.c_int64,
                    *[ctypes.c_void_p] * 4,
                )(addresses[1])
            )
            _FUNCTION.append(
                ctypes.CFUNCTYPE(None, ctypes.c_int64, *[ctypes.c_void_p] * 17)(addresses[2])
            )
            leaves = [ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int64]
            leaves += [ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p]
            _FUNCTION.append(
                ctypes.CFUNCTYPE(
                    None,
                    ctypes.c_int64,
                    ctypes.c_void_p,
                    ctypes.c_double,
                    *[ctypes.c_void_p] * 14,
                    *leaves,
                    *leaves,
                    ctypes.c_int64,
                    ctypes.c_void_p,
                    ctypes.c_void_p,
                    ctypes.c_void_p,
                )(addresses[3])
            )
            _FUNCTION.append(
                ctypes.CFUNCTYPE(
                    None,
                    ctypes.c_int64,
                    ctypes.c_int64,
                    ctypes.c_void_p,
                    ctypes.c_int64,
                    *[ctypes.c_void_p] * 4,
                    ctypes.c_double,
                    ctypes.c_double,
                    ctypes.c_int64,
                    *[ctypes.c_void_p] * 3,
                )(addresses[4])
            )
            _FUNCTION.append(
                ctypes.CFUNCTYPE(
                    None,
                    ctypes.c_int64,
                    ctypes.c_void_p,
                    ctypes.c_int64,
                    *[ctypes.c_void_p] * 5,
                    ctypes.c_double,
                    ctypes.c_int64,
                    *[ctypes.c_void_p] * 3,
                )(addresses[5])
            )
    return tuple(_FUNCTION)


def pair_rows(rows, poses, table, spheres, boxes, limits, deep, max_iterations: int):
    """:func:`free_states_ir` with ``rows``: each row (R, 3) int64 - a state (a row of
    ``poses`` (M, B, 12)) and two bodies of ``table`` - walked up to its own limit (R,):
    (status (R,), nearest (R,)), or None (no compiled kernel)."""
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    limits = np.ascontiguousarray(limits, dtype=float)
    head = (len(rows), rows.ctypes.data)
    return _fused_call(
        5,
        head,
        poses,
        table,
        spheres,
        boxes,
        limits.ctypes.data,
        deep,
        max_iterations,
        (len(rows),),
    )


def free_states(pairs, poses, table, spheres, boxes, limit, deep, max_iterations: int):
    """:func:`free_states_ir` on ``pairs`` (P, 2) of bodies whose rows of ``table`` (B,
    :data:`BODY_WORDS`) int64 (:func:`body_table`), ``spheres`` (B, 4) and ``boxes`` (B, 9)
    describe them, at
    ``poses`` (N, B, 12): (status (N, P), nearest (N, P)), or None (no compiled kernel)."""
    pairs = np.ascontiguousarray(pairs, dtype=np.int64)
    head = (len(poses), len(pairs), pairs.ctypes.data)
    return _fused_call(
        4,
        head,
        poses,
        table,
        spheres,
        boxes,
        float(limit),
        deep,
        max_iterations,
        (len(poses), len(pairs)),
    )


def _fused_call(which, head, poses, table, spheres, boxes, limit, deep, max_iterations, shape):
    """One call of :func:`free_states_ir`'s kernel ``which`` (4: states, 5: rows): ``head``
    its leading arguments, ``limit`` its limit (a double, or the address of the rows'), the
    outputs of ``shape``; the caller holds every array whose address it passes (the kernel
    reads raw addresses)."""
    if kernels.backend() != "llvm":
        return None
    function = _functions()[which]
    if function is None:
        return None
    poses = np.ascontiguousarray(poses, dtype=float)
    status = np.zeros(shape, dtype=np.int64)
    nearest = np.full(shape, np.inf)
    witness = np.zeros(WITNESS)
    if status.size:
        function(
            *head,
            poses.shape[1],
            poses.ctypes.data,
            table.ctypes.data,
            spheres.ctypes.data,
            boxes.ctypes.data,
            limit,
            float(deep),
            int(max_iterations),
            status.ctypes.data,
            nearest.ctypes.data,
            witness.ctypes.data,
        )
    return status, nearest


def body_table(sides: list) -> np.ndarray:
    """The rows (B, :data:`BODY_WORDS`) int64 of :func:`free_states_ir` for bodies' prepared
    sides (:func:`walk_side`, held by the caller as long as the table is used)."""
    return np.array([[*side[1], *side[2]] for side in sides], dtype=np.int64).reshape(
        -1, BODY_WORDS
    )


def walk_side(tree, leaves) -> tuple:
    """A body's tree and leaf table as :func:`contacts` takes them (contiguous, typed; kept
    by the caller, so that one pair's call does not convert them again): ``leaves`` =
    (table (R, V, 3), neighbours (R, V, D) int64 or None: scanned, pose (12,): the table's
    frame in the tree's, R's rows then t, estimate: (axes (R, 3, 3), centres (R, 3)) in the
    table's frame as :func:`rworld_cli.collision.convex.penetration` takes them, or None);
    the tree's leaf ``item`` is the table's row ``item``, a polytope; an inner node's is
    passed as minus its number of leaves (:func:`contacts_ir`)."""
    table, neighbours, pose, estimate = leaves
    arrays = [np.ascontiguousarray(x, dtype=float) for x in (tree.center, tree.half, tree.axes)]
    # an inner node's item: minus the number of leaves below it (the walk's leaf-against-box
    # bound is tried only above enough of them); a leaf's: its row
    item = np.where(tree.item >= 0, tree.item, -_leaves_below(tree))
    arrays += [np.ascontiguousarray(x, dtype=np.int64) for x in (tree.left, tree.right, item)]
    table = np.ascontiguousarray(table, dtype=float)
    degree = 0 if neighbours is None else int(np.shape(neighbours)[2])
    neighbours = (
        np.full((1, 1, 1), -2, dtype=np.int64)
        if neighbours is None
        else np.ascontiguousarray(neighbours, dtype=np.int64)
    )
    pose = np.ascontiguousarray(pose, dtype=float)
    # each row's axes (3 rows of 3) and centre, in the table's frame, for the depth estimate;
    # none (a flag of 0, one zero row) where the exact query is to decide
    flag = 0 if estimate is None else 1
    axes, centres = (np.zeros((1, 9)), np.zeros((1, 3))) if estimate is None else estimate
    axes = np.ascontiguousarray(np.reshape(axes, (-1, 9)), dtype=float)
    centres = np.ascontiguousarray(np.reshape(centres, (-1, 3)), dtype=float)
    held = (*arrays, table, neighbours, pose, axes, centres)
    addresses = [x.ctypes.data for x in arrays]
    leaf = [table.shape[1], table.ctypes.data, neighbours.ctypes.data, degree, pose.ctypes.data]
    leaf += [flag, axes.ctypes.data, centres.ctypes.data]
    return held, addresses, leaf


def _leaves_below(tree) -> np.ndarray:
    """The number of leaves under each node of ``tree`` (N,) int64: every leaf climbs to the
    root at once, one level a step."""
    N = len(tree.item)
    parent = np.full(N, -1, dtype=np.int64)
    inner = np.flatnonzero(tree.item < 0)
    parent[tree.left[inner]] = inner
    parent[tree.right[inner]] = inner
    count = np.zeros(N, dtype=np.int64)
    at = np.flatnonzero(tree.item >= 0)
    while len(at):
        np.add.at(count, at, 1)
        at = parent[at]
        at = at[at >= 0]
    return count


def contacts(side_a, side_b, R, t, limit, deep: float, max_iterations: int):
    """For each of K states ``T_a_b`` = (``R`` (K, 3, 3), ``t`` (K, 3)): whether a leaf pair of
    the two bodies (:func:`walk_side` each) within ``limit`` [m] (one for all states, or (K,))
    overlaps, deeper than ``deep``
    by GJK's bound, and the least distance of those that do not (:func:`contacts_ir`):
    (status (K,) int, nearest (K,), witness (K, :data:`WITNESS`): the nearest pair's closest
    points in a's frame, its leaves, and where shallow overlaps were found their deepest's
    depth or NaN), or None when no compiled kernel is available or a tree is too deep for its
    stack."""
    if kernels.backend() != "llvm":
        return None
    function = _functions()[3]
    if function is None:
        return None
    # every array is held by a name until the call returns: the kernel reads raw addresses
    Rc, tc = np.ascontiguousarray(R, dtype=float), np.ascontiguousarray(t, dtype=float)
    K = len(Rc)
    status = np.zeros(K, dtype=np.int64)
    nearest = np.full(K, np.inf)
    witness = np.full((K, WITNESS), -1.0)
    if not K:
        return status, nearest, witness
    limits = np.ascontiguousarray(np.broadcast_to(np.asarray(limit, dtype=float), (K,)))
    function(
        K,
        limits.ctypes.data,
        float(deep),
        Rc.ctypes.data,
        tc.ctypes.data,
        *side_a[1],
        *side_b[1],
        *side_a[2],
        *side_b[2],
        int(max_iterations),
        status.ctypes.data,
        nearest.ctypes.data,
        witness.ctypes.data,
    )
    if status[0] < 0:  # a tree deeper than the kernel's stack: the caller's search answers
        return None
    return status, nearest, witness


def _tree_arrays(tree_a, tree_b) -> list[np.ndarray]:
    """Both trees' arrays in the kernels' argument order (each tree: centre, half, axes as
    float64; left, right, item as int64), contiguous; held by the caller until the call
    returns (the kernels read raw addresses)."""
    out = []
    for tree in (tree_a, tree_b):
        out += [np.ascontiguousarray(x, dtype=float) for x in (tree.center, tree.half, tree.axes)]
        out += [np.ascontiguousarray(x, dtype=np.int64) for x in (tree.left, tree.right, tree.item)]
    return out


def descend(tree_a, tree_b, k, a, b, R, t):
    """The descent of :func:`rworld_cli.collision.bvh.candidates`, compiled: each node pair
    (``a[q]``, ``b[q]``) at state ``k[q]`` of ``R`` (K, 3, 3), ``t`` (K, 3) followed down to a
    leaf pair; (leaf nodes of a, of b), or None when no compiled kernel is available."""
    if kernels.backend() != "llvm":
        return None
    function = _functions()[2]
    if function is None:
        return None
    # every array is held by a name until the call returns: the kernel reads raw addresses
    ka = np.ascontiguousarray(k, dtype=np.int64)
    na = np.array(a, dtype=np.int64)  # copies: the kernel writes the leaves over them
    nb = np.array(b, dtype=np.int64)
    Rc, tc = np.ascontiguousarray(R, dtype=float), np.ascontiguousarray(t, dtype=float)
    trees = _tree_arrays(tree_a, tree_b)
    function(
        len(ka),
        ka.ctypes.data,
        na.ctypes.data,
        nb.ctypes.data,
        Rc.ctypes.data,
        tc.ctypes.data,
        *[x.ctypes.data for x in trees],
    )
    return na, nb


def touching(tree_a, tree_b, R: np.ndarray, t: np.ndarray, limit: float):
    """The leaf pairs of two trees whose boxes' bound stays within ``limit`` [m] all the way
    down, at each of K states ``T_a_b`` = (``R`` (K, 3, 3), ``t`` (K, 3)): (k, leaf_a, leaf_b)
    int arrays sorted by state, as :func:`rworld_cli.collision.bvh.candidates` finds them
    without its refinements (a collision test); None when no compiled kernel is available."""
    if kernels.backend() != "llvm":
        return None
    walk = _functions()[1]
    if walk is None:
        return None
    # every array is held by a name until the call returns: the kernel reads raw addresses
    Rc, tc = np.ascontiguousarray(R, dtype=float), np.ascontiguousarray(t, dtype=float)
    trees = _tree_arrays(tree_a, tree_b)
    capacity = max(64, 8 * len(Rc))
    while True:
        out = [np.empty(capacity, dtype=np.int64) for _ in range(3)]
        count = np.zeros(1, dtype=np.int64)
        walk(
            len(Rc),
            float(limit),
            Rc.ctypes.data,
            tc.ctypes.data,
            *[x.ctypes.data for x in trees],
            capacity,
            *[x.ctypes.data for x in out],
            count.ctypes.data,
        )
        found = int(count[0])
        if found < 0:  # a tree deeper than the kernel's stack: the numpy search answers
            return None
        if found <= capacity:
            return out[0][:found], out[1][:found], out[2][:found]
        capacity = found


def box_gap(tree_a, a, tree_b, b, k, R, t) -> np.ndarray | None:
    """:func:`rworld_cli.collision.bvh.box_gap` of node pairs ``a[q]``, ``b[q]`` at states
    ``k[q]`` of ``R`` (K, 3, 3), ``t`` (K, 3), compiled; None when no kernel is available."""
    if kernels.backend() != "llvm":
        return None
    function = _functions()[0]
    if function is None:
        return None
    out = np.empty(len(a))
    if not len(a):
        return out
    # every array is held by a name until the call returns: the kernel reads raw addresses
    index = [np.ascontiguousarray(x, dtype=np.int64) for x in (a, b, k)]
    floats = [
        np.ascontiguousarray(x, dtype=float)
        for x in (
            tree_a.center,
            tree_a.half,
            tree_a.axes,
            tree_b.center,
            tree_b.half,
            tree_b.axes,
            R,
            t,
        )
    ]
    function(
        len(a), *[x.ctypes.data for x in index], *[x.ctypes.data for x in floats], out.ctypes.data
    )
    return out
