"""Straight-line TCP moves: a timed pose path, inverse kinematics along it, re-timed to the
joint limits.
"""

from __future__ import annotations

import math

import numpy as np

from .. import spatial
from ..kinematics.inverse import track
from ..kinematics.jacobian import ToolMount, tool_pose
from ..model.cell import DeviceModel
from ..units import (
    ANGULAR_ACCELERATION,
    ANGULAR_SPEED,
    LINEAR_ACCELERATION,
    LINEAR_SPEED,
    MAX_SAMPLES,
)
from .trajectory import SampledMove, TrapezoidProfile, interpolate_poses

# a line that its joints' rates would slow by more than this, past this condition number on
# its way, passes a singularity (a wrist flipping), and is refused as such
SINGULAR_SLOWDOWN = 20.0
SINGULAR_CONDITION = 1e4


class PathError(Exception):
    """A linear path cannot be followed; ``fraction`` says where along it."""

    def __init__(self, reason: str, fraction: float, detail: str):
        super().__init__(detail)
        self.reason, self.fraction, self.detail = reason, fraction, detail


def linear_move(
    device: DeviceModel,
    mount: ToolMount | None,
    t0: float,
    q_start,
    T_base_target,
    dt: float,
    speed: float = 1.0,
    acceleration: float = 1.0,
    position_only: bool = False,
) -> SampledMove | None:
    """A straight TCP line from where the tool is to ``T_base_target``, within the joint limits.

    The path is timed by a trapezoid under the Cartesian limits above (scaled
    by ``speed`` and ``acceleration``), solved by IK at every ``dt``, and
    slowed down as a whole if a joint would exceed its velocity or
    acceleration limit.

    Raises
    ------
    PathError
        The line leaves the workspace or passes a singularity (a joint would turn at more than
        ``SINGULAR_SLOWDOWN`` times its top speed there), with the fraction of the path; it
        cannot be kept within the joints' limits; it takes more clock samples than the bound.
    """
    q_start = np.asarray(q_start, dtype=float)
    T_start = tool_pose(device, q_start, mount)
    dp = float(np.linalg.norm(T_base_target[:3, 3] - T_start[:3, 3]))
    dth = (
        0.0
        if position_only
        else float(
            np.linalg.norm(spatial.rotation_vector(T_start[:3, :3].T @ T_base_target[:3, :3]))
        )
    )
    if dp < 1e-9 and dth < 1e-9:
        return None
    V = min(LINEAR_SPEED * speed / max(dp, 1e-12), ANGULAR_SPEED * speed / max(dth, 1e-12))
    A = min(
        LINEAR_ACCELERATION * acceleration / max(dp, 1e-12),
        ANGULAR_ACCELERATION * acceleration / max(dth, 1e-12),
    )
    v_max, a_max = device.limit_array("velocity"), device.limit_array("acceleration")
    slowdown = 1.0  # how much the rounds have slowed the line so far
    for _ in range(8):  # re-timing rounds, not samples
        profile = TrapezoidProfile.fit(V, A)
        if not profile.T / dt <= MAX_SAMPLES:  # bounded before anything is allocated
            raise PathError(
                "samples",
                0.0,
                f"the line takes {profile.T:.4g} s: {profile.T / dt:.3g} clock samples at dt "
                f"{dt:g} s, above the bound of {MAX_SAMPLES:,}",
            )
        K = max(3, math.ceil(profile.T / dt) + 1)
        tau = np.linspace(0.0, profile.T, K)
        s = profile.evaluate(tau)[0]
        targets = interpolate_poses(T_start, T_base_target, s)
        if position_only:
            targets[:, :3, :3] = T_start[:3, :3]
        # no condition bound here: beside a singularity the tracking keeps 1e-6, and the
        # re-timing below tells a line that only runs slowly from a wrist that must flip
        result = track(device, targets, q_start, mount, position_only, max_condition=np.inf)
        if result.failed_at is not None:
            fraction = float(s[result.failed_at])
            raise PathError(
                "unreachable",
                fraction,
                f"the line leaves the workspace at {fraction:.0%} of the path "
                f"({result.error * 1000:.3g} mm short)",
            )
        qd = np.gradient(result.q, tau, axis=0)
        qdd = np.gradient(qd, tau, axis=0)
        ratio = max(
            float(np.max(np.abs(qd) / v_max)), math.sqrt(float(np.max(np.abs(qdd) / a_max)))
        )
        if ratio <= 1.0 + 1e-6:
            return SampledMove(t0, t0 + tau, result.q, qd, qdd)
        slowdown *= ratio
        if slowdown > SINGULAR_SLOWDOWN and result.condition > SINGULAR_CONDITION:
            # beside a singularity: a wrist that must flip, not a line to drive slowly
            k, j = np.unravel_index(int(np.argmax(np.abs(qd) / v_max)), qd.shape)
            fraction = float(s[k])
            raise PathError(
                "singular",
                fraction,
                f"the line passes a singularity at {fraction:.0%} of the path: "
                f"{device.joints[j].name} would turn at {slowdown:.3g} x its top speed "
                f"(Jacobian condition number {result.condition:.3g})",
            )
        V, A = V / (ratio * 1.05), A / (ratio * 1.05) ** 2
    raise PathError(
        "limits",
        1.0,
        "cannot keep the joints within their velocity and acceleration limits on this line",
    )
