"""A small straight-line code generator with constant folding, for the hot paths.

Why: the recursive kinematics and Newton-Euler formulas of a given device
contain many constants - DH twists of 0 or 90 degrees, zero link offsets,
zero centre-of-mass components, diagonal inertias.  The report exploits this
by hand (section 4, eqs. 6-9: "for most commercially available manipulators
the link twist angles are either 0 or 90 degrees").  We do it mechanically:
the formulas are written once against :class:`Emitter`, which folds every
operation with a constant 0, 1 or -1, shares common subexpressions, and emits
Python source with one operation per line.  Compiled, that source runs

* on per-joint columns of shape ``(N,)`` - one numpy call per surviving
  operation, vectorised over all samples (no Python loop over samples), and
* on plain Python floats - a single state with no numpy overhead at all.

An operand (``Num``) is either a Python ``float`` (a folded constant) or the
name (``str``) of a generated variable or argument.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

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
        self._memo: dict[tuple, str] = {}
        self._count = 0

    def _emit(self, key: tuple, text: str) -> str:
        name = self._memo.get(key)
        if name is None:
            name = f"t{self._count}"
            self._count += 1
            self.lines.append(f"    {name} = {text}")
            self._memo[key] = name
        return name

    @staticmethod
    def _const(x: Num) -> bool:
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

    def call(self, fn: str, a: Num) -> Num:
        if self._const(a):
            return snap(getattr(math, fn)(a))
        return self._emit((fn, a), f"{fn}({a})")

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
    def compile(self, name: str, args: Sequence[str], outputs: Sequence[Num]) -> Generated:
        """Compile to two functions (numpy and math) returning the outputs as a tuple."""
        body = "\n".join(self.lines)
        ret = ", ".join(o if isinstance(o, str) else repr(o) for o in outputs)
        source = (
            f"def {name}({', '.join(args)}):\n{body}\n    return "
            f"({ret}{',' if len(outputs) == 1 else ''})\n"
        )
        code = compile(source, f"<rworld generated {name}>", "exec")
        fns = {}
        for label, lib in (("array", np), ("scalar", math)):
            namespace = {"cos": lib.cos, "sin": lib.sin}
            exec(code, namespace)
            fns[label] = namespace[name]
        return Generated(source, fns["array"], fns["scalar"], len(self.lines))


CHUNK = 2048  # samples per block: temporaries stay in cache and reuse the allocator's small blocks


class Generated:
    """A generated function in two flavours: numpy columns, or Python floats."""

    def __init__(self, source: str, array_fn: Callable, scalar_fn: Callable, operations: int):
        self.source = source
        self.array = array_fn
        self.scalar = scalar_fn
        self.operations = operations

    def evaluate(
        self, columns: Sequence, constants: Sequence[float], n_out: int, single: bool
    ) -> np.ndarray:
        """Run on one state or a batch.

        Parameters
        ----------
        columns : sequence
            Per-argument values: floats (``single``) or contiguous arrays of shape (N,).
        constants : sequence of float
            Trailing arguments shared by all samples (e.g. gravity).
        n_out : int
            Number of outputs.

        Returns
        -------
        ndarray, shape (n_out,) or (N, n_out)

        Why chunks: on arrays of 1e5 samples each of the hundreds of
        temporaries is a fresh 800 kB allocation that the C library maps and
        page-faults anew; blocks of 2048 samples stay in cache and run 3-6x faster.
        """
        if single:
            return np.array(self.scalar(*columns, *constants), dtype=float)
        N = len(columns[0]) if columns else 1
        out = np.empty((N, n_out))
        for start in range(0, N, CHUNK):
            stop = min(start + CHUNK, N)
            values = self.array(*(c[start:stop] for c in columns), *constants)
            for k, v in enumerate(values):
                out[start:stop, k] = v
        return out
