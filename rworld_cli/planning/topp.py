"""Time-optimal timing of a joint path under velocity, acceleration and torque limits.

Reachability analysis as in TOPP-RA (Pham & Pham 2018).  Along a path
q(s), s in [0, 1], with x = sdot^2 and u = sddot:

* joint velocity   qd  = q'(s) sdot                  -> x <= (v_max / |q'|)^2
* acceleration     qdd = q'(s) u + q''(s) x          -> |a u + b x| <= a_max
* torque           tau = a_t u + b_t x + c_t          -> |.| <= tau_max
  with a_t = M q', b_t = M q'' + C(q, q') q', c_t = g(q) from the batched
  Newton-Euler (``DeviceDynamics``: armature in M, payload folded in).

On a grid s_0 < ... < s_N (``gridpoints`` = N + 1 points, as in toppra), u is
constant on each interval and x is linear in s (x_{i+1} = x_i + 2 ds u).
Acceleration and torque limits are imposed at both ends of each interval
("interpolation"), velocity limits at the grid points.  Each stage's
constraints are linear in (u, x); eliminating u (Fourier-Motzkin) gives the
feasible x as an interval - the part that does not depend on the
neighbouring stage is computed for all stages at once, vectorised.  A
backward pass builds the controllable sets K_i (from rest at the end); a
forward pass takes the largest u that stays controllable (from rest at the
start).

Between grid points the path's curvature varies, so a limit can be exceeded
there.  After each solve the exact maxima of joint velocity and acceleration
on every interval are found in closed form (on a cubic piece with x linear
in s, qdd is a quadratic in s and d(qd^2)/ds = 2 q' qdd, so the candidates are
the ends, the vertex and the roots of qdd).  Torque is bounded on a fine grid
of s fixed before the first solve (``check_samples`` points, every grid point
and spline break among them): its coefficients a_t, b_t, c_t are computed
there once, so every later check is arithmetic, not Newton-Euler.  On each
fine cell, with u and the interval's x known, |tau| is at most the larger of
its two ends plus h^2/8 max|d2 tau/ds2| (the error bound of linear
interpolation), and d2 tau/ds2 = a_t'' u + b_t'' x + 4 b_t' u + c_t'' is
bounded from second differences of the coefficients, doubled.  An interval
whose bound exceeds a limit gets its two grid points capped at the speed
that fixes it (scaling x on an interval scales qd by sqrt, qdd and the
motion torque linearly), and the passes run again - a local slow-down, where
the excess is.  If that has not settled after a few rounds, the whole timing
is slowed uniformly by the factor the check asks for.  Either way the
returned trajectory respects every limit between grid points as well
(velocity and acceleration exactly, torque by the bound).

A joint with no limit of a kind (``inf``) is unlimited in that kind, for that
joint alone; the other joints' limits of the kind still hold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UserError
from ..units import MAX_SAMPLES
from .constraints import (  # noqa: F401  (Constraint: the protocol, re-exported)
    BetweenGridPoints,
    Constraint,
    InfeasiblePath,
    JointAcceleration,
    JointTorque,
    JointVelocity,
    PathGrid,
    Segments,
)
from .path import JointPath

__all__ = [
    "InfeasiblePath",
    "Limits",
    "Timing",
    "time_optimal",
    "time_optimal_constrained",
    "constraints_from_limits",
    "sample_path",
    "sample_instants",
    "sample_trajectory",
    "limit_ratios",
    "Samples",
]


@dataclass
class Limits:
    """Joint limits for planning (SI), shape (n,) each.

    ``inf`` for one joint: that joint is unlimited in that kind, the others keep theirs.
    ``None`` for a kind: no joint is limited in it (e.g. torque limits switched off).
    """

    velocity: np.ndarray
    acceleration: np.ndarray | None
    effort: np.ndarray | None

    def unlimited(self) -> dict[str, list[int]]:
        """Per kind ('velocity', 'acceleration', 'torque'), the 0-based joints with no limit of
        it.
        """
        out = {}
        for kind, values in (
            ("velocity", self.velocity),
            ("acceleration", self.acceleration),
            ("torque", self.effort),
        ):
            if values is not None:
                free = np.flatnonzero(~np.isfinite(np.asarray(values, dtype=float))).tolist()
                if free:
                    out[kind] = free
        return out


@dataclass
class Timing:
    """A time law s(t) on a grid: piecewise-constant sddot.

    Attributes
    ----------
    s : ndarray, shape (N + 1,)
    x : ndarray, shape (N + 1,)
        sdot^2 at the grid points.
    u : ndarray, shape (N,)
        sddot on each interval.
    t : ndarray, shape (N + 1,)
        Time at the grid points [s].
    scale : float
        The uniform slow-down, applied only when the local repairs did not settle (1 = none).
    """

    s: np.ndarray
    x: np.ndarray
    u: np.ndarray
    t: np.ndarray
    scale: float = 1.0

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def sample(self, times: np.ndarray, interval: np.ndarray | None = None):
        """s, sdot, sddot at ``times`` (vectorised).

        ``interval`` (same shape, optional) names the grid interval whose sddot applies - at a grid
        instant, ``k - 1`` gives the limit from the left; by default the interval that starts there.
        """
        times = np.clip(np.asarray(times, dtype=float), 0.0, self.duration)
        if interval is None:
            interval = np.searchsorted(self.t, times, side="right") - 1
        k = np.clip(interval, 0, len(self.u) - 1)
        tau = times - self.t[k]
        sd0 = np.sqrt(np.maximum(self.x[k], 0.0))
        u = self.u[k]
        return self.s[k] + sd0 * tau + 0.5 * u * tau**2, sd0 + u * tau, u


def _times(s: np.ndarray, x: np.ndarray) -> np.ndarray:
    sd = np.sqrt(np.maximum(x, 0.0))
    dt = 2.0 * np.diff(s) / np.maximum(sd[:-1] + sd[1:], 1e-300)
    return np.concatenate([[0.0], np.cumsum(dt)])


_MARGIN = 1e-9  # the grid solution aims this far (relative) inside the limits
# A repair aims this far inside: capping one interval moves its neighbours' sddot a little, and a
# margin well above the torque bound's own keeps them from needing another round.  A constraint
# may ask for more (``repair_margin``: the torque bound, whose repairs cascade).
_REPAIR_MARGIN = 1e-6
# After a repair, an excess this small (value over limit) is taken out by slowing the whole timing
# - about 1e-5 of the cycle time at most - rather than by more rounds, each a full solve.
_SETTLE = 1e-5


def _per_stage(mask, *arrays):
    """For each array (N, w): per row i, the plain list of its elements where ``mask`` (one
    tolist, then slices).
    """
    stops = np.cumsum(mask.sum(axis=1)).tolist()
    starts = [0] + stops[:-1]
    return tuple(
        [flat[a:b] for a, b in zip(starts, stops)] for flat in (v[mask].tolist() for v in arrays)
    )


class _Stages:
    """The grid problem: per stage i (interval [s_i, s_i+1]) the bounds on u as lines in x_i,
    pruned.

    ``up_Q[i]``, ``up_P[i]``, ``up_row[i]``: u <= P + Q x_i (and the constraint row it came from);
    ``lw_hi``, ``lw_lo``: (G0, G1), the stage's lower bounds on u met with reachability:
    x_i <= (resp. >=) g0 + g1 K_hi_i+1 for g0, g1 in zip(G0[i], G1[i]);
    ``x_lo``, ``x_hi``: the x_i interval where the stage is feasible at all.
    """

    EPS = 1e-12

    def __init__(self, grid: PathGrid, constraints: list):
        s = grid.s
        self.s = s
        self.ds = np.diff(s)
        stages = len(s) - 1
        eps = self.EPS
        # the grid solution sits a hair inside every limit, so rounding never puts a grid point just
        # over it
        self.xvel = np.full(len(s), np.inf)
        A, B, LO, HI, labels = [], [], [], [], []
        for c in constraints:
            bound = c.x_bound(grid, _MARGIN)
            if bound is not None:
                self.xvel = np.minimum(self.xvel, bound)
            rows = c.grid_rows(grid, _MARGIN)
            if rows is not None:  # per grid point, lo <= A u + B x <= hi, shape (N + 1, C)
                A.append(rows.A), B.append(rows.B), LO.append(rows.lo), HI.append(rows.hi)
                labels += rows.labels
        x_hi = self.xvel[
            :-1
        ].copy()  # the velocity bound at the stage's own point (point i+1 is stage i+1's)
        x_lo = np.zeros(stages)
        if A:
            A, B, LO, HI = (np.concatenate(v, axis=1) for v in (A, B, LO, HI))
            # interpolation: stage i holds the constraints of point i and of point i+1 with x_{i+1}
            # = x_i + 2 ds u
            two_ds = 2.0 * self.ds[:, None]
            alpha = np.concatenate([A[:-1], A[1:] + two_ds * B[1:]], axis=1)  # (N, 2C)
            beta = np.concatenate([B[:-1], B[1:]], axis=1)
            lo = np.concatenate([LO[:-1], LO[1:]], axis=1)
            hi = np.concatenate([HI[:-1], HI[1:]], axis=1)
        else:
            alpha = beta = lo = hi = np.zeros((stages, 0))
        self.labels = labels + labels
        with np.errstate(divide="ignore", invalid="ignore"):
            # a constraint without u bounds x alone
            xonly = np.abs(alpha) <= eps
            bound_hi = np.where(beta > eps, hi / beta, np.where(beta < -eps, lo / beta, np.inf))
            bound_lo = np.where(beta > eps, lo / beta, np.where(beta < -eps, hi / beta, -np.inf))
            x_hi = np.minimum(x_hi, np.where(xonly, bound_hi, np.inf).min(axis=1, initial=np.inf))
            x_lo = np.maximum(x_lo, np.where(xonly, bound_lo, -np.inf).max(axis=1, initial=-np.inf))
            # otherwise each constraint is one upper and one lower bound on u, lines in x with the
            # same slope
            positive = alpha > 0
            slope = np.where(xonly, 0.0, -beta / alpha)
            coef_P = np.where(xonly, np.inf, np.where(positive, hi, lo) / alpha)  # u <= P + Q x
            coef_p = np.where(xonly, -np.inf, np.where(positive, lo, hi) / alpha)  # u >= p + q x

        # Only bounds on the envelope over a stage's x interval matter: a line that another line
        # beats at
        # both ends of the interval is beaten all along it.  Sorted by the value at one end, a line
        # survives when it is strictly better at the other end than every line before it (exact
        # pruning,
        # vectorised over all stages).  It runs over the x range the velocity allows, before
        # pairing;
        # the stage's final interval and any caps added later lie inside it, so the pruning stays
        # exact.
        ends = np.stack([x_lo, np.minimum(np.maximum(x_hi, x_lo), 1e12)], axis=1)  # (N, 2)

        def envelope(const, sign):
            """Lines of ``const + slope x`` that can attain the min (sign 1) or max (sign -1),
            compacted first.
            """
            with np.errstate(invalid="ignore"):
                at_lo = sign * (const + slope * ends[:, :1])
                at_hi = sign * (const + slope * ends[:, 1:])
            at_lo = np.where(np.isfinite(at_lo), at_lo, np.inf)  # never binds
            at_hi = np.where(np.isfinite(at_lo), at_hi, np.inf)
            order = np.argsort(
                at_lo, axis=1
            )  # ties in any order: a line dropped is still beaten at both ends
            hi_sorted = np.take_along_axis(at_hi, order, axis=1)
            best_before = np.minimum.accumulate(
                np.concatenate([np.full((len(order), 1), np.inf), hi_sorted[:, :-1]], axis=1),
                axis=1,
            )
            keep = (hi_sorted < best_before) & np.isfinite(np.take_along_axis(at_lo, order, axis=1))
            width = max(int(keep.sum(axis=1).max(initial=0)), 1)
            first = np.argsort(~keep, axis=1, kind="stable")[:, :width]
            pick = np.take_along_axis(order, first, axis=1)
            ok = np.take_along_axis(keep, first, axis=1)
            return pick, ok

        if alpha.shape[1]:
            up_pick, up_ok = envelope(coef_P, 1.0)
            lw_pick, lw_ok = envelope(coef_p, -1.0)
        else:
            up_pick = lw_pick = np.zeros((stages, 1), dtype=int)
            up_ok = lw_ok = np.zeros((stages, 1), dtype=bool)
            slope = coef_P = coef_p = np.zeros((stages, 1))
        coef_Q = np.where(up_ok, np.take_along_axis(slope, up_pick, axis=1), 0.0)
        coef_P = np.where(up_ok, np.take_along_axis(coef_P, up_pick, axis=1), np.inf)
        coef_q = np.where(lw_ok, np.take_along_axis(slope, lw_pick, axis=1), 0.0)
        coef_p = np.where(lw_ok, np.take_along_axis(coef_p, lw_pick, axis=1), -np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            d = (
                coef_q[:, :, None] - coef_Q[:, None, :]
            )  # every (lower, upper) pair of a stage: d x <= rhs
            rhs = coef_P[:, None, :] - coef_p[:, :, None]
            pair = lw_ok[:, :, None] & up_ok[:, None, :]
            x_hi = np.minimum(
                x_hi, np.where(pair & (d > eps), rhs / d, np.inf).min(axis=(1, 2), initial=np.inf)
            )
            x_lo = np.maximum(
                x_lo,
                np.where(pair & (d < -eps), rhs / d, -np.inf).max(axis=(1, 2), initial=-np.inf),
            )
            infeasible_pair = pair & (np.abs(d) <= eps) & (rhs < 0)
        if np.any(x_lo > x_hi + 1e-12) or infeasible_pair.any():
            k = int(np.argmax((x_lo > x_hi + 1e-12) | infeasible_pair.any(axis=(1, 2))))
            raise InfeasiblePath(
                f"no speed satisfies the limits at s = {s[k]:.4f} of the path (even at rest: "
                "check gravity against the torque limits)"
            )
        self.x_lo, self.x_hi = x_lo, x_hi
        # per stage, plain lists of the surviving lines for the sequential passes
        self.up_Q, self.up_P, self.up_row = _per_stage(up_ok, coef_Q, coef_P, up_pick)
        # The backward pass meets each line with the reachability lines of slope a = -1 / (2 ds).
        # An upper line against reach-lower gives a bound (P - K_lo' / h) / (a - Q): a constant
        # while
        # K_lo' = 0 (the usual case), precomputed here.  A lower line against reach-upper gives
        # g0 + g1 K_hi' with g0 = -p / (q - a), g1 = 1 / (h (q - a)).
        h = 2.0 * self.ds[:, None]
        slope_a = -1.0 / h
        with np.errstate(divide="ignore", invalid="ignore"):
            dd = slope_a - coef_Q
            bound = coef_P / dd
            self.up_hi0 = np.where(up_ok & (dd > eps), bound, np.inf).min(axis=1)
            self.up_lo0 = np.where(up_ok & (dd < -eps), bound, -np.inf).max(axis=1)
            dd = coef_q - slope_a
            g0, g1 = -coef_p / dd, 1.0 / (h * dd)

        self.lw_hi = _per_stage(lw_ok & (dd > eps), g0, g1)  # x_i <= g0 + g1 K_hi'
        self.lw_lo = _per_stage(lw_ok & (dd < -eps), g0, g1)  # x_i >= g0 + g1 K_hi'

    def backward(
        self, caps: np.ndarray, end_at_rest: bool, previous=None
    ) -> tuple[list, list, int]:
        """Controllable sets [K_lo_i, K_hi_i] of x_i, from the end (at rest, or at any allowed
        speed).

        ``caps`` (N + 1,): extra upper bounds on x at the grid points (inf: none).
        ``previous``: (K_lo, K_hi, caps) of an earlier pass.  Set i depends only on set i+1 and
        on the stage and cap at i, so the pass starts at the last changed cap and stops, below
        the first one, where a set comes out as before: a repair round costs what it changes.

        Returns
        -------
        K_lo, K_hi : list of float, N + 1 each
        lowest : int
            The lowest index whose set was computed (0 for a full pass): sets below it are the
            previous ones.
        """
        N = len(self.ds)
        s = self.s
        eps = self.EPS
        if previous is None:
            K_lo = [0.0] * (N + 1)
            K_hi = [0.0] * (N + 1)
            if not end_at_rest:
                K_hi[-1] = float(min(self.xvel[-1], caps[-1], 1e12))
            top, bottom = N - 1, 0
        else:
            K_lo, K_hi, old_caps = list(previous[0]), list(previous[1]), previous[2]
            changed = np.flatnonzero(caps != old_caps)
            if not len(changed):
                return K_lo, K_hi, N + 1
            if changed[-1] == N and not end_at_rest:
                K_hi[-1] = float(min(self.xvel[-1], caps[-1], 1e12))
            top, bottom = min(int(changed[-1]), N - 1), int(changed[0])
        caps_stage = caps[:-1]
        xlo_l, ds_l = self.x_lo.tolist(), self.ds.tolist()
        xhi_l = np.minimum(self.x_hi, caps_stage).tolist()
        hi0_l = np.minimum(np.minimum(self.x_hi, caps_stage), self.up_hi0).tolist()
        lo0_l = np.maximum(self.x_lo, self.up_lo0).tolist()
        up_Q, up_P = self.up_Q, self.up_P
        (hi_g0, hi_g1), (lo_g0, lo_g1) = self.lw_hi, self.lw_lo
        lowest = 0
        for i in range(top, -1, -1):  # stage i couples to i+1: sequential by nature
            K_lo1, K_hi1 = K_lo[i + 1], K_hi[i + 1]
            if K_lo1 == 0.0:
                lo_i, hi_i = lo0_l[i], hi0_l[i]
            else:  # reach-lower against each upper: (a - Q) x <= P - K_lo' / h
                h = 2.0 * ds_l[i]
                a = -1.0 / h
                lo_r = K_lo1 / h
                lo_i, hi_i = xlo_l[i], xhi_l[i]
                for Q, P in zip(up_Q[i], up_P[i]):
                    dd = a - Q
                    if dd > eps:
                        hi_i = min(hi_i, (P - lo_r) / dd)
                    elif dd < -eps:
                        lo_i = max(lo_i, (P - lo_r) / dd)
            for g0, g1 in zip(hi_g0[i], hi_g1[i]):  # each lower against reach-upper
                v = g0 + g1 * K_hi1
                if v < hi_i:
                    hi_i = v
            for g0, g1 in zip(lo_g0[i], lo_g1[i]):
                v = g0 + g1 * K_hi1
                if v > lo_i:
                    lo_i = v
            if lo_i > hi_i + 1e-12:
                raise InfeasiblePath(
                    f"the path cannot be followed to rest from s = {s[i]:.4f}: the limits leave "
                    "no speed there"
                )
            new_lo, new_hi = max(lo_i, 0.0), max(hi_i, 0.0)
            if previous is not None and i < bottom and new_lo == K_lo[i] and new_hi == K_hi[i]:
                lowest = i + 1  # as before from here down
                break
            K_lo[i], K_hi[i] = new_lo, new_hi
        if K_lo[0] > 1e-12:
            raise InfeasiblePath("the path cannot start from rest within the limits")
        return K_lo, K_hi, lowest

    def forward(
        self, K_lo: list, K_hi: list, caps: np.ndarray, cap_cause: list, previous=None
    ) -> tuple[np.ndarray, np.ndarray, list]:
        """From rest, the largest u on every stage that keeps x controllable; (x, u, what binds
        per stage).

        ``previous``: (x, u, binding, first, last) of an earlier pass and the span of grid
        points whose sets or caps changed since: the stages before ``first`` are kept, and past
        ``last`` the pass stops where x comes back onto the previous solution.
        """
        N = len(self.ds)
        ds_l, xvel_l, caps_l = self.ds.tolist(), self.xvel.tolist(), caps.tolist()
        labels, up_Q, up_P, up_row = self.labels, self.up_Q, self.up_P, self.up_row
        if previous is None:
            x = [0.0] * (N + 1)
            u = [0.0] * N
            binding = [""] * N
            start, last, old_x = 0, N, None
        else:
            old_x, old_u, old_binding, first, last = previous
            x, u, binding = old_x.tolist(), old_u.tolist(), list(old_binding)
            start = max(first - 1, 0)  # stage i reads the set and cap of point i + 1
        for i in range(start, N):
            h = 2.0 * ds_l[i]
            xi = x[i]
            if old_x is not None and i > last and xi == old_x[i]:
                break  # same speed, same sets and caps from here on: the rest is as before
            ui = (K_hi[i + 1] - xi) / h
            if K_hi[i + 1] >= xvel_l[i + 1] - 1e-9:
                which = "velocity"
            elif K_hi[i + 1] >= caps_l[i + 1]:
                which = cap_cause[i + 1]
            else:
                which = "braking ahead"
            for Q, P, k in zip(up_Q[i], up_P[i], up_row[i]):
                bound = P + Q * xi
                if bound < ui:
                    ui, which = bound, labels[k]
            ui = max(ui, (K_lo[i + 1] - xi) / h)
            x[i + 1] = min(max(xi + h * ui, K_lo[i + 1]), K_hi[i + 1])
            u[i] = (x[i + 1] - xi) / h
            binding[i] = which
        return np.array(x), np.array(u), binding


def interval_excess(
    timing: Timing,
    constraints: list,
    segments: Segments,
    repair_margin: float = _REPAIR_MARGIN,
    own_margins: bool = True,
):
    """Per grid interval, the factor f <= 1 on x (at both its ends) that keeps every constraint
    inside it.

    Returns
    -------
    factor : ndarray, shape (N,)
        1 where the interval is within its limits; below 1 where scaling x (and u) on the
        interval by f brings it back (velocity: 1 / ratio^2; acceleration and motion torque: 1 /
        ratio).
    cause : list of str
        Per interval the limit that asks for the smallest factor (empty where none).
    worst : float
        The largest |value| / limit found between grid points.
    """
    N = len(timing.u)
    factor = np.ones(N)
    between = BetweenGridPoints(timing, segments)
    found = [
        c.excess(
            timing,
            between,
            max(repair_margin, getattr(c, "repair_margin", 0.0) if own_margins else 0.0),
        )
        for c in constraints
    ]
    worst = max((e.worst for e in found), default=0.0)
    where = np.concatenate([e.interval for e in found]) if found else np.zeros(0, dtype=int)
    factors = np.concatenate([e.factor for e in found]) if found else np.zeros(0)
    labels = np.concatenate([e.label for e in found]) if found else np.zeros(0, dtype=object)
    cause = [""] * N
    if len(where):
        order = np.lexsort((factors, where))  # by interval, smallest factor first
        first = order[np.r_[True, np.diff(where[order]) != 0]]
        factor[where[first]] = factors[first]
        for i, label in zip(where[first].tolist(), labels[first].tolist()):
            cause[i] = label + " between grid points"
    return factor, cause, worst


def constraints_from_limits(
    limits: Limits, dynamics=None, gravity=None, check_samples: int | None = None
) -> list:
    """The constraint objects of joint limits: velocity, and acceleration and torque where given."""
    out: list = [JointVelocity(limits.velocity)]
    if limits.acceleration is not None:
        out.append(JointAcceleration(limits.acceleration))
    if limits.effort is not None and dynamics is not None:
        out.append(JointTorque(limits.effort, dynamics, gravity, check_samples))
    return out


_SPEED_CEILING = 1e12  # sdot^2 beyond this: nothing limits the path speed there


def time_optimal(
    path: JointPath,
    limits: Limits,
    dynamics=None,
    gravity=None,
    gridpoints: int = 1000,
    check_samples: int | None = None,
    end_at_rest: bool = True,
    repair: bool = True,
    max_rounds: int = 12,
) -> tuple[Timing, dict]:
    """The fastest timing of ``path`` from rest to rest within joint limits.

    Parameters
    ----------
    path : JointPath
    limits : Limits
        A joint with ``inf`` in a kind is unlimited in that kind, alone.
    dynamics : DeviceDynamics, optional
        Needed for torque limits (payload and armature as configured there).  Without
        friction: friction torque is not affine in (sddot, sdot^2).
    gravity : array_like, shape (3,), optional
        In the device's base frame [m/s^2].
    gridpoints : int
        Grid points on s in [0, 1] (``gridpoints - 1`` intervals), as toppra counts them.
    check_samples : int, optional
        Points of the fine s grid on which torque is bounded between grid points (at least
        one cell per grid interval; every grid point and spline break is among them).  Default:
        :func:`~rworld_cli.planning.constraints.check_cells` cells, four per grid interval and
        at least 1 000.
    end_at_rest, repair, max_rounds
        See :func:`time_optimal_constrained`.

    Returns
    -------
    (Timing, info) : see :func:`time_optimal_constrained`.
    """
    constraints = constraints_from_limits(limits, dynamics, gravity, check_samples)
    return time_optimal_constrained(path, constraints, gridpoints, end_at_rest, repair, max_rounds)


def time_optimal_constrained(
    path: JointPath,
    constraints: list,
    gridpoints: int = 1000,
    end_at_rest: bool = True,
    repair: bool = True,
    max_rounds: int = 12,
) -> tuple[Timing, dict]:
    """The fastest timing of ``path`` from rest within ``constraints`` (objects of
    ``constraints.py``).

    Parameters
    ----------
    end_at_rest : bool
        False: the path ends at the highest speed the limits allow there (the forward
        pass maximises sdot at every point, the last one included).
    repair : bool
        False: the plain grid solution (limits hold at the grid points only), as toppra returns it.
    max_rounds : int
        Local repairs before falling back to a uniform slow-down.

    Returns
    -------
    (Timing, info)
        ``info``: ``binding`` - per grid interval the constraint that limits it
        ('velocity', 'acceleration j', 'torque j', '... between grid points', 'braking ahead'),
        ``dense_ratio`` - the worst limit ratio between grid points (<= 1 unless ``repair=False``),
        ``grid`` (points), ``rounds`` (solves), ``repaired`` (grid points capped), ``x_limit``,
        ``K_hi``.

    Raises
    ------
    InfeasiblePath
        No timing keeps the limits, or nothing limits the path speed somewhere (every joint
        that moves there is unconstrained).
    """
    if gridpoints < 2:
        raise ValueError("time-optimal timing needs at least 2 grid points")
    s = np.linspace(0.0, 1.0, gridpoints)
    for c in constraints:
        c.prepare(path, s)
    grid = PathGrid(s, *path.evaluate(s))
    stages = _Stages(grid, constraints)
    segments = Segments(path, s)
    caps = np.full(gridpoints, np.inf)
    cap_cause = [""] * gridpoints
    rounds = 0
    solved = None  # the previous round's sets, caps and solution: repairs re-solve locally
    while True:
        rounds += 1
        if solved is None:
            K_lo, K_hi, _ = stages.backward(caps, end_at_rest)
            x, u, binding = stages.forward(K_lo, K_hi, caps, cap_cause)
        else:
            old_K_lo, old_K_hi, old_caps, old_x, old_u, old_binding = solved
            K_lo, K_hi, lowest = stages.backward(caps, end_at_rest, (old_K_lo, old_K_hi, old_caps))
            changed = np.flatnonzero(caps != old_caps)
            first = min(lowest, int(changed[0])) if len(changed) else gridpoints
            last = int(changed[-1]) if len(changed) else -1
            x, u, binding = stages.forward(
                K_lo, K_hi, caps, cap_cause, (old_x, old_u, old_binding, first, last)
            )
        solved = (K_lo, K_hi, caps.copy(), x, u, binding)
        unbounded = np.flatnonzero(~(x < _SPEED_CEILING))
        if len(unbounded):
            raise InfeasiblePath(
                f"nothing limits the path speed at s = {s[unbounded[0]]:.4f}: every joint that "
                "moves there "
                "is unlimited in velocity, acceleration and torque"
            )
        timing = Timing(s, x, u, _times(s, x))
        factor, cause, ratio = interval_excess(timing, constraints, segments)
        bad = np.flatnonzero(factor < 1.0)
        if not repair or not len(bad):
            break
        settle = rounds >= 2 and ratio <= 1.0 + _SETTLE
        if rounds >= max_rounds or settle:
            # not settled locally, or only a trace left (repairs that moved the excess next door
            # by 1e-6): slow the whole timing by what the check asks for - for a trace, without
            # the repairs' margins
            if settle:
                factor, _, ratio = interval_excess(timing, constraints, segments, _MARGIN, False)
            scale = 1.0
            for _ in range(5):
                scale /= np.sqrt(factor.min())
                timing = Timing(s, x / scale**2, u / scale**2, _times(s, x / scale**2), scale)
                factor, _, ratio = interval_excess(
                    timing, constraints, segments, _MARGIN if settle else _REPAIR_MARGIN, not settle
                )
                if factor.min() >= 1.0:
                    break
            else:
                raise InfeasiblePath(
                    f"could not bring the dense check within the limits (worst ratio {ratio:.6g})"
                )
            break
        # cap both ends of each offending interval at the speed that fixes it; from the third solve
        # on,
        # its neighbours' too, so a cap does not just move the excess next door (shifting their
        # sddot)
        reach = 0 if rounds < 3 else 1
        for i in bad:
            for p in range(max(i - reach, 0), min(i + 1 + reach, gridpoints - 1) + 1):
                if factor[i] * x[p] < caps[p]:
                    caps[p] = factor[i] * x[p]
                    cap_cause[p] = cause[i]
    repaired = int(np.isfinite(caps).sum())
    return timing, {
        "binding": binding,
        "dense_ratio": ratio,
        "grid": gridpoints,
        "rounds": rounds,
        "repaired": repaired,
        "x_limit": np.minimum(np.r_[stages.x_hi, stages.x_hi[-1]], stages.xvel) / timing.scale**2,
        "K_hi": np.array(K_hi) / timing.scale**2,
    }


@dataclass
class Samples:
    """A timed path sampled: the time law and the joint trajectory, one row per instant (SI).

    Attributes
    ----------
    t, s, sd, sdd : ndarray, shape (K,)
        Time [s], path parameter, its first and second time derivatives.  At a grid instant
        given twice (``switches``), the first row holds sddot from the left, the second from the
        right.
    q, qd, qdd : ndarray, shape (K, n)
    """

    t: np.ndarray
    s: np.ndarray
    sd: np.ndarray
    sdd: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray


def sample_instants(timing: Timing, samples=None, period: float | None = None) -> np.ndarray:
    """Times to sample at.

    ``samples`` equally spaced instants (an int), the given times (an array), or every
    ``period`` seconds from 0 until the end is covered (the last row at or after it, at rest).
    """
    if period is not None:
        if not timing.duration / period <= MAX_SAMPLES:  # bounded before anything is allocated
            raise UserError(
                f"the trajectory takes {timing.duration:.4g} s: {timing.duration / period:.3g} "
                f"rows at a period of {period:g} s, above the bound of {MAX_SAMPLES:,}"
            )
        count = int(np.ceil(timing.duration / period - 1e-9)) + 1
        return np.arange(count) * period
    if np.isscalar(samples):
        return np.linspace(0.0, timing.duration, int(samples))
    return np.asarray(samples, dtype=float)


def sample_path(path: JointPath, timing: Timing, times, switches: bool = False) -> Samples:
    """The trajectory at ``times`` (clipped to [0, duration]); see :class:`Samples`.

    ``switches=True`` adds both one-sided limits at every interior grid instant, where sddot
    jumps, so a minimum or maximum at a switch is not missed; the rows stay sorted by time.
    """
    t = np.asarray(times, dtype=float)
    interval = None
    if switches:
        inner = np.arange(1, len(timing.u))
        t_all = np.concatenate([t, timing.t[inner], timing.t[inner]])
        k_all = np.concatenate(
            [
                np.searchsorted(timing.t, np.clip(t, 0.0, timing.duration), side="right") - 1,
                inner - 1,
                inner,
            ]
        )
        order = np.argsort(t_all, kind="stable")
        t, interval = t_all[order], k_all[order]
    s, sd, sdd = timing.sample(t, interval)
    after = t > timing.duration  # fixed-rate rows past the end: at rest there
    sd, sdd = np.where(after, 0.0, sd), np.where(after, 0.0, sdd)
    q, dq, ddq = path.evaluate(s)
    return Samples(t, s, sd, sdd, q, dq * sd[:, None], ddq * (sd**2)[:, None] + dq * sdd[:, None])


def sample_trajectory(path: JointPath, timing: Timing, samples, switches: bool = False):
    """t, q, qd, qdd at ``samples`` equally spaced instants (an int) or at the given times (an
    array).

    ``switches``: see :func:`sample_path`.
    """
    out = sample_path(path, timing, sample_instants(timing, samples), switches)
    return out.t, out.q, out.qd, out.qdd


def limit_ratios(q, qd, qdd, limits: Limits, dynamics=None, gravity=None) -> dict:
    """|value| / limit per sample and joint: 'velocity', 'acceleration', 'torque' (those that
    apply).
    """
    out = {"velocity": np.abs(qd) / limits.velocity}
    if limits.acceleration is not None:
        out["acceleration"] = np.abs(qdd) / limits.acceleration
    if dynamics is not None and limits.effort is not None:
        out["torque"] = np.abs(dynamics.inverse(q, qd, qdd, gravity)) / limits.effort
    return out
