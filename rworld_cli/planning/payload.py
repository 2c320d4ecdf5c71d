"""Dynamic load-carrying capacity of a trajectory: exact, since torque is affine in the payload
mass.

With a payload of mass m at a fixed point (or with fixed mass properties
scaled by m), tau(m) = tau_0 + m tau_1 at every sample; the largest m with
|tau| <= tau_max everywhere is the smallest margin ratio
(tau_max - tau_0) / tau_1 (tau_1 > 0) or (tau_max + tau_0) / -tau_1 (tau_1 < 0)
over samples and joints.  It is negative when the trajectory overloads a
joint without any payload.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..dynamics import DeviceDynamics, Payload


@dataclass
class Capacity:
    mass: float  # [kg]
    joint: int  # 0-based binding joint
    sample: int  # index of the binding sample
    side: str  # "upper" | "lower": which torque limit binds


def payload_capacity(
    device,
    q,
    qd,
    qdd,
    gravity,
    com_in_tool,
    mount=None,
    armature=True,
    friction=False,
    unit_payload=None,
    link_loads=None,
) -> Capacity:
    """The largest point-mass payload (at ``com_in_tool``) the samples can carry within the effort
    limits.

    ``unit_payload`` overrides the point mass: a 1 kg-scaled Payload (an object's mass properties
    per kg).
    ``link_loads``: what else rides on the links (``DeviceDynamics``), carried in any case.
    """
    bare = DeviceDynamics(device, None, mount, armature, friction, link_loads=link_loads)
    one = unit_payload if unit_payload is not None else Payload.point_mass(1.0, com_in_tool)
    loaded = DeviceDynamics(device, one, mount, armature, friction, link_loads=link_loads)
    tau0 = bare.inverse(q, qd, qdd, gravity)
    tau1 = loaded.inverse(q, qd, qdd, gravity) - tau0
    return affine_capacity(tau0, tau1, device.limit_array("effort"))


def affine_capacity(tau0: np.ndarray, tau_per_kg: np.ndarray, limits: np.ndarray) -> Capacity:
    """The largest m with ``|tau0 + m tau_per_kg| <= limits`` at every sample and joint.

    Parameters
    ----------
    tau0 : ndarray, shape (K, n)
        Joint torques without the payload [N m or N].
    tau_per_kg : ndarray, shape (K, n)
        What 1 kg of payload adds [N m / kg].
    limits : ndarray, shape (n,)
        Effort limits (inf: the joint is unlimited).

    Returns
    -------
    Capacity
        ``mass`` is inf when no limited joint feels the payload, negative when ``tau0`` already
        exceeds a limit the payload loads.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        up = np.where(tau_per_kg > 1e-12, (limits - tau0) / tau_per_kg, np.inf)
        low = np.where(tau_per_kg < -1e-12, (limits + tau0) / -tau_per_kg, np.inf)
    ratios = np.minimum(up, low)
    k, j = np.unravel_index(int(np.argmin(ratios)), ratios.shape)
    return Capacity(
        float(ratios[k, j]), int(j), int(k), "upper" if up[k, j] <= low[k, j] else "lower"
    )


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
    path: Any = None  # the JointPath timed (reshaped when the knots were optimised)
    given_shape_mass: float | None = (
        None  # with the knots optimised: the mass on the path as given [kg]
    )


class PointMassFamily:
    """The dynamics of a device carrying a point mass m, for the torque limits of a planner, as
    ``tau(m) = tau_0 + m (tau_1 - tau_0)``.

    Torque is affine in the mass of a point load (its mass, first and second moments enter
    Newton-Euler linearly), so the torque coefficients of a path for any m follow from two
    passes: without the load (``bare``) and with 1 kg at the same place (``unit``).  A bisection
    on the mass then runs Newton-Euler twice per path, not twice per probe.  ``at(m)`` gives the
    member with mass m; members share one cache of coefficients, keyed by path and s grid.
    """

    _has_friction = False  # what the torque constraint asks of its dynamics

    def __init__(self, bare: DeviceDynamics, unit: DeviceDynamics, mass: float = 0.0):
        self.bare, self.unit, self.mass = bare, unit, float(mass)
        self._cache: dict = {}

    def at(self, mass: float) -> PointMassFamily:
        member = PointMassFamily(self.bare, self.unit, mass)
        member._cache = self._cache
        return member

    def torque_coefficients(self, path, s: np.ndarray, gravity):
        """``(a, b, c)`` of :func:`rworld_cli.planning.constraints.path_coefficients` at mass m,
        each of shape (len(s), n)."""
        from .constraints import path_coefficients

        key = (id(path), s.tobytes(), None if gravity is None else np.asarray(gravity).tobytes())
        entry = self._cache.get(key)
        if entry is None or entry[0] is not path:
            bare = path_coefficients(path, s, self.bare, gravity)[3]
            unit = path_coefficients(path, s, self.unit, gravity)[3]
            entry = self._cache[key] = (path, bare, tuple(u - b for u, b in zip(unit, bare)))
        _, bare, per_kg = entry
        return tuple(b + self.mass * d for b, d in zip(bare, per_kg))


def _carrying(device, mass: float, com_in_tool, mount, link_loads) -> DeviceDynamics:
    """The planning dynamics (armature, no friction) of ``device`` carrying a point mass [kg]
    at ``com_in_tool`` [m], with what the cell puts on its links."""
    return DeviceDynamics(
        device,
        Payload.point_mass(mass, com_in_tool),
        mount,
        armature=True,
        friction=False,
        link_loads=link_loads,
    )


def _heaviest(
    device,
    path,
    limits,
    gravity,
    com_in_tool,
    duration,
    mount,
    gridpoints,
    tolerance,
    check_samples=None,
    link_loads=None,
):
    """(mass, timing, static bound) of the heaviest point mass ``path`` carries within ``duration``.

    A mass m is carryable in time T when the time-optimal timing with m on board (torque limits
    included) is no longer than T; that duration grows with m, so bisection on m finds the largest
    carryable mass to ``tolerance`` kg, never above the static bound (gravity alone along the path).

    Raises
    ------
    InfeasiblePath
        Not even an empty tool makes it in ``duration``.
    """
    from .topp import InfeasiblePath, time_optimal

    family = PointMassFamily(
        *(_carrying(device, m, com_in_tool, mount, link_loads) for m in (0.0, 1.0))
    )

    def fastest(m: float):
        try:
            timing, _ = time_optimal(
                path, limits, family.at(m), gravity, gridpoints, check_samples=check_samples
            )
            return timing
        except InfeasiblePath:
            return None

    s_static = np.linspace(0, 1, 2001)
    q_static = path.evaluate(s_static)[0]
    zero = np.zeros_like(q_static)
    static = payload_capacity(
        device, q_static, zero, zero, gravity, com_in_tool, mount, link_loads=link_loads
    ).mass
    lo, hi = 0.0, max(static, 0.0)
    first = fastest(0.0)
    if first is None or first.duration > duration:
        raise InfeasiblePath(
            f"the path cannot be done in {duration} s even without a payload"
            + (f" (fastest: {first.duration:.4f} s)" if first is not None else "")
        )
    best = first
    while hi - lo > tolerance:  # bisection on the mass: each probe is one time-optimal solve
        mid = 0.5 * (lo + hi)
        timing = fastest(mid)
        if timing is not None and timing.duration <= duration:
            lo, best = mid, timing
        else:
            hi = mid
    return lo, best, static


def _knots_from(z: np.ndarray) -> np.ndarray:
    """Knots on [0, 1] from unconstrained log-spacings z (K - 2 of them; the first spacing is
    the unit).
    """
    d = np.exp(np.concatenate([[0.0], np.clip(z, -5.0, 5.0)]))
    return np.concatenate([[0.0], np.cumsum(d) / d.sum()])


def optimise_knots(
    device,
    path,
    limits,
    gravity,
    com_in_tool,
    duration,
    mass,
    mount=None,
    gridpoints: int = 200,
    tolerance: float = 1e-3,
    evaluations: int = 80,
    progress=None,
    link_loads=None,
):
    """The knots (path parameters of the waypoints) whose spline carries the most within
    ``duration``.

    The spline still passes through every waypoint; moving the knots changes its shape between
    them (its boundary conditions keep holding).  The heaviest payload for a cycle time and the
    fastest cycle for a payload are the same question asked two ways: a shape that does ``mass`` in
    less than ``duration`` carries more.  So Nelder-Mead minimises the time-optimal duration with
    ``mass`` on board over the log-spacings of the knots (one solve per shape), then the mass of the
    best shape is found by bisection, and the two steps repeat while the mass grows.  A shape that
    leaves the joint position limits between the waypoints, or cannot be followed, is refused.

    Returns
    -------
    (knots, mass) : the best knots, shape (K,), and the payload they carry at this search
        resolution (``gridpoints``, ``tolerance``) - the given knots if none is better.
    """
    from scipy.optimize import minimize

    from .path import JointPath, range_excursions
    from .topp import InfeasiblePath, time_optimal

    lower, upper = device.limit_array("lower"), device.limit_array("upper")
    spacing = np.diff(path.knots)
    z = np.log(spacing[1:] / spacing[0])
    used = 0

    def shaped(zz):
        candidate = JointPath(path.waypoints, _knots_from(zz), path.boundary)
        return (
            None if range_excursions(candidate, lower, upper) else candidate
        )  # exact extrema, not samples

    best_knots = path.knots
    try:  # the given shape at the search resolution: the figure to beat
        best_mass = _heaviest(
            device,
            path,
            limits,
            gravity,
            com_in_tool,
            duration,
            mount,
            gridpoints,
            tolerance,
            link_loads=link_loads,
        )[0]
    except InfeasiblePath:
        best_mass = mass
    for _ in range(3):
        dyn = _carrying(device, best_mass, com_in_tool, mount, link_loads)

        seen: dict[tuple, float] = {}

        def cycle_time(zz):
            nonlocal used
            key = tuple(np.asarray(zz).tolist())
            if key in seen:
                return seen[key]
            used += 1
            if progress is not None:
                progress(min(used, evaluations), evaluations)
            candidate = shaped(zz)
            seen[key] = 10.0 * duration  # refused: outside the position limits, or no timing at all
            if candidate is not None:
                try:
                    seen[key] = time_optimal(candidate, limits, dyn, gravity, gridpoints)[
                        0
                    ].duration
                except InfeasiblePath:
                    pass
            return seen[key]

        budget = evaluations - used
        if budget < len(z) + 2:
            break
        simplex = np.vstack([z] + [z + 0.25 * np.eye(len(z))[k] for k in range(len(z))])
        found = minimize(
            cycle_time,
            z,
            method="Nelder-Mead",
            options={
                "maxfev": budget,
                "initial_simplex": simplex,
                "xatol": 1e-3,
                "fatol": 1e-6 * duration,
            },
        )
        candidate = shaped(found.x)
        if candidate is None or found.fun >= cycle_time(z):
            break
        try:
            m = _heaviest(
                device,
                candidate,
                limits,
                gravity,
                com_in_tool,
                duration,
                mount,
                gridpoints,
                tolerance,
                link_loads=link_loads,
            )[0]
        except InfeasiblePath:
            break
        if m <= best_mass + tolerance:
            break
        z, best_knots, best_mass = found.x, _knots_from(found.x), m
    if progress is not None:
        progress(evaluations, evaluations)
    return best_knots, best_mass


def load_optimal(
    device,
    path,
    limits,
    gravity,
    com_in_tool,
    duration: float,
    mount=None,
    gridpoints: int = 400,
    tolerance: float = 1e-4,
    shape: bool = False,
    evaluations: int = 80,
    progress=None,
    link_loads=None,
) -> LoadOptimal:
    """Maximise the payload a path can carry within ``duration``: the timing, and with ``shape`` the
    knots.

    The timing is free; bisection on the mass (:func:`_heaviest`) to ``tolerance`` kg.  The
    resulting
    timing is stretched to take exactly ``duration``.  With ``shape=True`` the waypoints' path
    parameters are optimised as well (:func:`optimise_knots`, ``evaluations`` shapes at a coarser
    grid), the spline still passing through every waypoint; the result keeps the given shape
    when no other carries more (a ``blended`` path's knots follow its lengths: kept).
    ``link_loads`` (``DeviceDynamics``) ride on the links throughout.
    """
    from .path import JointPath
    from .topp import Limits, Timing, _times, sample_trajectory, time_optimal

    lim = Limits(limits.velocity, limits.acceleration, limits.effort)
    mass, best, static = _heaviest(
        device,
        path,
        lim,
        gravity,
        com_in_tool,
        duration,
        mount,
        gridpoints,
        tolerance,
        link_loads=link_loads,
    )
    given_mass = None
    if shape and len(path.waypoints) > 2 and path.boundary != "blended":  # knots by length
        knots, _ = optimise_knots(
            device,
            path,
            lim,
            gravity,
            com_in_tool,
            duration,
            mass,
            mount,
            min(gridpoints, 200),
            max(tolerance, 1e-3),
            evaluations,
            progress,
            link_loads,
        )
        if not np.allclose(knots, path.knots, atol=1e-12):
            reshaped = JointPath(path.waypoints, knots, path.boundary)
            m2, best2, static2 = _heaviest(
                device,
                reshaped,
                lim,
                gravity,
                com_in_tool,
                duration,
                mount,
                gridpoints,
                tolerance,
                link_loads=link_loads,
            )
            given_mass = mass
            if m2 > mass:
                path, mass, best, static = reshaped, m2, best2, static2
    stretch = duration / best.duration
    timing = Timing(
        best.s,
        best.x / stretch**2,
        best.u / stretch**2,
        _times(best.s, best.x / stretch**2),
        best.scale * stretch,
    )
    fast, _ = time_optimal(
        path, Limits(limits.velocity, limits.acceleration, None), None, gravity, gridpoints
    )
    _, q, qd, qdd = sample_trajectory(path, fast, 20001, switches=True)
    t_opt = payload_capacity(
        device, q, qd, qdd, gravity, com_in_tool, mount, link_loads=link_loads
    ).mass
    _, s, sd, sdd = quintic_timing(duration, 20001)
    q, dq, ddq = path.evaluate(s)
    quint = payload_capacity(
        device,
        q,
        dq * sd[:, None],
        ddq * (sd**2)[:, None] + dq * sdd[:, None],
        gravity,
        com_in_tool,
        mount,
        link_loads=link_loads,
    ).mass
    return LoadOptimal(mass, duration, timing, t_opt, quint, static, path, given_mass)
