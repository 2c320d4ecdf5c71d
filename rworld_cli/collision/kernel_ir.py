"""One builder for what the compiled box-tree kernels share: a function of a declared
signature in a module of its own, counted loops, slots, the walk's stack of node pairs, and the
scalar arithmetic of the bound (:mod:`rworld_cli.collision.bvh_ir`,
:mod:`rworld_cli.collision.free_states_ir`).

A kernel's signature is a tuple of argument kinds (:data:`I64`, :data:`F64`, :data:`DPTR`,
:data:`IPTR`); the same tuple makes the LLVM function type (:func:`function_type`) and the
ctypes prototype the caller uses (:func:`prototype`), so the two cannot disagree.

llvmlite is imported inside the functions: this module is read only when a kernel is built.
"""

from __future__ import annotations

import numpy as np

I64, F64, DPTR, IPTR = "i64", "double", "double*", "i64*"
# a box tree as the kernels read it: centre (N, 3), half extents (N, 3), axes (N, 9: rows),
# left, right (N,) and item (N,: a leaf's row, an inner node's minus its leaf count)
TREE = (DPTR, DPTR, DPTR, IPTR, IPTR, IPTR)
# a body's leaf table: V, vertices, neighbours, D, pose (12), estimate flag, axes, centres
LEAVES = (I64, DPTR, IPTR, I64, DPTR, I64, DPTR, DPTR)
STACK = 512  # node pairs pending in a walk: depth of both trees at the most, with room


def llvm_type(kind: str):
    """The llvmlite type of an argument kind."""
    import llvmlite.ir as ir

    D, I = ir.DoubleType(), ir.IntType(64)
    return {I64: I, F64: D, DPTR: ir.PointerType(D), IPTR: ir.PointerType(I)}[kind]


def function_type(signature: tuple):
    """``void f(...)`` of the argument kinds in ``signature``, as an llvmlite type."""
    import llvmlite.ir as ir

    return ir.FunctionType(ir.VoidType(), [llvm_type(kind) for kind in signature])


def prototype(signature: tuple):
    """The ctypes prototype of ``void f(...)`` of ``signature`` (pointers as addresses)."""
    import ctypes

    kinds: dict[str, type[ctypes._SimpleCData]] = {I64: ctypes.c_int64, F64: ctypes.c_double}
    kinds[DPTR] = kinds[IPTR] = ctypes.c_void_p
    return ctypes.CFUNCTYPE(None, *[kinds[kind] for kind in signature])


class Emit:
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

    def load(self, pointer, index):
        """``pointer[index]``."""
        return self.b.load(self.b.gep(pointer, [index]))

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

    def minimum(self, x, y):
        return self.b.select(self.b.fcmp_ordered("<", x, y), x, y)

    def length(self, v):
        """The length of a 3-vector."""
        return self.b.call(self.sqrt, [self.add(*[self.b.fmul(x, x) for x in v])])

    def rotate(self, R, p):
        """``R p`` for ``R`` (9, rows) and ``p`` (3)."""
        b = self.b
        return [self.add(*[b.fmul(R[3 * r + m], p[m]) for m in range(3)]) for r in range(3)]

    def apply(self, R, t, p):
        """``R p + t`` for ``R`` (9, rows), ``t`` and ``p`` (3)."""
        b = self.b
        return [self.add(*[b.fmul(R[3 * r + m], p[m]) for m in range(3)], t[r]) for r in range(3)]

    def state(self, R, t, k):
        """State ``k``'s ``T_a_b``: ``R`` (9) and ``t`` (3) read from the (K, 9), (K, 3) tables."""
        b = self.b
        return self.row(R, b.mul(k, self.i(9)), 9), self.row(t, b.mul(k, self.i(3)), 3)

    def node(self, tree, index):
        """A node's (axes (9), half extents (3), centre (3)) of ``tree`` (its centre, half
        and axes pointers first)."""
        centre, half, axes = tree[:3]
        b = self.b
        return (
            self.row(axes, b.mul(index, self.i(9)), 9),
            self.row(half, b.mul(index, self.i(3)), 3),
            self.row(centre, b.mul(index, self.i(3)), 3),
        )

    def is_leaf(self, tree, index):
        """The node's item and whether it is a leaf (an item of 0 or more)."""
        item = self.load(tree[5], index)
        return item, self.b.icmp_signed(">=", item, self.i(0))

    def children(self, A, B, na, nb, leaf_a, leaf_b, hA, hB):
        """The two child pairs (left, then right) of the inner pair (``na``, ``nb``), split as
        :func:`rworld_cli.collision.bvh._split` splits it: the node with the larger box (sum of
        half extents), or the one that is not a leaf."""
        b = self.b
        larger = b.fcmp_ordered(">=", self.add(*hA), self.add(*hB))
        split_a = b.and_(b.not_(leaf_a), b.or_(leaf_b, larger))
        pairs = []
        for side in (3, 4):  # left, then right
            child_a = b.select(split_a, self.load(A[side], na), na)
            child_b = b.select(split_a, nb, self.load(B[side], nb))
            pairs.append((child_a, child_b))
        return pairs

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
        world = [sub(x, cA[i]) for i, x in enumerate(self.apply(R, t, cB))]
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
            return self.length([maximum(v, c(0.0)) for v in values])

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


class Kernel(Emit):
    """``void symbol(signature)`` in an LLVM module of its own, the builder in its entry
    block; ``args`` its arguments.  ``text()`` is the module's IR."""

    def __init__(self, name: str, symbol: str, signature: tuple, noalias: bool = False):
        import llvmlite.ir as ir

        self.module = ir.Module(name=name)
        self.fn = ir.Function(self.module, function_type(signature), name=symbol)
        self.args = self.fn.args
        if noalias:
            for arg in self.args:
                if arg.type.is_pointer:
                    arg.add_attribute("noalias")
        super().__init__(ir.IRBuilder(self.fn.append_basic_block("entry")), self.module)

    def declare(self, symbol: str, signature: tuple):
        """A function of this module's link unit, defined by another module."""
        return self.ir.Function(self.module, function_type(signature), name=symbol)

    def block(self, name: str):
        return self.fn.append_basic_block(name)

    def _alloca(self, kind, name: str):
        # in the entry block, wherever the builder is: an alloca inside a loop would grow the
        # stack frame at every turn
        here = self.b.block
        self.b.position_at_start(self.fn.entry_basic_block)
        slot = self.b.alloca(kind, name=name)
        self.b.position_at_end(here)
        return slot

    def slot(self, kind, name: str, value=None):
        """A variable on the function's stack frame (``kind``: :data:`I64`, :data:`F64`, or an
        llvmlite type), stored ``value`` (where the builder is) when one is given."""
        slot = self._alloca(llvm_type(kind) if isinstance(kind, str) else kind, name)
        if value is not None:
            self.b.store(value, slot)
        return slot

    def array(self, kind, count: int, name: str, values=None):
        """``count`` values of ``kind`` on the stack frame, filled from ``values`` if given."""
        kind = llvm_type(kind) if isinstance(kind, str) else kind
        array = self._alloca(self.ir.ArrayType(kind, count), name)
        for j, value in enumerate(values or ()):
            self.b.store(self.c(value) if kind == self.D else self.i(value), self.cell(array, j))
        return array

    def cell(self, array, j):
        """The address of ``array[j]`` (``j`` an int or an i64 value)."""
        return self.b.gep(array, [self.i(0), self.i(j) if isinstance(j, int) else j])

    def first(self, array, kind):
        """``array`` as a pointer of ``kind`` (what a call takes)."""
        return self.b.bitcast(self.cell(array, 0), llvm_type(kind))

    def for_each(self, count, name: str, after, start: int = 0):
        """Open ``for index in range(start, count)``, leaving the builder in the body: (the
        index's slot, the block that steps to the next index - a body ends by branching there,
        or to ``after`` to leave early).  ``after`` is where the loop goes when done."""
        b = self.b
        index = self.slot(I64, name, self.i(start))
        head, body, step = self.block(f"{name}_head"), self.block(name), self.block(f"{name}_next")
        b.branch(head)
        b.position_at_end(head)
        b.cbranch(b.icmp_signed("<", b.load(index), count), body, after)
        b.position_at_end(step)
        b.store(b.add(b.load(index), self.i(1)), index)
        b.branch(head)
        b.position_at_end(body)
        return index, step

    def text(self) -> str:
        return str(self.module)


class PairStack:
    """The node pairs a depth-first walk of two box trees has yet to look at, on the kernel's
    stack frame (:data:`STACK` deep); with ``bounds``, each pair's lower bound beside it."""

    def __init__(self, kernel: Kernel, bounds: bool = False):
        self.k = kernel
        self.a = kernel.array(I64, STACK, "stack_a")
        self.b = kernel.array(I64, STACK, "stack_b")
        self.g = kernel.array(F64, STACK, "stack_g") if bounds else None
        self.top = kernel.slot(I64, "top")
        self.next = None  # the block that pops the next pair (a pair's code ends there)

    def start(self, bound=None):
        """The roots' pair as the only one pending."""
        k = self.k
        k.b.store(k.i(0), k.cell(self.a, 0))
        k.b.store(k.i(0), k.cell(self.b, 0))
        if self.g is not None:
            k.b.store(bound, k.cell(self.g, 0))
        k.b.store(k.i(1), self.top)

    def pop(self, empty):
        """Branch to the popping loop and leave the builder where the top pair is popped: its
        (a, b, bound or None); ``empty`` is where the loop goes when none is left."""
        k, b = self.k, self.k.b
        self.next, body = k.block("pop_head"), k.block("pop_body")
        b.branch(self.next)
        b.position_at_end(self.next)
        b.cbranch(b.icmp_signed(">", b.load(self.top), k.i(0)), body, empty)
        b.position_at_end(body)
        top = b.sub(b.load(self.top), k.i(1))
        b.store(top, self.top)
        g = None if self.g is None else b.load(k.cell(self.g, top))
        return b.load(k.cell(self.a, top)), b.load(k.cell(self.b, top)), g

    def push_two(self, first, second, overflow):
        """Push two pairs, ``first`` ((a, b) or (a, b, bound)) on top, so looked at first, and
        go on popping; with no room for them (a tree far deeper than it should be),
        ``overflow()`` is emitted instead (it ends the function)."""
        k, b = self.k, self.k.b
        top = b.load(self.top)
        push, full = k.block("push"), k.block("overflow")
        b.cbranch(b.icmp_signed("<=", b.add(top, k.i(2)), k.i(STACK)), push, full)
        b.position_at_end(push)
        for at, pair in ((top, second), (b.add(top, k.i(1)), first)):
            for stack, value in zip((self.a, self.b, self.g), pair):
                b.store(value, k.cell(stack, at))
        b.store(b.add(top, k.i(2)), self.top)
        b.branch(self.next)
        b.position_at_end(full)
        overflow()
