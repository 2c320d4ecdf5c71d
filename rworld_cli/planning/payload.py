"""Dynamic load-carrying capacity of a trajectory: exact, since torque is affine in the payload mass.

With a payload of mass m at a fixed point (or with fixed mass properties
scaled by m), tau(m) = tau_0 + m tau_1 at every sample; the largest m with
|tau| <= tau_max everywhere is the smallest margin ratio
(tau_max - tau_0) / tau_1 (tau_1 > 0) or (tau_max + tau_0) / -tau_1 (tau_1 < 0)
over samples and joints.  It is negative when the trajectory overloads a
joint without any payload.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics import DeviceDynamics, Payload


@dataclass
class Capacity:
    mass: float  # [kg]
    joint: int  # 0-based binding joint
    sample: int  # index of the binding sample
    side: str  # "upper" | "lower": which torque limit binds


def payload_capacity(device, q, qd, qdd, gravity, com_in_tool, mount=None, armature=True, friction=False, unit_payload=None) -> Capacity:
    """The largest point-mass payload (at ``com_in_tool``) the samples can carry within the effort limits.

    ``unit_payload`` overrides the point mass: a 1 kg-scaled Payload (an object's mass properties per kg).
    """
    bare = DeviceDynamics(device, None, mount, armature, friction)
    one = unit_payload if unit_payload is not None else Payload.point_mass(1.0, com_in_tool)
    loaded = DeviceDynamics(device, one, mount, armature, friction)
    tau0 = bare.inverse(q, qd, qdd, gravity)
    tau1 = loaded.inverse(q, qd, qdd, gravity) - tau0
    tmax = device.limit_array("effort")
    with np.errstate(divide="ignore", invalid="ignore"):
        up = np.where(tau1 > 1e-12, (tmax - tau0) / tau1, np.inf)
        low = np.where(tau1 < -1e-12, (tmax + tau0) / -tau1, np.inf)
    ratios = np.minimum(up, low)
    k, j = np.unravel_index(int(np.argmin(ratios)), ratios.shape)
    return Capacity(float(ratios[k, j]), int(j), int(k), "upper" if up[k, j] <= low[k, j] else "lower")


def quintic_timing(duration: float, samples: int):
    """s, sdot, sddot of the rest-to-rest quintic s = 10 r^3 - 15 r^4 + 6 r^5, r = t / T."""
    t = np.linspace(0.0, duration, samples)
    r = t / duration
    s = 10 * r**3 - 15 * r**4 + 6 * r**5
    sd = (30 * r**2 - 60 * r**3 + 30 * r**4) / duration
    sdd = (60 * r - 180 * r**2 + 120 * r**3) / duration**2
    return t, s, sd, sdd


@dataclass
class LoadOptimal:
    """The heaviest point mass a path can carry within a cycle time, and its timing."""

    mass: float  # [kg]
    duration: float  # the cycle time asked for [s]
    timing: object  # planning.topp.Timing of the loaded path (stretched to the cycle time)
    time_optimal_capacity: float  # capacity of the unloaded time-optimal timing (v + a limits) [kg]
    quintic_capacity: float  # capacity of a quintic time law over the same duration [kg]
    static_capacity: float  # the limit as the cycle time grows: gravity only [kg]


def load_optimal(device, path, limits, gravity, com_in_tool, duration: float, mount=None, gridpoints: int = 400,
                 tolerance: float = 1e-4) -> LoadOptimal:
    """Maximise the payload a path can carry within ``duration`` (the timing is free; the path shape is given).

    A mass m is carryable in time T when the time-optimal timing with m on
    board (torque limits included) is no longer than T; the time-optimal
    duration grows with m, so bisection on m finds the largest carryable
    mass to ``tolerance`` kg.  The resulting timing is stretched to take
    exactly ``duration``.
    """
    from .topp import InfeasiblePath, Limits, Timing, _times, sample_trajectory, time_optimal

    lim = Limits(limits.velocity, limits.acceleration, limits.effort)

    def fastest(m: float):
        dyn = DeviceDynamics(device, Payload.point_mass(m, com_in_tool), mount, armature=True, friction=False)
        try:
            timing, _ = time_optimal(path, lim, dyn, gravity, gridpoints, check_samples=4001)
            return timing
        except InfeasiblePath:
            return None

    s_static = np.linspace(0, 1, 2001)
    q_static = path.evaluate(s_static)[0]
    zero = np.zeros_like(q_static)
    static = payload_capacity(device, q_static, zero, zero, gravity, com_in_tool, mount).mass
    lo, hi = 0.0, max(static, 0.0)
    first = fastest(0.0)
    if first is None or first.duration > duration:
        raise InfeasiblePath(f"the path cannot be done in {duration} s even without a payload"
                             + (f" (fastest: {first.duration:.4f} s)" if first is not None else ""))
    best = first
    while hi - lo > tolerance:  # bisection on the mass: each probe is one time-optimal solve
        mid = 0.5 * (lo + hi)
        timing = fastest(mid)
        if timing is not None and timing.duration <= duration:
            lo, best = mid, timing
        else:
            hi = mid
    stretch = duration / best.duration
    timing = Timing(best.s, best.x / stretch**2, best.u / stretch**2, _times(best.s, best.x / stretch**2), best.scale * stretch)
    fast, _ = time_optimal(path, Limits(limits.velocity, limits.acceleration, None), None, gravity, gridpoints)
    _, q, qd, qdd = sample_trajectory(path, fast, 20001, switches=True)
    t_opt = payload_capacity(device, q, qd, qdd, gravity, com_in_tool, mount).mass
    _, s, sd, sdd = quintic_timing(duration, 20001)
    q, dq, ddq = path.evaluate(s)
    quint = payload_capacity(device, q, dq * sd[:, None], ddq * (sd**2)[:, None] + dq * sdd[:, None], gravity, com_in_tool, mount).mass
    return LoadOptimal(lo, duration, timing, t_opt, quint, static)
