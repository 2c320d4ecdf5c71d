"""Constraints on a timed path, as objects: each gives its bounds on the grid and its check between
grid points.

Along a path q(s) with x = sdot^2 and u = sddot, a constraint is either

* a bound on x alone at each grid point (:meth:`Constraint.x_bound`: joint velocity), or
* rows ``lo <= A u + B x <= hi`` at each grid point (:meth:`Constraint.grid_rows`: joint
  acceleration ``q' u + q'' x``; torque ``a u + b x + c``),

and between grid points it says where a timing exceeds it and by which factor on x that
interval must be slowed (:meth:`Constraint.excess`).  The time-optimal algorithm
(``topp.py``) sees only this protocol: a new constraint is a new class here.

Every constraint holds per joint; ``inf`` for a joint means that joint is unlimited in it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from .path import JointPath, quadratic_roots


class InfeasiblePath(Exception):
    """No timing satisfies the limits (e.g. gravity alone exceeds a torque limit)."""


@dataclass
class GridRows:
    """Constraints ``lo <= A u + B x <= hi`` per grid point: arrays of shape (N + 1, C), one
    label per column.
    """

    A: np.ndarray
    B: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    labels: list[str]


@dataclass
class Excess:
    """Where a timing exceeds a constraint between grid points.

    ``interval`` (K,): grid intervals; ``factor`` (K,): the factor on x (at both ends of the
    interval)
    that brings each back within the limit; ``label`` (K,): what is exceeded; ``worst``: the largest
    |value| / limit found anywhere (1 or less when nothing is exceeded).
    """

    interval: np.ndarray
    factor: np.ndarray
    label: np.ndarray
    worst: float

    @staticmethod
    def none(worst: float = 0.0) -> Excess:
        return Excess(np.zeros(0, dtype=int), np.zeros(0), np.zeros(0, dtype=object), worst)


class Constraint(Protocol):
    kind: str  # "velocity", "acceleration", "torque", ...

    def prepare(self, path: JointPath, s: np.ndarray) -> None:
        """Precompute what the constraint needs on the grid ``s`` (called once per solve)."""

    def x_bound(self, grid: PathGrid, margin: float) -> np.ndarray | None:
        """Upper bound on x per grid point (N + 1,), ``margin`` (relative) inside the limit; or
        None.
        """

    def grid_rows(self, grid: PathGrid, margin: float) -> GridRows | None:
        """Its rows in (u, x) per grid point, ``margin`` inside the limit; or None."""

    def excess(self, timing, between: BetweenGridPoints, repair_margin: float) -> Excess:
        """Where ``timing`` exceeds the constraint between grid points, and the factors that fix
        it.
        """


@dataclass
class PathGrid:
    """The path at the grid points: s (N + 1,), q, q', q'' (N + 1, n)."""

    s: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray


# --------------------------------------------------------------------------- between grid points


class Segments:
    """The grid intervals cut at the path's polynomial breaks: per segment its interval and the
    local cubic.

    On a segment starting at s_a, with sigma = s - s_a: q'(sigma) = d1 + d2 sigma + d3 sigma^2.
    """

    def __init__(self, path: JointPath, s: np.ndarray):
        breaks, coef = path.pieces
        cuts = np.union1d(s, breaks[(breaks > s[0]) & (breaks < s[-1])])
        sa, sb = cuts[:-1], cuts[1:]
        mid = 0.5 * (sa + sb)
        self.interval = np.clip(np.searchsorted(s, mid) - 1, 0, len(s) - 2)
        piece = np.clip(np.searchsorted(breaks, mid) - 1, 0, coef.shape[1] - 1)
        tau = (sa - breaks[piece])[:, None]
        c3, c2, c1 = coef[0, piece], coef[1, piece], coef[2, piece]  # (S, n)
        self.d1 = (3.0 * c3 * tau + 2.0 * c2) * tau + c1  # q'(s_a)
        self.d2 = 6.0 * c3 * tau + 2.0 * c2  # q''(s_a)
        self.d3 = 3.0 * c3  # q'''/2
        self.offset = sa - s[self.interval]  # s_a - s_i
        self.length = (sb - sa)[:, None]


class BetweenGridPoints:
    """A timing on every segment between grid points: the exact peaks of joint speed and
    acceleration.

    On a cubic piece with x linear in s, qdd is a quadratic in s and d(qd^2)/ds = 2 q' qdd, so the
    candidates are the segment's ends, the vertex of qdd and its roots.  Computed when first asked.
    """

    def __init__(self, timing, segments: Segments):
        self.timing = timing
        self.segments = segments
        seg = segments
        k = seg.interval
        self.interval = k
        self.uu = timing.u[k][:, None]
        self.xa = (timing.x[k] + 2.0 * timing.u[k] * seg.offset)[:, None]
        # joint acceleration on the segment: A0 + A1 sigma + A2 sigma^2
        self.A0 = self.uu * seg.d1 + seg.d2 * self.xa
        self.A1 = 3.0 * self.uu * seg.d2 + 2.0 * seg.d3 * self.xa
        self.A2 = 5.0 * self.uu * seg.d3
        self._acc = self._speed = None

    def _inside(self, t):
        return np.isfinite(t) & (t > 0) & (t < self.segments.length)

    def acceleration_peak(self) -> np.ndarray:
        """max |qdd| per segment and joint (S, n)."""
        if self._acc is None:
            A0, A1, A2, L = self.A0, self.A1, self.A2, self.segments.length

            def acc(t):
                return A0 + (A1 + A2 * t) * t

            with np.errstate(divide="ignore", invalid="ignore"):
                vertex = -A1 / (2.0 * A2)
            peak = np.maximum(np.abs(A0), np.abs(acc(L)))
            inside = self._inside(vertex)
            self._acc = np.where(
                inside, np.maximum(peak, np.abs(acc(np.where(inside, vertex, 0.0)))), peak
            )
        return self._acc

    def speed_peak(self) -> np.ndarray:
        """max |qd| per segment and joint (S, n)."""
        if self._speed is None:
            seg, uu, xa = self.segments, self.uu, self.xa

            def speed2(t):
                qs = seg.d1 + (seg.d2 + seg.d3 * t) * t
                return qs * qs * np.maximum(xa + 2.0 * uu * t, 0.0)

            v2 = np.maximum(speed2(0.0), speed2(seg.length))
            for r in quadratic_roots(
                self.A0, self.A1, self.A2
            ):  # interior maxima sit where qdd = 0
                ok = self._inside(r)
                v2 = np.where(ok, np.maximum(v2, speed2(np.where(ok, r, 0.0))), v2)
            self._speed = np.sqrt(v2)
        return self._speed


def _per_segment_excess(
    ratio: np.ndarray,
    scale: np.ndarray,
    interval: np.ndarray,
    names: list[str],
    repair_margin: float,
) -> Excess:
    """Excess from per-segment ratios (S, n) and the factor each would need (S, n)."""
    worst = float(ratio.max(initial=0.0))
    f = np.where(ratio > 1.0, scale * (1.0 - repair_margin), 1.0)
    col = np.argmin(f, axis=1)
    f_seg = f[np.arange(len(f)), col]
    over = f_seg < 1.0
    return Excess(interval[over], f_seg[over], np.array(names, dtype=object)[col[over]], worst)


# --------------------------------------------------------------------------- the joint limits


class JointVelocity:
    """|qd_j| <= v_j: on the grid x <= (v_j / |q'_j|)^2; between grid points the exact speed
    peak.
    """

    kind = "velocity"

    def __init__(self, limit):
        self.limit = np.asarray(limit, dtype=float)

    def prepare(self, path, s) -> None:
        pass

    def x_bound(self, grid: PathGrid, margin: float) -> np.ndarray:
        v = self.limit * (1.0 - margin)
        with np.errstate(divide="ignore", over="ignore"):
            return np.min(
                np.where(np.abs(grid.dq) > 1e-12, (v / np.abs(grid.dq)) ** 2, np.inf), axis=1
            )

    def grid_rows(self, grid, margin):
        return None

    def excess(self, timing, between: BetweenGridPoints, repair_margin: float) -> Excess:
        ratio = between.speed_peak() / self.limit
        names = [f"velocity {j + 1}" for j in range(ratio.shape[1])]
        return _per_segment_excess(
            ratio, 1.0 / np.maximum(ratio**2, 1e-300), between.interval, names, repair_margin
        )


class JointAcceleration:
    """|qdd_j| <= a_j with qdd = q' u + q'' x: rows on the grid; between grid points the exact
    peak.
    """

    kind = "acceleration"

    def __init__(self, limit):
        self.limit = np.asarray(limit, dtype=float)

    def prepare(self, path, s) -> None:
        pass

    def x_bound(self, grid, margin):
        return None

    def grid_rows(self, grid: PathGrid, margin: float) -> GridRows:
        amax = np.broadcast_to(self.limit * (1.0 - margin), grid.q.shape)
        return GridRows(
            grid.dq,
            grid.ddq,
            -amax,
            amax,
            [f"acceleration {j + 1}" for j in range(grid.q.shape[1])],
        )

    def excess(self, timing, between: BetweenGridPoints, repair_margin: float) -> Excess:
        ratio = between.acceleration_peak() / self.limit
        names = [f"acceleration {j + 1}" for j in range(ratio.shape[1])]
        return _per_segment_excess(
            ratio, 1.0 / np.maximum(ratio, 1e-300), between.interval, names, repair_margin
        )


def path_coefficients(path: JointPath, s: np.ndarray, dynamics=None, gravity=None):
    """Per grid point: q', q'', and the torque coefficients (a_t, b_t, c_t) if dynamics is given."""
    q, dq, ddq = path.evaluate(s)
    if dynamics is None:
        return q, dq, ddq, None
    zero = np.zeros_like(q)
    g = np.zeros(3)
    a_t = dynamics.inverse(q, zero, dq, g)  # M q' (armature included)
    b_t = dynamics.inverse(q, dq, ddq, g)  # M q'' + C(q, q') q'
    c_t = dynamics.gravity_torques(q, gravity)
    return q, dq, ddq, (a_t, b_t, c_t)


def check_cells(intervals: int) -> int:
    """Default number of fine cells of the torque bound for ``intervals`` grid intervals: four
    per interval, at least 1 000.

    The bound's margin shrinks with the square of the cell width; at 1 000 cells on the bench's
    paths it is about 1e-5 of the limit, well inside the repair's own margin, and the
    coefficients then cost three batched Newton-Euler passes of a few thousand samples.
    """
    return max(1000, 4 * intervals)


class JointTorque:
    """|tau_j| <= tau_max_j with tau = a u + b x + c (a = M q', b = M q'' + C(q, q') q', c = g(q)).

    The coefficients come from the batched Newton-Euler (``dynamics``: armature, payload and carried
    loads as configured there; no friction) on a fine grid of s fixed before the first solve
    (``check_samples`` points; every grid point and spline break is one of them, so each fine cell
    lies in one grid interval, where u is constant and x linear, and in one cubic piece).  On the
    grid they give the rows; between grid points, on a fine cell of width h, |tau| is at most the
    larger of its two ends plus h^2/8 max|d2tau/ds2| (the error bound of linear interpolation), with
    d2tau/ds2 = a'' u + b'' x + 4 b' u + c'' bounded term by term from second differences of the
    coefficients (not across a break), doubled.  Every check is arithmetic, not Newton-Euler.
    """

    kind = "torque"
    SAFETY = 2.0  # on the curvature estimated by second differences
    # A torque repair shifts the neighbours' sddot, which can push their torque over in turn:
    # aiming 1e-4 inside (on x, about 5e-5 of the local speed) ends that cascade in two to four
    # solves on the bench's paths, where 1e-6 took up to twelve.
    repair_margin = 1e-4

    def __init__(self, limit, dynamics, gravity=None, check_samples: int | None = None):
        if getattr(dynamics, "_has_friction", False):
            raise ValueError(
                "torque constraints take dynamics without friction (friction is not affine in "
                "sddot and sdot^2)"
            )
        self.limit = np.asarray(limit, dtype=float)
        self.dynamics = dynamics
        self.gravity = gravity
        self.check_samples = check_samples

    def prepare(self, path: JointPath, s: np.ndarray) -> None:
        N = len(s) - 1
        cells = check_cells(N) if self.check_samples is None else self.check_samples - 1
        per_interval = max(1, int(np.ceil(cells / N)))
        sub = (
            s[:-1, None] + np.diff(s)[:, None] * (np.arange(per_interval) / per_interval)
        ).ravel()
        breaks = path.pieces[0]
        inner = breaks[(breaks > s[0]) & (breaks < s[-1])]
        fine = np.union1d(np.append(sub, s[-1]), inner)
        self.grid_index = np.searchsorted(fine, s)
        family = getattr(self.dynamics, "torque_coefficients", None)  # payload.PointMassFamily
        if family is not None:
            a, b, c = family(path, fine, self.gravity)
        else:
            _, _, _, (a, b, c) = path_coefficients(path, fine, self.dynamics, self.gravity)
        self.a, self.b, self.c = a, b, c
        h = np.diff(fine)
        mid = 0.5 * (fine[:-1] + fine[1:])
        self.interval = np.clip(np.searchsorted(s, mid, side="right") - 1, 0, N - 1)
        self.offset0 = (
            fine[:-1] - s[self.interval]
        )  # a fine cell's ends, from its grid interval's start
        self.offset1 = fine[1:] - s[self.interval]
        smooth = ~np.isin(fine[1:-1], inner)  # second differences only inside a cubic piece
        n = a.shape[1]
        f = np.concatenate([a, b, c], axis=1)  # the three at once: (P, 3n)
        slope = np.diff(f, axis=0) / h[:, None]  # per cell
        d = np.abs(np.diff(slope, axis=0)) * (2.0 / (h[1:] + h[:-1]))[:, None]  # per inner point
        d[~smooth] = 0.0
        # a cell's estimate: the largest at its two ends and their neighbours (edge values
        # repeated), i.e. a window of four over d padded by two at each end
        padded = np.concatenate([d[:1], d[:1], d, d[-1:], d[-1:]])
        pairs = np.maximum(padded[:-1], padded[1:])
        curvature = self.SAFETY * np.maximum(pairs[:-2], pairs[2:])  # (P - 1, 3n)
        a2, b2, c2 = curvature[:, :n], curvature[:, n : 2 * n], curvature[:, 2 * n :]
        b1 = np.abs(slope[:, n : 2 * n]) + h[:, None] * b2
        w = (h * h / 8.0)[:, None]
        self.e_u = w * (a2 + 4.0 * b1)  # the bound's margin: e_u |u| + e_x x + e_c
        self.e_x = w * b2
        self.e_c = w * c2

    def x_bound(self, grid, margin):
        return None

    def grid_rows(self, grid: PathGrid, margin: float) -> GridRows:
        k = self.grid_index
        a, b, c = self.a[k], self.b[k], self.c[k]
        tmax = np.broadcast_to(self.limit * (1.0 - margin), a.shape)
        return GridRows(
            a, b, -tmax - c, tmax - c, [f"torque {j + 1}" for j in range(a.shape[1])]
        )  # inf where no limit

    def excess(self, timing, between, repair_margin: float) -> Excess:
        a, b, c = self.a, self.b, self.c
        k = self.interval
        u = timing.u[k][:, None]
        x0 = (timing.x[k] + 2.0 * timing.u[k] * self.offset0)[:, None]
        x1 = (timing.x[k] + 2.0 * timing.u[k] * self.offset1)[:, None]
        t0 = a[:-1] * u + b[:-1] * x0 + c[:-1]
        t1 = a[1:] * u + b[1:] * x1 + c[1:]
        bound = np.maximum(np.abs(t0), np.abs(t1))
        bound += self.e_u * np.abs(u) + self.e_x * np.maximum(x0, x1) + self.e_c
        ratio = bound / self.limit
        worst = float(ratio.max(initial=0.0))
        rows, cols = np.nonzero(ratio > 1.0)
        if not len(rows):
            return Excess.none(worst)
        # only where it is exceeded: the end that binds, its sign and its gravity part
        t0, t1 = t0[rows, cols], t1[rows, cols]
        right = np.abs(t1) > np.abs(t0)
        side = np.where(np.where(right, t1, t0) >= 0, 1.0, -1.0)
        grav = np.where(right, c[1:][rows, cols], c[:-1][rows, cols])
        room = side * self.limit[cols] - grav  # what the motion part may use
        if np.any(room * side <= 0):
            raise InfeasiblePath("gravity alone exceeds a torque limit on the path")
        motion = side * bound[rows, cols] - grav  # the bound less gravity: it scales with timing
        labels = np.array([f"torque {j + 1}" for j in range(a.shape[1])], dtype=object)[cols]
        return Excess(k[rows], room / motion * (1.0 - repair_margin), labels, worst)
