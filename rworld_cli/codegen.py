"""A small straight-line code generator with constant folding, for the hot paths.

Why: the recursive kinematics and Newton-Euler formulas of a given device
contain many constants - DH twists of 0 or 90 degrees, zero link offsets,
zero centre-of-mass components, diagonal inertias.  The report exploits this
by hand (section 4, eqs. 6-9: "for most commercially available manipulators
the link twist angles are either 0 or 90 degrees").  We do it mechanically:
the formulas are written once against :class:`Emitter`, which folds every
operation with a constant 0, 1 or -1, shares common subexpressions, and emits
Python source with one operation per line.  The emitted program runs three ways:

* compiled to machine code by LLVM (:mod:`rworld_cli.kernels`): one loop over the samples
  with the straight-line body inside, on both cores for large batches - the default;
* as Python source on per-joint columns of shape ``(N,)`` - one numpy call per surviving
  operation, vectorised over all samples (no Python loop over samples) - the fallback when
  LLVM is unavailable or ``RWORLD_KERNELS=numpy``;
* as the same source on plain Python floats - a single state, in the fallback.

An operand (``Num``) is either a Python ``float`` (a folded constant) or the
name (``str``) of a generated variable or argument.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, TypeGuard

import numpy as np

Num = float | str
Vec = tuple  # tuple[Num, Num, Num]

_SNAP = 1e-14  # cos(pi/2) = 6e-17 is a zero twist term, not a number to multiply by


def snap(x: float) -> float:
    """Round values within 1e-14 of 0, +1 or -1 to them exactly (for sin/cos of DH twists)."""
    for target in (0.0, 1.0, -1.0):
        if abs(x - target) < _SNAP:
            return target
    return float(x)


class Emitter:
    """Collects generated lines; every method returns a folded constant or a variable name."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        # the same program as operations: (result name, (opcode, operands...)), for the compiler
        self.ops: list[tuple[str, tuple]] = []
        self._memo: dict[tuple, str] = {}
        self._count = 0

    def _emit(self, key: tuple, text: str) -> str:
        name = self._memo.get(key)
        if name is None:
            name = f"t{self._count}"
            self._count += 1
            self.lines.append(f"    {name} = {text}")
            self.ops.append((name, key))
            self._memo[key] = name
        return name

    @staticmethod
    def _const(x: Num) -> TypeGuard[float]:
        return isinstance(x, float)

    def mul(self, a: Num, b: Num) -> Num:
        if self._const(a) and self._const(b):
            return a * b
        if self._const(a):
            a, b = b, a
        if self._const(b):
            if b == 0.0:
                return 0.0
            if b == 1.0:
                return a
            if b == -1.0:
                return self.neg(a)
            return self._emit(("*c", a, b), f"{a} * {b!r}")
        x, y = sorted((a, b))
        return self._emit(("*", x, y), f"{x} * {y}")

    def add(self, a: Num, b: Num) -> Num:
        if self._const(a) and self._const(b):
            return a + b
        if self._const(a):
            a, b = b, a
        if self._const(b):
            if b == 0.0:
                return a
            return self._emit(("+c", a, b), f"{a} + {b!r}")
        x, y = sorted((a, b))
        return self._emit(("+", x, y), f"{x} + {y}")

    def sub(self, a: Num, b: Num) -> Num:
        if self._const(a) and self._const(b):
            return a - b
        if self._const(b):
            return self.add(a, -b)
        if self._const(a) and a == 0.0:
            return self.neg(b)
        if a == b:
            return 0.0
        return self._emit(("-", a, b), f"{a} - {b}" if not self._const(a) else f"{a!r} - {b}")

    def neg(self, a: Num) -> Num:
        if self._const(a):
            return -a
        return self._emit(("neg", a), f"-{a}")

    def div(self, a: Num, b: Num) -> Num:
        if self._const(a) and self._const(b):
            return a / b
        if self._const(a) and a == 0.0:
            return 0.0
        if self._const(b) and b == 1.0:
            return a
        text_a = repr(a) if self._const(a) else a
        text_b = repr(b) if self._const(b) else b
        return self._emit(("/", a, b), f"{text_a} / {text_b}")

    def call(self, fn: str, a: Num) -> Num:
        """``fn(a)`` for ``fn`` in cos, sin, sqrt."""
        if fn not in FUNCTIONS:
            raise ValueError(f"no generated function {fn!r}")
        if self._const(a):
            return snap(getattr(math, fn)(a))
        return self._emit((fn, a), f"{fn}({a})")

    def coulomb(self, velocity: Num, positive: float, negative: float) -> Num:
        """Coulomb friction torque: ``positive`` if velocity > 0, ``-negative`` if < 0, else 0."""
        if positive == 0.0 and negative == 0.0:
            return 0.0
        if self._const(velocity):
            return positive if velocity > 0 else -negative if velocity < 0 else 0.0
        return self._emit(
            ("coulomb", velocity, float(positive), float(negative)),
            f"coulomb({velocity}, {float(positive)!r}, {float(negative)!r})",
        )

    # ---------------------------------------------------------------- vectors
    def vadd(self, a: Vec, b: Vec) -> Vec:
        return tuple(self.add(x, y) for x, y in zip(a, b))

    def vsub(self, a: Vec, b: Vec) -> Vec:
        return tuple(self.sub(x, y) for x, y in zip(a, b))

    def vscale(self, s: Num, v: Vec) -> Vec:
        return tuple(self.mul(s, x) for x in v)

    def cross(self, a: Vec, b: Vec) -> Vec:
        return (
            self.sub(self.mul(a[1], b[2]), self.mul(a[2], b[1])),
            self.sub(self.mul(a[2], b[0]), self.mul(a[0], b[2])),
            self.sub(self.mul(a[0], b[1]), self.mul(a[1], b[0])),
        )

    def dot(self, a: Vec, b: Vec) -> Num:
        return self.add(self.add(self.mul(a[0], b[0]), self.mul(a[1], b[1])), self.mul(a[2], b[2]))

    def matvec(self, M: Sequence[Sequence[Num]], v: Vec) -> Vec:
        return tuple(self.dot(tuple(row), v) for row in M)

    def mattvec(self, M: Sequence[Sequence[Num]], v: Vec) -> Vec:
        return tuple(self.dot((M[0][j], M[1][j], M[2][j]), v) for j in range(3))

    def matmul(self, A, B):
        return tuple(
            tuple(self.dot(tuple(A[i]), (B[0][j], B[1][j], B[2][j])) for j in range(3))
            for i in range(3)
        )

    # ---------------------------------------------------------------- compile
    def compile(
        self,
        name: str,
        groups: Sequence[tuple[str, int]],
        outputs: Sequence[Num],
        shapes: Sequence[tuple[int, ...]] | None = None,
    ) -> Generated:
        """Wrap the program up: inputs in ``groups``, results ``outputs``.

        Parameters
        ----------
        name : str
            Function name (shows in tracebacks and in the compiled symbol).
        groups : sequence of (prefix, size)
            The inputs as arrays: group ``("q", 6)`` is the arguments ``q0 .. q5``, passed as one
            array of shape (6,) or (N, 6).
        outputs : sequence of Num
            Results, in order; names or folded constants.
        shapes : sequence of tuple of int, optional
            The one or two arrays a single state's results come in (:attr:`Generated.direct`),
            splitting ``outputs`` in order (row-major); default one array of all of them.
        """
        args = [f"{prefix}{i}" for prefix, size in groups for i in range(size)]
        body = "\n".join(self.lines)
        ret = ", ".join(o if isinstance(o, str) else repr(o) for o in outputs)
        source = (
            f"def {name}({', '.join(args)}):\n{body}\n    return "
            f"({ret}{',' if len(outputs) == 1 else ''})\n"
        )
        return Generated(name, source, list(groups), list(self.ops), list(outputs), shapes)


FUNCTIONS = ("cos", "sin", "sqrt")


def _coulomb_array(v, positive: float, negative: float):
    return np.where(v > 0, positive, np.where(v < 0, -negative, 0.0))


def _coulomb_scalar(v: float, positive: float, negative: float) -> float:
    return positive if v > 0 else -negative if v < 0 else 0.0


CHUNK = 2048  # samples per block: temporaries stay in cache and reuse the allocator's small blocks


_empty = np.empty


def _refuse(*inputs):
    return None  # no compiled kernel: always the general path


class Generated:
    """A generated function: its operations, its Python source, and how to run it.

    ``evaluate`` runs the compiled kernel when LLVM is available (:mod:`rworld_cli.kernels`),
    else the Python source on numpy columns (a batch) or on floats (one state).
    """

    def __init__(
        self,
        name: str,
        source: str,
        groups: list[tuple[str, int]],
        ops: list[tuple[str, tuple]],
        outputs: list[Num],
        shapes: Sequence[tuple[int, ...]] | None = None,
    ):
        self.name = name
        self.source = source
        self.groups = groups
        self.ops = ops
        self.outputs = outputs
        self.operations = len(ops)
        #: the arrays :attr:`direct` returns, splitting the outputs in order
        self.shapes = [tuple(shape) for shape in shapes] if shapes else [(len(outputs),)]
        if len(self.shapes) > 2 or sum(map(math.prod, self.shapes)) != len(outputs):
            raise ValueError(
                f"{name}: shapes {self.shapes} are not one or two arrays of {len(outputs)} outputs"
            )
        self._python: tuple[Callable, Callable] | None = None
        self._kernel: Any = None  # kernels.Kernel once looked up; False when unavailable
        #: ``direct(*inputs)``: one state the quickest way - an array of each of
        #: :attr:`shapes` (the array itself when there is one, else a pair) when the compiled
        #: kernel takes ``inputs`` as they are (exact float64 arrays, 1-D, of their groups'
        #: sizes), else None and the caller goes through :meth:`evaluate`, which converts or
        #: reports.  Built on the first call (an attribute, not a method: a single state pays
        #: for every Python frame).
        self.direct: Callable[..., Any] = self._first_direct

    @property
    def n_out(self) -> int:
        return len(self.outputs)

    def python(self) -> tuple[Callable, Callable]:
        """The source compiled by Python: (numpy-columns function, float function)."""
        if self._python is None:
            code = compile(self.source, f"<rworld generated {self.name}>", "exec")
            fns = []
            for lib, coulomb in ((np, _coulomb_array), (math, _coulomb_scalar)):
                namespace = {fn: getattr(lib, fn) for fn in FUNCTIONS}
                namespace["coulomb"] = coulomb
                exec(code, namespace)
                fns.append(namespace[self.name])
            self._python = (fns[0], fns[1])
        return self._python

    def kernel(self):
        """The compiled kernel, or None when compiled kernels are off or unavailable."""
        if self._kernel is None:
            from .kernels import compiled_kernel

            self._kernel = compiled_kernel(self) or False
        return self._kernel or None

    def _first_direct(self, *inputs: np.ndarray):
        self.direct = self._direct_call()
        return self.direct(*inputs)

    def _direct_call(self) -> Callable[..., Any]:
        """The function behind :attr:`direct`: the kernel's direct entry with fresh outputs."""
        kernel = self.kernel()
        entry = kernel.direct if kernel else None
        if entry is None:
            return _refuse
        shapes = self.shapes
        if len(shapes) == 1:
            (shape,) = shapes

            def one(*inputs):
                out = _empty(shape)
                return out if entry(*inputs, out) is out else None

            return one
        first, second = shapes

        def two(*inputs):
            a, b = _empty(first), _empty(second)
            return (a, b) if entry(*inputs, a, b) is a else None

        return two

    def evaluate(self, inputs: Sequence[np.ndarray], compiled: bool = True) -> np.ndarray:
        """Run on one state or a batch.

        Parameters
        ----------
        inputs : sequence of ndarray
            One float array per group, in order: shape (size,) - the same for every sample,
            or one state - or (N, size).
        compiled : bool
            Use the compiled kernel when there is one (False: the numpy source, for comparisons).

        Returns
        -------
        ndarray, shape (n_out,) when every input is 1-D, else (N, n_out)

        Why chunks in the numpy fallback: on arrays of 1e5 samples each of the hundreds of
        temporaries is a fresh 800 kB allocation that the C library maps and
        page-faults anew; blocks of 2048 samples stay in cache and run 3-6x faster.
        """
        kernel = self._kernel
        if kernel is None:
            kernel = self.kernel()
        if kernel and compiled:
            return kernel(inputs)
        array_fn, scalar_fn = self.python()
        if all(x.ndim == 1 for x in inputs):
            return np.array(scalar_fn(*(v for x in inputs for v in x.tolist())), dtype=float)
        N = next(len(x) for x in inputs if x.ndim == 2)
        columns: list = []
        for x in inputs:
            columns += x.tolist() if x.ndim == 1 else list(np.ascontiguousarray(x.T))
        out = np.empty((N, self.n_out))
        for start in range(0, N, CHUNK):
            stop = min(start + CHUNK, N)
            values = array_fn(*(c if isinstance(c, float) else c[start:stop] for c in columns))
            for k, v in enumerate(values):
                out[start:stop, k] = v
        return out
