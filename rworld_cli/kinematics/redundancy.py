"""The arm angle of a 7-axis arm (shoulder - elbow - wrist, as the KUKA LBR iiwa and Med are
built) and inverse kinematics that holds it.

The arm angle ``psi`` is the turn of the plane through the shoulder S, the elbow E and the
wrist W about the line from S to W, from the vertical plane through that line (``psi = 0``:
the elbow in the plane of S, W and the base's z axis, on the side z points to; positive by
the right hand about S -> W).  Where S -> W is vertical the base's x axis stands in for z.
S, E and W are where neighbouring joint axes meet (axes 1 and 2, 3 and 4, 5 and 6: for an
arm whose axes do not quite meet, the point of the second nearest the first).  For the LBR,
KUKA's own redundancy value ``E1`` is axis A3's angle: ``psi`` is the geometric one
(Shimizu et al., IEEE T-RO 24(5), 2008, use the same parametrisation with another reference
plane).
"""

from __future__ import annotations

import numpy as np

from ..model.cell import DeviceModel
from .configuration import _nearest_on, joint_axes
from .inverse import _errors, nearest_turns, solve_ik
from .jacobian import ToolMount, tool_pose

#: a start is given up when its residual fell by less than STALL_GAIN (relative) over the last
#: STALL_ITERATIONS steps: starts that converge do so in 10-40 steps, and every start the LBR's
#: tests ran 200 steps for ended where it stood after 20 (2026-11-29)
STALL_ITERATIONS = 20
STALL_GAIN = 0.01


def is_seven_axis_arm(device: DeviceModel) -> bool:
    """Seven revolute joints: a shoulder, an elbow and a wrist with one turn to spare."""
    return device.dof == 7 and all(j.kind == "revolute" for j in device.joints)


def shoulder_elbow_wrist(device: DeviceModel, Q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """S, E, W (K, 3) [m] in the device's natural frame at joint states ``Q`` (K, 7)."""
    points, directions = joint_axes(device, np.atleast_2d(np.asarray(Q, dtype=float)))
    S = _nearest_on(points[:, 0], directions[:, 0], points[:, 1], directions[:, 1])
    E = _nearest_on(points[:, 2], directions[:, 2], points[:, 3], directions[:, 3])
    W = _nearest_on(points[:, 4], directions[:, 4], points[:, 5], directions[:, 5])
    return S, E, W


def arm_angle(device: DeviceModel, Q) -> np.ndarray:
    """The arm angle (module docstring) of joint states ``Q`` (K, 7): (K,) [rad] in (-pi, pi]."""
    S, E, W = shoulder_elbow_wrist(device, Q)
    axis = W - S
    axis = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    up = np.broadcast_to([0.0, 0.0, 1.0], axis.shape)
    vertical = np.abs(np.einsum("ki,ki->k", axis, up)) > 1 - 1e-9
    up = np.where(vertical[:, None], [1.0, 0.0, 0.0], up)
    reference = up - np.einsum("ki,ki->k", up, axis)[:, None] * axis
    elbow = (E - S) - np.einsum("ki,ki->k", E - S, axis)[:, None] * axis
    sine = np.einsum("ki,ki->k", np.cross(reference, elbow), axis)
    return np.arctan2(sine, np.einsum("ki,ki->k", reference, elbow))


def _wrapped(angle):
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def solve_ik_arm_angle(
    device: DeviceModel,
    T_base_target,
    psi: float,
    mount: ToolMount | None = None,
    seed=None,
    restarts: int = 24,
    tolerance: float = 1e-9,
    max_iterations: int = 200,
    random_seed: int = 0,
):
    """Joint values (7,) [rad] that put the tool frame on ``T_base_target`` (4, 4) with the
    arm angle ``psi`` [rad], within the limits; None when no start converges.

    Damped least squares (Levenberg-Marquardt) on seven equations - the pose's six
    (``inverse._errors``) and the arm angle's - in seven unknowns, the Jacobian by central
    differences; from ``seed`` (default the home pose), then from the pose's own IK solution
    nearest it (six equations), then from ``restarts`` random starts within the limits.  The
    solution taken is the one nearest the seed (wide-range joints compared modulo a turn).
    """
    target = np.asarray(T_base_target, dtype=float)
    lower, upper = device.limit_array("lower"), device.limit_array("upper")
    box_lo, box_hi = (
        np.where(np.isfinite(lower), lower, -np.pi),
        np.where(np.isfinite(upper), upper, np.pi),
    )
    seed = np.asarray(device.home if seed is None else seed, dtype=float)
    rng = np.random.default_rng(random_seed)
    starts = [seed]
    # the pose alone first (the six equations, batched): from there only the turn about
    # S -> W is left to find, a few iterations
    posed = solve_ik(device, target, mount, seed, restarts=4)
    if posed.success:
        starts.append(np.asarray(posed.q, dtype=float))
    starts += list(rng.uniform(box_lo, box_hi, (restarts, device.dof)))

    def residuals(Q):  # (K, 7) -> (K, 7): the pose's six errors and the arm angle's
        Q = np.atleast_2d(Q)
        out = np.empty((len(Q), 7))
        out[:, :6] = _errors(tool_pose(device, Q, mount), target)
        out[:, 6] = _wrapped(arm_angle(device, Q) - psi)
        return out

    h = 1e-7
    steps = np.vstack([np.eye(device.dof), -np.eye(device.dof)]) * h
    found: list[np.ndarray] = []
    for q in starts:
        q = q.copy()
        damping = 1e-3
        r = residuals(q)[0]
        history = [float(np.linalg.norm(r))]
        for _ in range(max_iterations):
            if np.abs(r).max() < tolerance:
                break
            if (
                len(history) > STALL_ITERATIONS
                and history[-1] > (1 - STALL_GAIN) * history[-1 - STALL_ITERATIONS]
            ):
                break  # a local minimum (most random starts end in one): the next start
            around = residuals(q + steps)  # central differences, one batch
            J = ((around[: device.dof] - around[device.dof :]) / (2 * h)).T
            if not (np.all(np.isfinite(J)) and np.all(np.isfinite(r))):
                break  # the arm angle is undefined here (shoulder, elbow and wrist in line)
            try:
                dq = -np.linalg.solve(J.T @ J + damping * np.eye(device.dof), J.T @ r)
            except np.linalg.LinAlgError:
                break  # this start leads nowhere; the next one is tried
            trial = np.clip(q + dq, lower, upper)
            r_trial = residuals(trial)[0]
            if np.linalg.norm(r_trial) < np.linalg.norm(r):
                q, r = trial, r_trial
                damping = max(damping / 3, 1e-12)
            else:
                damping *= 5
                if damping > 1e6:
                    break
            history.append(float(np.linalg.norm(r)))
        if np.abs(r).max() < 1e-7:
            found.append(q)
            if len(found) >= 3 or np.allclose(q, seed, atol=np.pi / 2):
                break  # near the seed (the solution a joint move from it takes), or enough
    if not found:
        return None
    revolute = np.ones(device.dof, dtype=bool)
    found = [nearest_turns(q, seed, revolute, lower, upper) for q in found]
    return min(found, key=lambda q: float(np.linalg.norm(q - seed)))
