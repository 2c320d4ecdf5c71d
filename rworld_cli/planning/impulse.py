"""Maximum end-point impulse: the motion that arrives at a target with the most momentum along a
direction.

The report's first result ("trajectories that can deliver maximum impulse at
a specified end-point"; e.g. seating ammunition, driving a pin).  The motion
starts at rest at ``q_start`` and ends at the target configuration
``q_end``; the joint path is a cubic Hermite curve whose end tangent is
``L w`` with ``w = J_v^+ d`` - the joint direction that moves the tool point
along ``d`` - so the tool point arrives moving along ``d``.  For each
tangent length L the timing is time-optimal with the end speed left free
(the limits then decide how fast it can arrive); a golden-section search
over L picks the largest momentum ``m (v . d)`` (with no payload, the
largest speed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kinematics.jacobian import jacobian
from .path import JointPath, range_excursions
from .topp import InfeasiblePath, Limits, time_optimal


class HermitePath(JointPath):
    """q(s) from q0 (tangent 0) to q1 (tangent m1), cubic Hermite, s in [0, 1]."""

    def __init__(self, q0, q1, m1):
        self.q0, self.q1, self.m1 = (np.asarray(v, dtype=float) for v in (q0, q1, m1))
        self.waypoints = np.stack([self.q0, self.q1])
        dq = self.q1 - self.q0
        # q0 + (3 s^2 - 2 s^3) dq + (s^3 - s^2) m1, highest power first
        coefficients = np.stack([-2 * dq + self.m1, 3 * dq - self.m1, np.zeros_like(dq), self.q0])[
            :, None, :
        ]
        self._set_polynomial(np.array([0.0, 1.0]), coefficients)


@dataclass
class ImpulseResult:
    momentum: float  # m (v . d) [kg m/s]; v . d when no payload
    speed_along: float  # v . d [m/s]
    end_velocity: np.ndarray  # tool point velocity at the end, base frame [m/s]
    end_joint_velocity: np.ndarray  # [rad/s or m/s]
    duration: float  # [s]
    tangent_length: float
    binding: str  # what limits the arrival
    path: HermitePath
    timing: object


def max_impulse(
    device,
    q_start,
    q_end,
    direction,
    mass: float,
    com_in_tool,
    limits: Limits,
    dynamics,
    gravity,
    mount=None,
    gridpoints: int = 300,
    evaluations: int = 24,
) -> ImpulseResult:
    """The arrival at ``q_end`` with the most momentum along ``direction`` (base frame) within the
    limits.

    Raises
    ------
    InfeasiblePath
        The tool cannot move along ``direction`` at the target (singular), or no motion is feasible.
    """
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    Jv = jacobian(device, np.asarray(q_end, dtype=float), mount, com_in_tool)[:3]
    w = np.linalg.pinv(Jv) @ d
    if np.linalg.norm(Jv @ w - d) > 1e-6 or np.linalg.norm(w) < 1e-12:
        raise InfeasiblePath(
            "the tool cannot move along that direction at the target (a singular configuration)"
        )
    span = max(float(np.linalg.norm(np.asarray(q_end) - np.asarray(q_start))), 0.1)
    base = span / np.linalg.norm(w)

    lower, upper = device.limit_array("lower"), device.limit_array("upper")

    def evaluate(log_l: float, check_samples: int | None = None):
        L = base * np.exp(log_l)
        path = HermitePath(q_start, q_end, L * w)
        if range_excursions(
            path, lower, upper
        ):  # the approach swings a joint out of its range (exact extrema)
            return -np.inf, None
        try:
            timing, info = time_optimal(
                path,
                limits,
                dynamics,
                gravity,
                gridpoints,
                check_samples=check_samples,
                end_at_rest=False,
            )
        except InfeasiblePath:
            return -np.inf, None
        sd_end = np.sqrt(max(timing.x[-1], 0.0))
        v = Jv @ (L * w) * sd_end
        return float(v @ d), (L, path, timing, info, v, L * w * sd_end)

    golden = (np.sqrt(5) - 1) / 2
    a, b = np.log(0.05), np.log(20.0)
    c, e = b - golden * (b - a), a + golden * (b - a)
    fc, fe = evaluate(c)[0], evaluate(e)[0]
    for _ in range(
        evaluations
    ):  # golden-section search over the log tangent length (a cheaper torque check while searching)
        if fc >= fe:
            b, e, fe = e, c, fc
            c = b - golden * (b - a)
            fc = evaluate(c)[0]
        else:
            a, c, fc = c, e, fe
            e = a + golden * (b - a)
            fe = evaluate(e)[0]
    speed, found = evaluate(
        c if fc >= fe else e, check_samples=20001
    )  # the chosen motion gets the full dense guarantee
    if found is None or not np.isfinite(speed) or speed <= 0:
        raise InfeasiblePath(
            "no motion to the target within the limits (every approach tried leaves a joint's "
            "position "
            "range or exceeds a limit)"
        )
    L, path, timing, info, v, qd_end = found
    return ImpulseResult(
        mass * speed if mass > 0 else speed,
        speed,
        v,
        qd_end,
        timing.duration,
        L,
        info["binding"][-1] if info["binding"] else "",
        path,
        timing,
    )
