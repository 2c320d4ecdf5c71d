"""Joint-space paths q(s), s in [0, 1]: piecewise cubic polynomials."""

from __future__ import annotations

import numpy as np


class JointPath:
    """A cubic spline through joint waypoints.

    Parameters
    ----------
    waypoints : array_like, shape (K, n)
        Joint values [rad or m] at the knots.
    knots : array_like, shape (K,), optional
        Path parameters of the waypoints; default equally spaced on [0, 1].
    boundary : {"clamped", "natural", "not-a-knot"}
        ``clamped``: dq/ds = 0 at both ends (start and end at rest).
    """

    def __init__(self, waypoints, knots=None, boundary: str = "clamped"):
        from scipy.interpolate import CubicSpline

        self.waypoints = np.asarray(waypoints, dtype=float)
        if self.waypoints.ndim != 2 or len(self.waypoints) < 2:
            raise ValueError("a path needs at least 2 waypoints of n joint values")
        self.boundary = boundary
        self.knots = np.linspace(0.0, 1.0, len(self.waypoints)) if knots is None else np.asarray(knots, dtype=float)
        if self.knots.shape != (len(self.waypoints),) or np.any(np.diff(self.knots) <= 0) or self.knots[0] != 0 or self.knots[-1] != 1:
            raise ValueError("knots must rise strictly from 0 to 1, one per waypoint")
        self._set_polynomial(CubicSpline(self.knots, self.waypoints, bc_type=boundary))

    def _set_polynomial(self, poly) -> None:
        """``poly``: a scipy PPoly of degree <= 3 on [0, 1], values of shape (n,)."""
        self.spline = poly
        self.d1 = poly.derivative(1)
        self.d2 = poly.derivative(2)

    @property
    def dof(self) -> int:
        return self.waypoints.shape[1]

    @property
    def pieces(self) -> tuple[np.ndarray, np.ndarray]:
        """(breaks, coefficients): breaks shape (P + 1,); coefficients shape (4, P, n), highest power first,
        in powers of (s - breaks[p]) on piece p (scipy's PPoly layout, padded to cubic)."""
        c = self.spline.c
        if c.shape[0] < 4:
            c = np.concatenate([np.zeros((4 - c.shape[0],) + c.shape[1:]), c])
        return self.spline.x, c

    def evaluate(self, s):
        """q, dq/ds, d2q/ds2 at ``s`` (shape (N,)), each (N, n)."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
        return self.spline(s), self.d1(s), self.d2(s)
