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
    sqrt = module.declare_intrinsic("llvm.sqrt", [D])
    fabs = module.declare_intrinsic("llvm.fabs", [D])
    entry = fn.append_basic_block("entry")
    head = fn.append_basic_block("head")
    body = fn.append_basic_block("body")
    done = fn.append_basic_block("done")
    b = ir.IRBuilder(entry)
    b.branch(head)
    b.position_at_end(head)
    q = b.phi(I64, name="q")
    q.add_incoming(ir.Constant(I64, 0), entry)
    b.cbranch(b.icmp_signed("<", q, Q), body, done)
    b.position_at_end(body)

    def c(x: float):
        return ir.Constant(D, float(x))

    def row(pointer, base, count):
        return [b.load(b.gep(pointer, [b.add(base, ir.Constant(I64, j))])) for j in range(count)]

    def mul(x, y):
        return b.fmul(x, y)

    def add(*xs):
        total = xs[0]
        for x in xs[1:]:
            total = b.fadd(total, x)
        return total

    def sub(x, y):
        return b.fsub(x, y)

    def absolute(x):
        return b.call(fabs, [x])

    def maximum(x, y):
        return b.select(b.fcmp_ordered(">", x, y), x, y)

    def three(index):
        return b.mul(index, ir.Constant(I64, 3))

    def nine(index):
        return b.mul(index, ir.Constant(I64, 9))

    a = b.load(b.gep(ia, [q]))
    bb = b.load(b.gep(ib, [q]))
    k = b.load(b.gep(ik, [q]))
    Ua = row(ua, nine(a), 9)  # rows: Ua[3 i + j]
    Ub = row(ub, nine(bb), 9)
    hA = row(ha, three(a), 3)
    hB = row(hb, three(bb), 3)
    cA = row(ca, three(a), 3)
    cB = row(cb, three(bb), 3)
    R = row(Rp, nine(k), 9)
    t = row(tp, three(k), 3)
    # W = R Ub^T (3 x 3): W[i][j] = sum_l R[i][l] Ub[j][l]; M = Ua W
    W = [
        [add(*[mul(R[3 * i + l], Ub[3 * j + l]) for l in range(3)]) for j in range(3)]
        for i in range(3)
    ]
    M = [
        [add(*[mul(Ua[3 * i + l], W[l][j]) for l in range(3)]) for j in range(3)] for i in range(3)
    ]
    # p = Ua (R cB + t - cA)
    world = [sub(add(*[mul(R[3 * i + l], cB[l]) for l in range(3)], t[i]), cA[i]) for i in range(3)]
    p = [add(*[mul(Ua[3 * i + l], world[l]) for l in range(3)]) for i in range(3)]
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
        return b.call(sqrt, [add(*[mul(x, x) for x in clipped])])

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
            length = b.call(sqrt, [maximum(sub(c(1.0), mul(M[i][j], M[i][j])), c(0.0))])
            gap = b.fdiv(sub(sub(across, reach_a), reach_b), maximum(length, c(1e-6)))
            gap = b.select(b.fcmp_ordered(">", length, c(1e-6)), gap, c(-np.inf))
            edge = maximum(edge, gap)
    inside = maximum(
        maximum(maximum(*along_a[:2]), along_a[2]), maximum(maximum(*along_b[:2]), along_b[2])
    )
    inside = maximum(inside, edge)
    result = b.select(
        b.fcmp_ordered(">", inside, c(0.0)), maximum(maximum(apart_a, apart_b), edge), inside
    )
    b.store(result, b.gep(out, [q]))
    q_next = b.add(q, ir.Constant(I64, 1))
    q.add_incoming(q_next, b.block)
    b.branch(head)
    b.position_at_end(done)
    b.ret_void()
    return str(module)


_FUNCTION: list = []  # [ctypes function or None], built once per process


def box_gap_function():
    """The compiled bound as a ctypes function, or None (kernels off, or the compile failed)."""
    if not _FUNCTION:
        import ctypes

        source = Path(__file__).read_text()
        symbol = f"rworld_box_gap_{hashlib.sha256(source.encode()).hexdigest()[:20]}"
        addresses = kernels.compile_ir("box gap", lambda: box_gap_ir(symbol), [symbol], source)
        _FUNCTION.append(
            None
            if addresses is None
            else ctypes.CFUNCTYPE(None, ctypes.c_int64, *[ctypes.c_void_p] * 12)(addresses[0])
        )
    return _FUNCTION[0]


def box_gap(tree_a, a, tree_b, b, k, R, t) -> np.ndarray | None:
    """:func:`rworld_cli.collision.bvh.box_gap` of node pairs ``a[q]``, ``b[q]`` at states
    ``k[q]`` of ``R`` (K, 3, 3), ``t`` (K, 3), compiled; None when no kernel is available."""
    if kernels.backend() != "llvm":
        return None
    function = box_gap_function()
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
