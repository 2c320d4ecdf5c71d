"""Robot kinematic calibration: the robot's own errors identified from points an external
instrument measured on a frame the robot carries (a laser tracker's reflector, a CMM arm's
probe), at known joint values.

**The error model**: every joint takes a small pose error ``E(d) = (Rot(d[3:]), d[:3])``, 6
numbers per joint - three lengths, two tilts of the axis (a tilt between nearly parallel axes is
one of them: no DH singularity, as Hayati's beta avoids it) and the joint's zero (the rotation
about its own axis).  A joint frame (the URDF's ``origin``) takes it on its right,
``origin' = origin @ E(d)``; a DH row before it, ``A' = E(d) @ A`` (the row's
``correction``).  The measured frame's offset on its link takes 3 (a point) more, and an
instrument frame other than the world 6 more.  The base pose needs none: an error there is an
error of joint 1's frame.

**Identifiability.**  The model is complete and so redundant: a length along two parallel
axes, a rotation about an axis that only turns what is measured about itself.  The singular
value decomposition of the identification Jacobian, each column scaled by the parameter's
typical error (1 mm, 1 mrad), finds the combinations the data cannot determine: they stay
nominal (the minimum-norm step), and each is reported with the parameters it mixes.

**Estimation.**  Gauss-Newton on the scaled, truncated system: with Gaussian noise of the given
sigma the estimate is the maximum-likelihood one and its covariance ``sigma^2 (J^T J)^+`` is
the Cramer-Rao bound of the identifiable combinations; predicted position errors follow from
it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .. import spatial
from ..kinematics.forward import link_poses
from ..model.cell import DeviceModel
from ..model.measurements import RobotObservations  # noqa: F401  (read by schema/robotobs)

LENGTH_SCALE = 1e-3  # [m]: a typical length error, to scale the Jacobian's columns
ANGLE_SCALE = 1e-3  # [rad]


def small_pose(d: np.ndarray) -> np.ndarray:
    """The pose ``(Rot(rotation vector d[3:]), d[:3])`` (4, 4)."""
    T = np.eye(4)
    angle = float(np.linalg.norm(d[3:]))
    if angle > 0:
        T[:3, :3] = spatial.axis_rotation(d[3:] / angle, angle)
    T[:3, 3] = d[:3]
    return T


@dataclass
class RobotModel:
    """The chain and what is measured, as the calibration sees it (SI).

    ``T_frame_base`` (the device's base in the instrument's frame), ``link`` (1..n, the link
    carrying the target) and ``p_link_target`` (the target point in that link's frame).
    """

    device: DeviceModel
    T_frame_base: np.ndarray
    link: int
    p_link_target: np.ndarray
    frame_estimated: bool  # the instrument's frame is a parameter (it is not the world)
    R_link_target: np.ndarray | None = None  # set: full poses are measured (6-DoF)

    @property
    def target_count(self) -> int:
        return 3 if self.R_link_target is None else 6

    @property
    def names(self) -> list[str]:
        out = []
        six = ("x", "y", "z", "rx", "ry", "rz")
        for j in self.device.joints:
            out += [f"{j.name}.{k}" for k in six]
        out += [f"target.{k}" for k in six[: self.target_count]]
        if self.frame_estimated:
            out += [f"frame.{k}" for k in six]
        return out

    @property
    def scales(self) -> np.ndarray:
        joint = [LENGTH_SCALE] * 3 + [ANGLE_SCALE] * 3
        out = joint * self.device.dof + joint[: self.target_count]
        if self.frame_estimated:
            out += joint
        return np.array(out)

    def apply(self, p: np.ndarray) -> tuple[DeviceModel, np.ndarray, np.ndarray]:
        """(the device with its joint frames corrected, the target point, T_frame_base)."""
        n = self.device.dof
        if self.device.convention == "frames":  # the joint frame: origin' = origin E
            joints = tuple(
                dataclasses.replace(
                    j, origin=np.asarray(j.origin) @ small_pose(p[6 * i : 6 * i + 6])
                )
                for i, j in enumerate(self.device.joints)
            )
        else:  # a DH row: A' = E A, after any correction it has
            joints = tuple(
                dataclasses.replace(
                    j,
                    correction=(np.eye(4) if j.correction is None else j.correction)
                    @ small_pose(p[6 * i : 6 * i + 6]),
                )
                for i, j in enumerate(self.device.joints)
            )
        device = dataclasses.replace(self.device, joints=joints)
        m = self.target_count
        target = np.eye(4)
        if self.R_link_target is None:  # a point: its offset on the link
            target[:3, 3] = self.p_link_target + p[6 * n : 6 * n + 3]
        else:  # a frame: its pose on the link, moved in its own axes
            target[:3, :3], target[:3, 3] = self.R_link_target, self.p_link_target
            target = target @ small_pose(p[6 * n : 6 * n + 6])
        T = self.T_frame_base
        if self.frame_estimated:  # the instrument frame F' = F E: points in F' = E^-1 (F-based)
            T = np.linalg.solve(small_pose(p[6 * n + m : 6 * n + m + 6]), T)
        return device, target, T

    def poses(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """The target frame in the instrument's frame at joint values ``q`` (K, n): (K, 4, 4)."""
        device, target, T = self.apply(p)
        link = link_poses(device, q)[:, self.link - 1]
        return T @ link @ target

    def points(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """The target in the instrument's frame at joint values ``q`` (K, n): (K, 3) [m]."""
        return self.poses(p, q)[:, :3, 3]

    def residuals(self, p: np.ndarray, obs) -> np.ndarray:
        """Model minus measurement per observation, (K, 3) [m], or (K, 6) for poses with the
        rotation's error (rotation vector) weighted to the position's sigma."""
        T = self.poses(p, obs.q)
        if obs.surfaces is not None:  # the ball on a known surface: its gap, one per contact
            return obs.surfaces.gaps(T[:, :3, 3])[:, None]
        position = T[:, :3, 3] - obs.points
        if obs.rotations is None:
            return position
        turn = spatial.rotation_vector(np.swapaxes(obs.rotations, -1, -2) @ T[:, :3, :3])
        return np.hstack([position, turn * (obs.sigma / obs.sigma_angle)])

    def residual_jacobian(self, p: np.ndarray, obs) -> np.ndarray:
        """d residuals / d p, (K m, P), by central differences."""
        return _differences(lambda x: self.residuals(x, obs), p)

    def jacobian(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """d points / d p, (3K, P), by central differences."""
        return _differences(lambda x: self.points(x, q), p)


def _differences(f, p: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central differences of ``f`` (P,) -> array, flattened: (len(f(p).ravel()), P); one
    batched evaluation pair per parameter, over all observations (error of order h^2)."""
    columns = []
    for k in range(len(p)):
        dp = np.zeros(len(p))
        dp[k] = h
        columns.append((f(p + dp) - f(p - dp)).ravel() / (2 * h))
    return np.array(columns).T


@dataclass
class Unidentifiable:
    """A combination of parameters the data cannot determine: kept nominal."""

    parameters: list[tuple[str, float]]  # (name, weight) of its largest entries

    def describe(self) -> str:
        return " + ".join(f"{w:+.2f} {n}" for n, w in self.parameters)


@dataclass
class RobotCalibration:
    """The identified parameters and their statistics (SI, scaled back)."""

    model: RobotModel
    p: np.ndarray  # (P,) the estimate
    sigma: np.ndarray  # (P,) 1 sigma of each parameter (of its identifiable part)
    covariance: np.ndarray  # (P, P)
    rank: int
    unidentifiable: list[Unidentifiable]
    observability: float  # Borm and Menq's O1 of the scaled Jacobian's identifiable part
    residuals: np.ndarray  # (K, m) [m] after: positions (3), poses (6), contacts' gaps (1)
    residuals_before: np.ndarray  # (K, m) [m]
    iterations: int
    device: DeviceModel  # corrected
    T_frame_base: np.ndarray
    sigma_instrument: float = 0.0  # [m], 1 sigma per coordinate

    @property
    def flagged(self) -> np.ndarray:
        """Observations with a coordinate's residual over 4 sigma (indices)."""
        return np.flatnonzero(np.abs(self.residuals).max(axis=1) > 4 * self.sigma_instrument)

    def predicted_rms(self, q: np.ndarray) -> float:
        """The rms position error the estimate's covariance predicts at joint values ``q`` [m]
        (the Cramer-Rao bound of the calibrated model's prediction)."""
        J = self.model.jacobian(self.p, q)
        per_coordinate = np.einsum("ij,jk,ik->i", J, self.covariance, J)
        return float(np.sqrt(per_coordinate.reshape(-1, 3).sum(axis=1).mean()))


def identify(model: RobotModel, obs: RobotObservations, iterations: int = 20) -> RobotCalibration:
    """Maximum-likelihood estimate of the identifiable parameters from ``obs``.

    Raises
    ------
    ValueError
        Fewer equations than identifiable parameters.
    """
    P = len(model.names)
    p = np.zeros(P)
    scales = model.scales
    q = obs.q
    before = model.residuals(p, obs)
    rank, U, s, Vt = 0, None, None, None
    done = 0
    for done in range(1, iterations + 1):
        e = model.residuals(p, obs).ravel()
        J = model.residual_jacobian(p, obs) * scales  # scaled columns
        U, s, Vt = np.linalg.svd(J, full_matrices=False)
        rank = int(np.sum(s > s[0] * 1e-6))
        step = -Vt[:rank].T @ ((U[:, :rank].T @ e) / s[:rank])
        p = p + step * scales
        if np.abs(step).max() < 1e-9:  # in scaled units: 1e-12 m, 1e-12 rad
            break
    assert Vt is not None and s is not None
    after = model.residuals(p, obs)
    V = Vt[:rank].T
    covariance_scaled = obs.sigma**2 * (V / s[:rank] ** 2) @ V.T
    covariance = covariance_scaled * np.outer(scales, scales)
    names = model.names
    unidentifiable = []
    for v in Vt[rank:]:
        order = np.argsort(-np.abs(v))[:4]
        entries = [(names[k], float(v[k])) for k in order if abs(v[k]) > 0.05]
        unidentifiable.append(Unidentifiable(entries))
    # Borm and Menq's O1: the geometric mean of the singular values over the root of the count
    observability = float(np.exp(np.log(s[:rank]).mean()) / np.sqrt(len(q))) if rank else 0.0
    device, _, T = model.apply(p)
    out = RobotCalibration(
        model,
        p,
        np.sqrt(np.maximum(np.diag(covariance), 0.0)),
        covariance,
        rank,
        unidentifiable,
        observability,
        after,
        before,
        done,
        device,
        T,
        obs.sigma,
    )
    return out


def position_errors(model: RobotModel, p: np.ndarray, obs: RobotObservations) -> dict:
    """rms, 95th percentile and largest distance [m] between the model's points and ``obs``
    (contacts: the ball's gap to its surface)."""
    if obs.surfaces is not None:
        d = np.abs(model.residuals(p, obs)[:, 0])
    else:
        d = np.linalg.norm(model.points(p, obs.q) - obs.points, axis=1)
    return {
        "rms": float(np.sqrt(np.mean(d**2))),
        "p95": float(np.percentile(d, 95)),
        "max": float(d.max()),
    }
