"""Joint-space paths q(s), s in [0, 1]: piecewise cubic polynomials."""

from __future__ import annotations

from dataclasses import dataclass

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
        self.knots = (
            np.linspace(0.0, 1.0, len(self.waypoints))
            if knots is None
            else np.asarray(knots, dtype=float)
        )
        if (
            self.knots.shape != (len(self.waypoints),)
            or np.any(np.diff(self.knots) <= 0)
            or self.knots[0] != 0
            or self.knots[-1] != 1
        ):
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
        """(breaks, coefficients): breaks shape (P + 1,); coefficients shape (4, P, n), highest
        power first,
        in powers of (s - breaks[p]) on piece p (scipy's PPoly layout, padded to cubic)."""
        c = self.spline.c
        if c.shape[0] < 4:
            c = np.concatenate([np.zeros((4 - c.shape[0],) + c.shape[1:]), c])
        return self.spline.x, c

    def evaluate(self, s):
        """q, dq/ds, d2q/ds2 at ``s`` (shape (N,)), each (N, n)."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
        return self.spline(s), self.d1(s), self.d2(s)

    def extrema(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The exact range of every joint over s in [0, 1]: (q_min, s_min, q_max, s_max), each shape
        (n,).

        On each cubic piece the candidates are its two ends and the roots of q'(s) inside it
        (a quadratic), so an excursion between waypoints is found wherever it peaks.
        """
        breaks, c = self.pieces  # c: (4, P, n), powers of (s - breaks[p]), highest first
        h = np.diff(breaks)[:, None]  # (P, 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            roots = quadratic_roots(
                c[2], 2.0 * c[1], 3.0 * c[0]
            )  # q' = c2 + 2 c1 sigma + 3 c0 sigma^2
        candidates = [np.zeros_like(c[0]), np.broadcast_to(h, c[0].shape)]
        for r in roots:
            candidates.append(np.where(np.isfinite(r) & (r > 0) & (r < h), r, 0.0))
        sigma = np.stack(candidates)  # (4, P, n)
        value = ((c[0] * sigma + c[1]) * sigma + c[2]) * sigma + c[3]
        s_at = breaks[:-1][None, :, None] + sigma
        value, s_at = value.reshape(-1, self.dof), s_at.reshape(-1, self.dof)
        lo, hi = np.argmin(value, axis=0), np.argmax(value, axis=0)
        cols = np.arange(self.dof)
        return value[lo, cols], s_at[lo, cols], value[hi, cols], s_at[hi, cols]


@dataclass
class RangeExcursion:
    """A joint that leaves its position range along a path (SI)."""

    joint: int  # 0-based
    s: float  # path parameter where it peaks
    value: float  # its value there [rad or m]
    limit: float  # the limit it passes
    side: str  # "lower" | "upper"


def range_excursions(
    path: JointPath, lower, upper, tolerance: float = 1e-9
) -> list[RangeExcursion]:
    """Joints whose exact extremum along ``path`` passes ``lower`` / ``upper`` (shape (n,), inf:
    none).
    """
    q_min, s_min, q_max, s_max = path.extrema()
    out = []
    for j in range(path.dof):
        if q_min[j] < lower[j] - tolerance:
            out.append(
                RangeExcursion(j, float(s_min[j]), float(q_min[j]), float(lower[j]), "lower")
            )
        if q_max[j] > upper[j] + tolerance:
            out.append(
                RangeExcursion(j, float(s_max[j]), float(q_max[j]), float(upper[j]), "upper")
            )
    return out


def quadratic_roots(c0, c1, c2):
    """Both roots of c0 + c1 t + c2 t^2 (nan where there are none), stable for c2 -> 0 (then one
    root).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = c1 * c1 - 4.0 * c2 * c0
        root = np.sqrt(np.where(disc >= 0, disc, np.nan))
        qq = -0.5 * (c1 + np.copysign(root, c1))
        return qq / c2, c0 / qq
