"""Time-optimal timing of a joint path under velocity, acceleration and torque limits.

Reachability analysis as in TOPP-RA (Pham & Pham 2018).  Along a path
q(s), s in [0, 1], with x = sdot^2 and u = sddot:

* joint velocity   qd  = q'(s) sdot                  -> x <= (v_max / |q'|)^2
* acceleration     qdd = q'(s) u + q''(s) x          -> |a u + b x| <= a_max
* torque           tau = a_t u + b_t x + c_t          -> |.| <= tau_max
  with a_t = M q', b_t = M q'' + C(q, q') q', c_t = g(q) from the batched
  Newton-Euler (``DeviceDynamics``: armature in M, payload folded in).

On a grid s_0 < ... < s_N, u is constant on each interval and x is linear
in s (x_{i+1} = x_i + 2 ds u).  Constraints are imposed at both ends of each
interval ("interpolation").  Each stage's constraints are linear in (u, x);
eliminating u (Fourier-Motzkin) gives the feasible x as an interval - the
part that does not depend on the neighbouring stage is computed for all
stages at once, vectorised.  A backward pass builds the controllable sets
K_i (from rest at the end); a forward pass takes the largest u that stays
controllable (from rest at the start).

Between grid points the spline's curvature varies, so the profile is
checked at ``check_samples`` times and, if any limit is exceeded there,
slowed uniformly until none is - the trajectory respects every limit when
sampled densely, not only at grid points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .path import JointPath


class InfeasiblePath(Exception):
    """No timing satisfies the limits (e.g. gravity alone exceeds a torque limit)."""


@dataclass
class Limits:
    """Joint limits for planning (SI); ``inf`` (or None) where a limit does not apply."""

    velocity: np.ndarray
    acceleration: np.ndarray | None
    effort: np.ndarray | None


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
        The uniform slow-down applied after the dense check (1 = none).
    """

    s: np.ndarray
    x: np.ndarray
    u: np.ndarray
    t: np.ndarray
    scale: float = 1.0

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def sample(self, times: np.ndarray):
        """s, sdot, sddot at ``times`` (vectorised)."""
        times = np.clip(np.asarray(times, dtype=float), 0.0, self.duration)
        k = np.clip(np.searchsorted(self.t, times, side="right") - 1, 0, len(self.u) - 1)
        tau = times - self.t[k]
        sd0 = np.sqrt(np.maximum(self.x[k], 0.0))
        u = self.u[k]
        return self.s[k] + sd0 * tau + 0.5 * u * tau**2, sd0 + u * tau, u


def _times(s: np.ndarray, x: np.ndarray) -> np.ndarray:
    sd = np.sqrt(np.maximum(x, 0.0))
    dt = 2.0 * np.diff(s) / np.maximum(sd[:-1] + sd[1:], 1e-300)
    return np.concatenate([[0.0], np.cumsum(dt)])


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


def _rows(alpha, beta, lo, hi):
    """lo <= alpha u + beta x <= hi as rows (alpha, beta, gamma) of alpha u + beta x <= gamma, shape (N, 2m, 3)."""
    return np.concatenate([np.stack([alpha, beta, hi], axis=-1), np.stack([-alpha, -beta, -lo], axis=-1)], axis=1)


def time_optimal(path: JointPath, limits: Limits, dynamics=None, gravity=None, gridpoints: int = 1000,
                 check_samples: int = 20001, end_at_rest: bool = True) -> tuple[Timing, dict]:
    """The fastest timing of ``path`` from rest to rest within the limits.

    With ``end_at_rest=False`` the path ends at the highest speed the limits
    allow there (the forward pass maximises sdot at every point, the last one included).

    Returns
    -------
    (Timing, info)
        ``info``: ``binding`` - per grid interval the constraint that limits
        it ('velocity j', 'acceleration j', 'torque j'), ``dense_ratio`` -
        the worst limit ratio when sampled densely, ``grid`` used.

    Raises
    ------
    InfeasiblePath
    """
    s = np.linspace(0.0, 1.0, gridpoints + 1)
    ds = np.diff(s)
    q, dq, ddq, torque = path_coefficients(path, s, dynamics, gravity)
    n = q.shape[1]
    rows = []  # per grid point: alpha u + beta x <= gamma
    labels = []
    if limits.acceleration is not None:
        amax = np.broadcast_to(limits.acceleration, (len(s), n))
        rows.append(_rows(dq, ddq, -amax, amax))
        labels += [f"acceleration {j + 1}" for j in range(n)] * 2
    if torque is not None and limits.effort is not None:
        a_t, b_t, c_t = torque
        tmax = np.broadcast_to(limits.effort, (len(s), n))
        finite = np.isfinite(tmax)
        rows.append(_rows(a_t, b_t, np.where(finite, -tmax - c_t, -np.inf), np.where(finite, tmax - c_t, np.inf)))
        labels += [f"torque {j + 1}" for j in range(n)] * 2
    with np.errstate(divide="ignore"):
        xvel = np.min(np.where(np.abs(dq) > 1e-12, (limits.velocity / np.abs(dq)) ** 2, np.inf), axis=1)
    if rows:
        R = np.concatenate(rows, axis=1)  # (N+1, m, 3)
        # interpolation: stage i holds the constraints of point i and of point i+1 with x_{i+1} = x_i + 2 ds u
        here = R[:-1]
        there = R[1:].copy()
        there[..., 0] = there[..., 0] + 2.0 * ds[:, None] * there[..., 1]
        stage = np.concatenate([here, there], axis=1)  # (N, 2m, 3)
        stage_labels = labels + labels
    else:
        stage = np.zeros((gridpoints, 0, 3))
        stage_labels = []
    stage = np.where(np.isfinite(stage), stage, np.where(stage > 0, 1e300, -1e300))
    alpha, beta, gamma = stage[..., 0], stage[..., 1], stage[..., 2]
    eps = 1e-12
    lower = alpha < -eps  # u >= (gamma - beta x) / alpha  = p + q x
    upper = alpha > eps  # u <= P + Q x
    # x-only rows, and the velocity bound
    x_hi = np.minimum(xvel[:-1], xvel[1:])
    x_lo = np.zeros(gridpoints)
    xonly = ~(lower | upper)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_hi = np.minimum(x_hi, np.where(xonly & (beta > eps), gamma / beta, np.inf).min(axis=1, initial=np.inf))
        x_lo = np.maximum(x_lo, np.where(xonly & (beta < -eps), gamma / beta, -np.inf).max(axis=1, initial=-np.inf))

    def compact(mask, pad_const, pad_slope):
        """Each stage's rows of one kind first, padded to a common width with a bound that never binds."""
        order = np.argsort(~mask, axis=1, kind="stable")[:, : max(int(mask.sum(axis=1).max()), 1)]
        valid = np.take_along_axis(mask, order, axis=1)
        a, b, g = (np.take_along_axis(v, order, axis=1) for v in (alpha, beta, gamma))
        with np.errstate(divide="ignore", invalid="ignore"):
            const = np.where(valid, g / a, pad_const)
            slope = np.where(valid, -b / a, pad_slope)
        return order, valid, const, slope

    up_rows, up_ok, coef_P, coef_Q = compact(upper, np.inf, 0.0)  # u <= P + Q x
    lw_rows, lw_ok, coef_p, coef_q = compact(lower, -np.inf, 0.0)  # u >= p + q x
    with np.errstate(divide="ignore", invalid="ignore"):
        d = coef_q[:, :, None] - coef_Q[:, None, :]  # every (lower, upper) pair of a stage: d x <= rhs
        rhs = coef_P[:, None, :] - coef_p[:, :, None]
        pair = lw_ok[:, :, None] & up_ok[:, None, :]
        x_hi = np.minimum(x_hi, np.where(pair & (d > eps), rhs / d, np.inf).min(axis=(1, 2), initial=np.inf))
        x_lo = np.maximum(x_lo, np.where(pair & (d < -eps), rhs / d, -np.inf).max(axis=(1, 2), initial=-np.inf))
        infeasible_pair = pair & (np.abs(d) <= eps) & (rhs < 0)
    if np.any(x_lo > x_hi + 1e-12) or infeasible_pair.any():
        k = int(np.argmax((x_lo > x_hi + 1e-12) | infeasible_pair.any(axis=(1, 2))))
        raise InfeasiblePath(f"no speed satisfies the limits at s = {s[k]:.4f} of the path (even at rest: check gravity against the torque limits)")
    def per_stage(mask, *arrays):
        """Row-major flattening groups rows by stage: one tolist, then slices."""
        flat = [a[mask].tolist() for a in arrays]
        ends = np.cumsum(mask.sum(axis=1)).tolist()
        starts = [0] + ends[:-1]
        return [list(zip(*(f[a:b] for f in flat))) for a, b in zip(starts, ends)]

    # Only bounds on the envelope over a stage's x interval matter: a line that another line beats at
    # both ends of the interval is beaten all along it (exact pruning, vectorised over all stages).
    ends = np.stack([x_lo, np.minimum(np.maximum(x_hi, x_lo), 1e12)], axis=1)  # (N, 2)

    def undominated(const, slope, ok, better):
        E = const[:, :, None] + slope[:, :, None] * ends[:, None, :]  # (N, m, 2)
        idx = np.arange(const.shape[1])
        earlier = idx[None, :] < idx[:, None]  # (k, j): j before k; of equal lines keep the first
        with np.errstate(invalid="ignore"):
            beats = better(E[:, None, :, 0], E[:, :, None, 0], True) & better(E[:, None, :, 1], E[:, :, None, 1], True)
            strictly = better(E[:, None, :, 0], E[:, :, None, 0], False) | better(E[:, None, :, 1], E[:, :, None, 1], False)
            return ok & ~(beats & (strictly | earlier[None]) & ok[:, None, :]).any(axis=2)

    keep_up = undominated(coef_P, coef_Q, up_ok, lambda a, b, eq: a <= b if eq else a < b)
    keep_lw = undominated(coef_p, coef_q, lw_ok, lambda a, b, eq: a >= b if eq else a > b)
    ups = per_stage(keep_up, coef_Q, coef_P, up_rows)
    lws = per_stage(keep_lw, coef_q, coef_p)
    xlo_l, xhi_l, ds_l, xvel_l = x_lo.tolist(), x_hi.tolist(), ds.tolist(), xvel.tolist()
    # backward pass: controllable sets, ending at rest
    K_lo = [0.0] * (gridpoints + 1)
    K_hi = [0.0] * (gridpoints + 1)
    if not end_at_rest:
        K_hi[-1] = float(min(xvel[-1], 1e12))
    for i in range(gridpoints - 1, -1, -1):  # stage i couples to i+1: sequential by nature
        h = 2.0 * ds_l[i]
        a = -1.0 / h
        lo_r, hi_r = K_lo[i + 1] / h, K_hi[i + 1] / h  # u >= lo_r + a x, u <= hi_r + a x
        lo_i, hi_i = xlo_l[i], xhi_l[i]
        for Q, P, _ in ups[i]:  # reach-lower against each upper: (a - Q) x <= P - lo_r
            dd = a - Q
            if dd > eps:
                hi_i = min(hi_i, (P - lo_r) / dd)
            elif dd < -eps:
                lo_i = max(lo_i, (P - lo_r) / dd)
        for q_, p_ in lws[i]:  # each lower against reach-upper: (q - a) x <= hi_r - p
            dd = q_ - a
            if dd > eps:
                hi_i = min(hi_i, (hi_r - p_) / dd)
            elif dd < -eps:
                lo_i = max(lo_i, (hi_r - p_) / dd)
        if lo_i > hi_i + 1e-12:
            raise InfeasiblePath(f"the path cannot be followed to rest from s = {s[i]:.4f}: the limits leave no speed there")
        K_lo[i], K_hi[i] = max(lo_i, 0.0), max(hi_i, 0.0)
    if K_lo[0] > 1e-12:
        raise InfeasiblePath("the path cannot start from rest within the limits")
    # forward pass: the largest u that keeps x controllable
    x = [0.0] * (gridpoints + 1)
    u = [0.0] * gridpoints
    binding = []
    for i in range(gridpoints):
        h = 2.0 * ds_l[i]
        xi = x[i]
        ui = (K_hi[i + 1] - xi) / h
        which = "velocity" if K_hi[i + 1] >= xvel_l[i + 1] - 1e-9 else "braking ahead"
        for Q, P, k in ups[i]:
            bound = P + Q * xi
            if bound < ui:
                ui, which = bound, stage_labels[k]
        ui = max(ui, (K_lo[i + 1] - xi) / h)
        x[i + 1] = min(max(xi + h * ui, K_lo[i + 1]), K_hi[i + 1])
        u[i] = (x[i + 1] - xi) / h
        binding.append(which)
    x, u = np.array(x), np.array(u)
    timing = Timing(s, x, u, _times(s, x))
    scale = 1.0
    for _ in range(5):  # a uniform slow-down by the factor the dense check asks for (parts per million)
        k, ratio = dense_slowdown(path, timing, limits, dynamics, gravity, check_samples)
        if ratio <= 1.0:
            break
        scale *= k * (1 + 1e-9)
        timing = Timing(s, x / scale**2, u / scale**2, _times(s, x / scale**2), scale)
    else:
        raise InfeasiblePath(f"could not bring the dense check within the limits (worst ratio {ratio:.6g})")
    return timing, {"binding": binding, "dense_ratio": ratio, "grid": gridpoints,
                    "x_limit": np.minimum(np.r_[x_hi, x_hi[-1]], xvel) / scale**2, "K_hi": np.array(K_hi) / scale**2}


def sample_trajectory(path: JointPath, timing: Timing, samples: int):
    """t, q, qd, qdd at ``samples`` equally spaced times over the timing."""
    t = np.linspace(0.0, timing.duration, samples)
    s, sd, sdd = timing.sample(t)
    q, dq, ddq = path.evaluate(s)
    return t, q, dq * sd[:, None], ddq * (sd**2)[:, None] + dq * sdd[:, None]


def limit_ratios(q, qd, qdd, limits: Limits, dynamics=None, gravity=None) -> dict:
    """|value| / limit per sample and joint: 'velocity', 'acceleration', 'torque' (those that apply)."""
    out = {"velocity": np.abs(qd) / limits.velocity}
    if limits.acceleration is not None:
        out["acceleration"] = np.abs(qdd) / limits.acceleration
    if dynamics is not None and limits.effort is not None:
        out["torque"] = np.abs(dynamics.inverse(q, qd, qdd, gravity)) / limits.effort
    return out


def dense_slowdown(path, timing, limits, dynamics, gravity, samples) -> tuple[float, float]:
    """(factor k >= 1 that a uniform slow-down needs, worst limit ratio now) from a dense sampling.

    Slowing time by k divides velocities by k, accelerations and the motion
    part of the torque by k^2; gravity torque stays.
    """
    _, q, qd, qdd = sample_trajectory(path, timing, samples)
    need = [np.max(np.abs(qd) / limits.velocity)]
    worst = need[0]
    if limits.acceleration is not None:
        r = np.max(np.abs(qdd) / limits.acceleration)
        worst = max(worst, r)
        need.append(np.sqrt(r))
    if dynamics is not None and limits.effort is not None:
        tau_g = dynamics.gravity_torques(q, gravity)
        tau = dynamics.inverse(q, qd, qdd, gravity)
        worst = max(worst, np.max(np.abs(tau) / limits.effort))
        room = limits.effort - np.abs(tau_g)
        if np.any(room <= 0):
            raise InfeasiblePath("gravity alone exceeds a torque limit on the path")
        need.append(np.sqrt(np.max(np.abs(tau - tau_g) / room)))
    return float(max(1.0, max(need))), float(worst)
