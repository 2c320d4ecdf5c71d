"""Joint-space paths q(s), s in [0, 1]: piecewise cubic polynomials."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.paths import MAX_BLEND


class JointPath:
    """A cubic spline through joint waypoints.

    Parameters
    ----------
    waypoints : array_like, shape (K, n)
        Joint values [rad or m] at the knots.
    knots : array_like, shape (K,), optional
        Path parameters of the waypoints; default equally spaced on [0, 1].
    boundary : {"clamped", "natural", "not-a-knot", "segments", "blended"}
        ``clamped``: dq/ds = 0 at both ends (start and end at rest); ``natural``: d2q/ds2 = 0
        there; ``not-a-knot``: the third derivative is continuous at the second and the
        second-last knot; ``segments``: dq/ds = 0 at every knot, so that each piece runs
        along the straight joint-space segment between its waypoints (``q_i + (q_{i+1} -
        q_i)(3u^2 - 2u^3)``), at rest at each: the lines a collision-free path was checked
        on (``rworld plan path``), not a spline through them.  The others are the same
        splines as ``scipy.interpolate.CubicSpline`` with that ``bc_type`` (tested to 1e-12),
        built here: importing scipy's interpolation costs about half a second, more than a
        whole time-optimal solve.  ``blended``: the segments' straight lines, with each
        interior corner whose ``blends`` entry is above 0 cut by a parabolic blend
        (:func:`blended_pieces`): the path keeps moving through it; a corner at 0 is passed
        at rest, as under ``segments``.  Its knots follow the joint-space length
        (:func:`length_knots`), so that the blends' curves - what was checked - are fixed by
        the waypoints and blends alone: other knots are refused.
    blends : array_like, shape (K,), optional
        ``blended`` only: per waypoint, the blend's half-width as a fraction of the shorter
        of its two knot intervals, in [0, 0.5] (the ends: 0).  Default: all 0 (the
        segments).
    """

    def __init__(self, waypoints, knots=None, boundary: str = "clamped", blends=None):
        self.waypoints = np.asarray(waypoints, dtype=float)
        if self.waypoints.ndim != 2 or len(self.waypoints) < 2:
            raise ValueError("a path needs at least 2 waypoints of n joint values")
        self.boundary = boundary
        if boundary == "blended":
            by_length = length_knots(self.waypoints)
            if knots is not None and not np.allclose(knots, by_length, rtol=0, atol=1e-9):
                raise ValueError("a blended path's knots follow its joint-space lengths: give none")
            knots = by_length
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
        if boundary == "blended":
            self.blends = (
                np.zeros(len(self.waypoints))
                if blends is None
                else np.asarray(blends, dtype=float).ravel()
            )
            self._set_polynomial(*blended_pieces(self.knots, self.waypoints, self.blends))
            return
        if blends is not None:
            raise ValueError("blends are for boundary 'blended'")
        self.blends = None
        slopes = spline_slopes(self.knots, self.waypoints, boundary)
        self._set_polynomial(self.knots, hermite_coefficients(self.knots, self.waypoints, slopes))

    def _set_polynomial(self, breaks: np.ndarray, coefficients: np.ndarray) -> None:
        """``breaks`` (P + 1,) on [0, 1]; ``coefficients`` (4, P, n), highest power first, in
        powers of (s - breaks[p]) on piece p."""
        self._breaks = np.asarray(breaks, dtype=float)
        self._coef = np.asarray(coefficients, dtype=float)

    @property
    def dof(self) -> int:
        return self.waypoints.shape[1]

    @property
    def pieces(self) -> tuple[np.ndarray, np.ndarray]:
        """(breaks, coefficients): breaks shape (P + 1,); coefficients shape (4, P, n), highest
        power first, in powers of (s - breaks[p]) on piece p (scipy's PPoly layout)."""
        return self._breaks, self._coef

    def evaluate(self, s):
        """q, dq/ds, d2q/ds2 at ``s`` (shape (N,)), each (N, n)."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
        breaks, c = self._breaks, self._coef
        piece = np.clip(np.searchsorted(breaks, s, side="right") - 1, 0, c.shape[1] - 1)
        t = (s - breaks[piece])[:, None]
        c3, c2, c1, c0 = c[0, piece], c[1, piece], c[2, piece], c[3, piece]  # (N, n) each
        q = ((c3 * t + c2) * t + c1) * t + c0
        dq = (3.0 * c3 * t + 2.0 * c2) * t + c1
        ddq = 6.0 * c3 * t + 2.0 * c2
        return q, dq, ddq

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


def length_knots(waypoints) -> np.ndarray:
    """Path parameters of a polyline's waypoints (W, n) by joint-space length (Euclidean), 0
    to 1 (W,); equally spaced when it has no length."""
    waypoints = np.asarray(waypoints, dtype=float)
    if len(waypoints) < 2:
        return np.zeros(len(waypoints))
    lengths = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(waypoints, axis=0), axis=1))]
    return lengths / lengths[-1] if lengths[-1] > 0 else np.linspace(0.0, 1.0, len(waypoints))


def blend_corners(knots: np.ndarray, values: np.ndarray, blends: np.ndarray) -> np.ndarray:
    """Each waypoint's blend as its three control states: (K, 3, n) - where the blend leaves
    the incoming segment, the corner, where it joins the outgoing one (all three the corner
    where there is no blend).  The blend is the quadratic Bezier curve of those three, inside
    their triangle (so inside the joint box when they are)."""
    tau, slopes = _blend_widths(knots, values, blends)
    out = np.repeat(values[:, None, :], 3, axis=1)
    inner = np.arange(1, len(values) - 1)
    out[inner, 0] -= tau[inner, None] * slopes[inner - 1]
    out[inner, 2] += tau[inner, None] * slopes[inner]
    return out


def blend_half_widths(knots, blends) -> np.ndarray:
    """Each waypoint's blend half-width in s (K,): its ``blends`` fraction (K,) of the shorter
    knot interval beside it (0 at the ends)."""
    knots = np.asarray(knots, dtype=float)
    blends = np.asarray(blends, dtype=float).ravel()
    K = len(knots)
    if blends.shape != (K,) or not np.all((blends >= 0) & (blends <= MAX_BLEND)):
        raise ValueError(f"blends: one per waypoint, each in [0, {MAX_BLEND}]")
    if K > 2 and (blends[0] != 0 or blends[-1] != 0):
        raise ValueError("the path's ends are not blended (they are at rest)")
    h = np.diff(knots)
    tau = np.zeros(K)
    if K > 2:
        tau[1:-1] = blends[1:-1] * np.minimum(h[:-1], h[1:])
    return tau


def _blend_widths(knots, values, blends):
    """(tau (K,): each blend's half-width in s, slopes (K - 1, n): each segment's dq/ds)."""
    knots, values = np.asarray(knots, dtype=float), np.asarray(values, dtype=float)
    if len(values) != len(knots):
        raise ValueError("blends: one per waypoint")
    return blend_half_widths(knots, blends), np.diff(values, axis=0) / np.diff(knots)[:, None]


def blended_pieces(knots, values, blends) -> tuple[np.ndarray, np.ndarray]:
    """The pieces of the ``blended`` path: (breaks (P + 1,), coefficients (4, P, n)) in the
    :attr:`JointPath.pieces` layout.

    Segment i runs along its chord from waypoint i to i + 1 over s in [knots[i],
    knots[i+1]], slope ``v_i = (q_{i+1} - q_i) / h_i``.  A corner k with half-width
    ``tau_k = blends[k] min(h_{k-1}, h_k)`` > 0 replaces s in [knots[k] - tau_k, knots[k] +
    tau_k] by the parabola ``q_k - tau_k v_{k-1} + v_{k-1} t + (v_k - v_{k-1}) t^2 / (4
    tau_k)``, t from 0 to 2 tau_k: it leaves the incoming line and joins the outgoing one
    with their slopes (dq/ds continuous; d2q/ds2 steps).  Between blends each segment's
    remaining piece is the cubic along its chord with slope ``v_i`` at a blended end and 0
    at an end at rest (``t + t^2 - t^3`` of the piece, or ``3t^2 - 2t^3`` with both at rest:
    monotone, never off the chord).  All blends 0 gives the ``segments`` path exactly.
    """
    knots, values = np.asarray(knots, dtype=float), np.asarray(values, dtype=float)
    tau, slopes = _blend_widths(knots, values, blends)
    breaks: list[float] = [0.0]
    pieces: list[np.ndarray] = []
    n = values.shape[1]
    for i in range(len(values) - 1):
        a, b = knots[i] + tau[i], knots[i + 1] - tau[i + 1]
        if tau[i] > 0:  # the blend about waypoint i
            width = 2.0 * tau[i]
            pieces.append(
                np.stack(
                    [
                        np.zeros(n),
                        (slopes[i] - slopes[i - 1]) / (2.0 * width),
                        slopes[i - 1],
                        values[i] - tau[i] * slopes[i - 1],
                    ]
                )
            )
            breaks.append(knots[i] + tau[i])
        if b - a > 1e-15 * max(1.0, abs(b)):  # the line between (none when two blends meet)
            q0 = values[i] + tau[i] * slopes[i]
            q1 = values[i + 1] - tau[i + 1] * slopes[i]
            m0 = slopes[i] if tau[i] > 0 else np.zeros(n)
            m1 = slopes[i] if tau[i + 1] > 0 else np.zeros(n)
            pieces.append(
                hermite_coefficients(np.array([a, b]), np.stack([q0, q1]), np.stack([m0, m1]))[:, 0]
            )
            breaks.append(b)
    breaks[-1] = 1.0
    return np.array(breaks), np.stack(pieces, axis=1)


def quadratic_roots(c0, c1, c2):
    """Both roots of c0 + c1 t + c2 t^2 (nan where there are none), stable for c2 -> 0 (then one
    root).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = c1 * c1 - 4.0 * c2 * c0
        root = np.sqrt(np.where(disc >= 0, disc, np.nan))
        qq = -0.5 * (c1 + np.copysign(root, c1))
        return qq / c2, c0 / qq


def hermite_coefficients(knots: np.ndarray, values: np.ndarray, slopes: np.ndarray) -> np.ndarray:
    """The cubic pieces through ``values`` (K, n) with ``slopes`` (K, n) at ``knots`` (K,):
    coefficients (4, K - 1, n), highest power first, in powers of (s - knots[p])."""
    h = np.diff(knots)[:, None]
    delta = np.diff(values, axis=0) / h
    m0, m1 = slopes[:-1], slopes[1:]
    return np.stack(
        [(m0 + m1 - 2.0 * delta) / (h * h), (3.0 * delta - 2.0 * m0 - m1) / h, m0, values[:-1]]
    )


def spline_slopes(knots: np.ndarray, values: np.ndarray, boundary: str) -> np.ndarray:
    """The slopes (K, n) at the knots of the C2 cubic spline through ``values`` (K, n).

    Interior knots: continuity of the second derivative,
    ``h_i m_{i-1} + 2 (h_{i-1} + h_i) m_i + h_{i-1} m_{i+1} = 3 (h_i d_{i-1} + h_{i-1} d_i)``
    with h the knot spacings and d the chord slopes; the ends by ``boundary`` (see
    :class:`JointPath`; not-a-knot's first and last rows are reduced to two terms with their
    neighbours', as scipy does).  Two knots under not-a-knot or natural give the chord, three
    under not-a-knot the parabola through them (scipy's special cases).  A tridiagonal solve
    (Thomas algorithm) over the K knots, each step vectorised over the n joints.
    """
    if boundary not in ("clamped", "natural", "not-a-knot", "segments"):
        raise ValueError(f"unknown spline boundary {boundary!r}")
    if boundary == "segments":  # at rest at every knot: each piece runs along its chord
        return np.zeros_like(values, dtype=float)
    K = len(knots)
    h = np.diff(knots)
    d = np.diff(values, axis=0) / h[:, None]  # (K - 1, n)
    if K == 2 and boundary != "clamped":
        return np.stack([d[0], d[0]])
    if K == 3 and boundary == "not-a-knot":
        curve = (d[1] - d[0]) / (h[0] + h[1])  # the parabola's second derivative / 2
        return np.stack(
            [d[0] - curve * h[0], d[0] + curve * h[0], d[0] + curve * (h[0] + 2 * h[1])]
        )
    lower, diag, upper = np.zeros(K), np.ones(K), np.zeros(K)  # row i: m_{i-1}, m_i, m_{i+1}
    rhs = np.zeros_like(values)
    lower[1:-1], diag[1:-1], upper[1:-1] = h[1:], 2.0 * (h[:-1] + h[1:]), h[:-1]
    rhs[1:-1] = 3.0 * (h[1:, None] * d[:-1] + h[:-1, None] * d[1:])
    if boundary == "natural":
        diag[0], upper[0], rhs[0] = 2.0, 1.0, 3.0 * d[0]
        lower[-1], diag[-1], rhs[-1] = 1.0, 2.0, 3.0 * d[-1]
    elif boundary == "not-a-knot":
        span = h[0] + h[1]
        diag[0], upper[0] = h[1], span
        rhs[0] = ((h[0] + 2.0 * span) * h[1] * d[0] + h[0] ** 2 * d[1]) / span
        span = h[-1] + h[-2]
        lower[-1], diag[-1] = span, h[-2]
        rhs[-1] = (h[-1] ** 2 * d[-2] + (2.0 * span + h[-1]) * h[-2] * d[-1]) / span
    # clamped: the first and last rows say m = 0, as they stand
    for i in range(K):  # forward elimination
        pivot = diag[i] - (lower[i] * upper[i - 1] if i else 0.0)
        upper[i] /= pivot
        rhs[i] = (rhs[i] - (lower[i] * rhs[i - 1] if i else 0.0)) / pivot
    for i in range(K - 2, -1, -1):  # back substitution
        rhs[i] -= upper[i] * rhs[i + 1]
    return rhs
