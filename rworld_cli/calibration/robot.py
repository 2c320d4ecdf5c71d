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

**Compliance** (``--model compliance``): a joint yields under the torque that holds the arm
against gravity, ``q_arm = q + c g(q)`` (the commanded ``q``; ``g`` from the cell's own link
masses and what the arm carries), one ``c`` per joint that carries a holding torque (Klimchik
et al.; Hollerbach, Khalil and Gautier, Springer Handbook of Robotics ch. 6).

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
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .. import spatial
from ..dynamics.compliance import compliances
from ..kinematics.forward import link_poses
from ..model.cell import DeviceModel
from ..model.measurements import RobotObservations  # noqa: F401  (read by schema/robotobs)

LENGTH_SCALE = 1e-3  # [m]: a typical length error, to scale the Jacobian's columns
ANGLE_SCALE = 1e-3  # [rad]
COMPLIANCE_SCALE = 1e-5  # [rad/(N m)]: a typical compliance error (industrial arms: 1e-7-1e-5)
COMPLIANCE_SCALE_PRISMATIC = 1e-6  # [m/N]


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
    # the torques that hold the arm against gravity, (K, n) [N m, N] at joint values (K, n),
    # with what it carries: the joints' deflection is compliance x these (None: a stiff arm)
    gravity: Callable[[np.ndarray], np.ndarray] | None = None
    # joints whose compliance is a parameter (indices; --model compliance)
    compliant: tuple[int, ...] = ()
    # the largest holding torque of each joint over its range [N m, N]: scales the compliance
    torque_scale: np.ndarray | None = None
    # (q, g(q)) of the last joint values asked (the fit asks the same at every difference)
    _held: tuple | None = field(default=None, init=False, repr=False, compare=False)

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
        out += [f"{self.device.joints[i].name}.compliance" for i in self.compliant]
        return out

    @property
    def compliance_start(self) -> int:
        """The index of the first compliance parameter (after the joints, target and frame)."""
        return 6 * self.device.dof + self.target_count + 6 * self.frame_estimated

    @property
    def scales(self) -> np.ndarray:
        joint = [LENGTH_SCALE] * 3 + [ANGLE_SCALE] * 3
        out = joint * self.device.dof + joint[: self.target_count]
        if self.frame_estimated:
            out += joint
        # a typical compliance error: 10 urad/Nm (1 um/N), or less where that would yield more
        # than 1 mrad (1 mm) at the joint's largest holding torque
        for i in self.compliant:
            prismatic = self.device.joints[i].kind == "prismatic"
            typical = LENGTH_SCALE if prismatic else ANGLE_SCALE
            cap = COMPLIANCE_SCALE_PRISMATIC if prismatic else COMPLIANCE_SCALE
            out.append(min(cap, typical / float(self.torque_scale[i])))  # type: ignore[index]
        return np.array(out)

    def deflected(self, device: DeviceModel, q: np.ndarray) -> np.ndarray:
        """The arm's joint values at commanded ``q`` (K, n): ``q + c * g(q)`` with each joint's
        compliance ``c`` of ``device`` (the commanded values when the arm is stiff)."""
        c = compliances(device)
        if self.gravity is None or not c.any():
            return q
        return q + c * self._holding(q)

    def _holding(self, q: np.ndarray) -> np.ndarray:
        """The gravity torques at ``q``, kept for the last array asked (the fit asks for the
        same observations at every parameter's difference)."""
        if self._held is not None and self._held[0] is q:
            return self._held[1]
        tau = np.asarray(self.gravity(q))  # type: ignore[misc]
        self._held = (q, tau)
        return tau

    def apply(self, p: np.ndarray) -> tuple[DeviceModel, np.ndarray, np.ndarray]:
        """(the device with its joint frames and compliance corrected, the target point,
        T_frame_base)."""
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
        if self.compliant:  # the compliance found added to the cell's own
            start = self.compliance_start
            joints = list(joints)
            for k, i in enumerate(self.compliant):
                j = joints[i]
                joints[i] = dataclasses.replace(j, compliance=j.compliance + p[start + k])
            joints = tuple(joints)
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
        link = link_poses(device, self.deflected(device, q))[:, self.link - 1]
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
    """A parameter the data cannot determine: kept exactly nominal.

    ``parameters``: the parameter (weight 1) and the identified ones its effect on the data is
    (nearly) a combination of, with their weights; ``sigma``: how well the data would determine
    it on its own, in units of its typical error (``inf``: not at all).
    """

    parameters: list[tuple[str, float]]  # (name, weight) of its largest entries
    sigma: float = float("inf")

    def describe(self) -> str:
        text = " + ".join(f"{w:+.2f} {n}" for n, w in self.parameters)
        if np.isfinite(self.sigma):
            return f"{text} (determined only to {self.sigma:.2g} x its typical error)"
        return text


@dataclass
class RobotCalibration:
    """The identified parameters and their statistics (SI, scaled back)."""

    model: RobotModel  # as fitted: its instrument frame registered first
    p: np.ndarray  # (P,) the estimate; 0 (nominal) for every parameter not identified
    sigma: np.ndarray  # (P,) 1 sigma of each parameter; 0 where kept nominal
    covariance: np.ndarray  # (P, P), scaled by the a-posteriori factor when it is above 1
    rank: int  # parameters identified
    unidentifiable: list[Unidentifiable]
    observability: float  # Borm and Menq's O1 of the scaled Jacobian of the identified ones
    residuals: np.ndarray  # (K, m) [m] after: positions (3), poses (6), contacts' gaps (1)
    residuals_before: np.ndarray  # (K, m) [m]
    iterations: int
    device: DeviceModel  # corrected
    T_frame_base: np.ndarray
    sigma_instrument: float = 0.0  # [m], 1 sigma per coordinate, as the files state it
    identified: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))  # indices
    converged: bool = True
    variance_factor: float = 1.0  # a-posteriori sigma / stated sigma (chi^2 / dof, rooted)
    T_frame_registered: np.ndarray = field(default_factory=lambda: np.eye(4))
    weights: np.ndarray | None = None  # (K,) the robust loss's final weights
    notes: list[str] = field(default_factory=list)

    @property
    def flagged(self) -> np.ndarray:
        """Observations far above the rest (indices, largest first): a residual over 5 times
        the median and over 4 a-posteriori sigmas."""
        d = np.linalg.norm(self.residuals, axis=1)
        floor = 4 * self.sigma_instrument * max(self.variance_factor, 1.0)
        big = np.flatnonzero((d > 5 * np.median(d)) & (d > floor))
        return big[np.argsort(-d[big])]

    def predicted_rms(self, q: np.ndarray) -> float:
        """The rms position error predicted at joint values ``q`` [m]: the estimate's own
        (its covariance) and what the parameters kept nominal do there (:meth:`predicted`)."""
        return float(np.hypot(*self.predicted(q)))

    def predicted(self, q: np.ndarray) -> tuple[float, float]:
        """(the estimate's rms error, the rms error of the parameters kept nominal) at joint
        values ``q`` [m].  The second: a typical error of each parameter not identified (1 mm,
        1 mrad), after the identified ones absorbed what the fit's data let them."""
        J = self.model.jacobian(self.p, q)
        per_coordinate = np.einsum("ij,jk,ik->i", J, self.covariance, J)
        estimate = float(np.sqrt(per_coordinate.reshape(-1, 3).sum(axis=1).mean()))
        kept = np.setdiff1d(np.arange(len(self.p)), self.identified)
        if not len(kept) or self._absorbed is None:
            return estimate, 0.0
        scales = self.model.scales
        J_s, J_e = J[:, self.identified] * scales[self.identified], J[:, kept] * scales[kept]
        induced = J_e - J_s @ self._absorbed  # (3K, E): per unit of each kept parameter
        return estimate, float(np.sqrt((induced**2).sum(axis=1).reshape(-1, 3).sum(axis=1).mean()))

    _absorbed: np.ndarray | None = None  # (S, E): identified change per kept parameter (scaled)


def register_frame(model: RobotModel, obs) -> tuple[RobotModel, np.ndarray]:
    """The instrument frame fitted first, in closed form, with the robot nominal: the rigid
    motion that best maps the nominal model's points onto the measured ones (Kabsch).  Returns
    the model with it and the frame's change ``C`` (``T_frame_base' = C T_frame_base``)."""
    a = model.points(np.zeros(len(model.names)), obs.q)
    b = obs.points
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    U, _, Vt = np.linalg.svd((a - ca).T @ (b - cb))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
    C = np.eye(4)
    C[:3, :3] = Vt.T @ D @ U.T
    C[:3, 3] = cb - C[:3, :3] @ ca
    return dataclasses.replace(model, T_frame_base=C @ model.T_frame_base), C


def rebased(model: RobotModel, p: np.ndarray) -> RobotModel:
    """``model`` with its instrument frame and target where the corrections ``p`` put them
    (the robot's own joints as they are): ``p`` of a frame-only fit becomes the zero."""
    _, target, T = model.apply(p)
    return dataclasses.replace(
        model,
        T_frame_base=T,
        p_link_target=target[:3, 3].copy(),
        R_link_target=None if model.R_link_target is None else target[:3, :3].copy(),
    )


def preference(model: RobotModel) -> list[int]:
    """The order parameters are taken in when the data cannot tell some apart: the instrument
    frame first (a base error is the instrument's, not joint 1's), then the target's offset,
    then the joints from the base to the flange (x, y, z, rx, ry, rz each), then the joints'
    compliance."""
    n6 = 6 * model.device.dof
    m = model.target_count
    start = model.compliance_start
    order = list(range(n6 + m, start))  # the frame, when estimated
    order += list(range(n6, n6 + m))
    # the joints' compliance last: what geometry explains is geometry's
    return order + list(range(n6)) + list(range(start, len(model.names)))


def on_last_axis(model: RobotModel, tolerance: float = 1e-3) -> float | None:
    """The distance [m] of a measured point from the last joint's axis when it lies within
    ``tolerance`` of it (its orientation about and across that axis is then unseen), else
    None; None for measured poses."""
    if model.R_link_target is not None:
        return None
    dev = model.device
    if dev.joints[-1].kind != "revolute":
        return None
    q = np.zeros(dev.dof)
    T_last = link_poses(dev, q[None])[0][-1]
    point = T_last @ np.append(model.p_link_target, 1.0)
    # the last joint's axis: where link n turns about, in the frame of link n - 1
    turned = link_poses(dev, np.r_[q[:-1], 1.0][None])[0][-1]
    R = turned[:3, :3] @ T_last[:3, :3].T
    angle = np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))
    if angle < 1e-9:
        return None
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / (2 * np.sin(angle))
    # a point on the axis: fixed by the turn (least squares of (R - I) x = t - R t_last...)
    t = turned[:3, 3] - R @ T_last[:3, 3]
    on_axis = np.linalg.lstsq(np.eye(3) - R, t, rcond=None)[0]
    v = point[:3] - on_axis
    distance = float(np.linalg.norm(v - (v @ axis) * axis))
    return distance if distance <= tolerance else None


def select(
    J: np.ndarray, order: list[int], sigma: float, excluded: set[int] = frozenset()
) -> tuple[list[int], dict[int, float]]:
    """The identified parameters: each column of the scaled Jacobian ``J`` (in units of the
    parameter's typical error) taken in ``order`` when the data determine it, beside the ones
    already taken, to better than its typical error (its sigma below 1 in those units, with
    the instrument's ``sigma``) and it is not numerically dependent on them; then, while any
    taken parameter's sigma in the joint fit is above 1, the worst is let go.  Returns (taken,
    {let go: its sigma in typical errors, inf when dependent})."""
    taken: list[int] = []
    basis = np.zeros((J.shape[0], 0))
    dropped: dict[int, float] = {}
    largest = float(np.linalg.norm(J, axis=0).max()) or 1.0
    for k in order:
        if k in excluded:
            dropped[k] = float("inf")
            continue
        c = J[:, k]
        orth = c - basis @ (basis.T @ c)
        size = float(np.linalg.norm(orth))
        if size <= 1e-7 * largest:
            dropped[k] = float("inf")
            continue
        if sigma / size > 1.0:
            dropped[k] = sigma / size
            continue
        taken.append(k)
        basis = np.hstack([basis, (orth / size)[:, None]])
    while taken:
        Js = J[:, taken]
        spread = sigma * np.sqrt(np.diag(np.linalg.pinv(Js.T @ Js)))
        worst = int(np.argmax(spread))
        if spread[worst] <= 1.0:
            break
        dropped[taken.pop(worst)] = float(spread[worst])
    return taken, dropped


LOSSES = ("linear", "huber", "soft_l1")


def _weights(norms: np.ndarray, loss: str, scale: float) -> np.ndarray:
    """IRLS weights of each observation's residual norm under the robust ``loss``."""
    z = norms / scale
    if loss == "huber":
        return np.where(z <= 1.0, 1.0, 1.0 / np.maximum(z, 1e-300))
    if loss == "soft_l1":
        return 1.0 / np.sqrt(1.0 + z**2)
    return np.ones_like(norms)


def identify(
    model: RobotModel,
    obs: RobotObservations,
    iterations: int = 50,
    loss: str = "linear",
    loss_scale: float | None = None,
    frame_only: bool = False,
) -> RobotCalibration:
    """Maximum-likelihood estimate of the identifiable parameters from ``obs``.

    The gauge is fixed the way the literature fixes it: an estimated instrument frame is first
    registered in closed form with the robot nominal (:func:`register_frame`), then fitted
    with the target's offset, the robot still nominal (``frame_only``; :func:`rebased`), so the
    same data give the same robot from any starting pose of the instrument and any guess of
    the target, and the corrections ``p`` count from that rigid fit; then the parameters
    are taken in a stated order (:func:`preference`) while the data determine each to better
    than its typical error (:func:`select`); the others stay exactly nominal and are listed.
    A point on the last joint's axis leaves that joint's rotations nominal.

    Gauss-Newton on the identified parameters (iteratively reweighted for a robust ``loss``,
    huber or soft_l1, with ``loss_scale`` [m], default 3 sigma) until the cost changes by less
    than 1e-10 of itself; the covariance is ``sigma^2 (J^T W J)^-1`` scaled by the
    a-posteriori variance factor (chi^2 / dof) when that is above 1.  ``frame_only``: only the
    instrument frame (and the target's offset) are fitted, the robot nominal.

    Raises
    ------
    ValueError
        An unknown loss.
    """
    if loss not in LOSSES:
        raise ValueError(f"loss must be one of {', '.join(LOSSES)}, not {loss!r}")
    P = len(model.names)
    C = np.eye(4)
    notes: list[str] = []
    if obs.surfaces is None:  # points or poses of a target (contacts: the surfaces' frame)
        T_given, target_given = model.T_frame_base, model.p_link_target
        if model.frame_estimated:
            model, C = register_frame(model, obs)
        if not frame_only:
            # then the frame and the target's offset fitted with the robot nominal (a rigid
            # fit, iterated): the robot's corrections start there, whatever the cell's guesses
            rigid = identify(model, obs, iterations, loss, loss_scale, frame_only=True)
            model = rebased(rigid.model, rigid.p)
            C = model.T_frame_base @ np.linalg.inv(T_given)
            moved = float(np.linalg.norm(model.p_link_target - target_given))
            if moved > 1e-3:
                notes.append(
                    f"the target's offset on its link, fitted first with the robot nominal"
                    f"{' (and the instrument frame)' if model.frame_estimated else ''}, lies "
                    f"{moved * 1000:.1f} mm from the cell's; the robot's corrections (and "
                    "--max-correction) start from that fit"
                )
    scales = model.scales
    p = np.zeros(P)
    before = model.residuals(p, obs)
    excluded: set[int] = set()
    n6 = 6 * model.device.dof
    if frame_only:
        excluded = set(range(n6)) | set(range(model.compliance_start, P))
    distance = on_last_axis(model)
    if distance is not None and not frame_only:
        excluded |= {n6 - 3, n6 - 2, n6 - 1}
        name = model.device.joints[-1].name
        notes.append(
            f"the target lies on {name}'s axis ({distance * 1000:.2f} mm off it): the flange's "
            f"orientation ({name}'s tilt and zero) is not determined and stays nominal; the "
            "calibration holds for points on that axis"
        )
    m_per = before.shape[1]
    J = model.residual_jacobian(p, obs) * scales
    taken, dropped = select(J, preference(model), obs.sigma, excluded)
    weights = np.ones(len(obs.q))
    scale = loss_scale if loss_scale is not None else 3 * obs.sigma * np.sqrt(m_per)
    cost_old, done, converged = None, 0, False
    for done in range(1, iterations + 1 if taken else 1):
        e = model.residuals(p, obs)
        weights = _weights(np.linalg.norm(e, axis=1), loss, scale)
        root = np.repeat(np.sqrt(weights), m_per)
        cost = float(np.sum(root**2 * e.ravel() ** 2))
        if cost_old is not None and abs(cost_old - cost) <= 1e-10 * max(cost, 1e-300):
            converged = True
            break
        cost_old = cost
        if done > 1:
            J = model.residual_jacobian(p, obs) * scales
        Js = J[:, taken] * root[:, None]
        step = np.linalg.lstsq(Js, -(root * e.ravel()), rcond=None)[0]
        p[taken] = p[taken] + step * scales[taken]
        if np.abs(step).max() < 1e-12:  # scaled units: 1e-15 m, 1e-15 rad
            converged = True
            break
    after = model.residuals(p, obs)
    J = model.residual_jacobian(p, obs) * scales
    root = np.repeat(np.sqrt(weights), m_per)
    Js = J[:, taken] * root[:, None]
    dof = max(len(after.ravel()) - len(taken), 1)
    chi2 = float(np.sum(root**2 * after.ravel() ** 2)) / obs.sigma**2
    factor = float(np.sqrt(chi2 / dof))
    information = np.linalg.pinv(Js.T @ Js) if taken else np.zeros((0, 0))
    covariance = np.zeros((P, P))
    covariance[np.ix_(taken, taken)] = (
        obs.sigma**2 * max(factor, 1.0) ** 2 * information * np.outer(scales[taken], scales[taken])
    )
    names = model.names
    unidentifiable = []
    kept = [k for k in range(P) if k not in taken]
    absorbed = information @ Js.T @ (J[:, kept] * root[:, None]) if taken and kept else None
    if not taken:
        notes.append(
            f"with the stated sigma ({obs.sigma * 1000:g} mm) the data determine no parameter "
            "to better than its typical error (1 mm, 1 mrad): nothing is identified"
        )
    for column, k in enumerate(kept):
        entries = [(names[k], 1.0)]
        if absorbed is not None:
            beta = absorbed[:, column]
            for j in np.argsort(-np.abs(beta))[:3]:
                if abs(beta[j]) > 0.05:
                    entries.append((names[taken[j]], float(-beta[j])))
        unidentifiable.append(Unidentifiable(entries, dropped.get(k, float("inf"))))
    observability = observability_index(J[:, taken], len(obs.q))
    device, _, T = model.apply(p)
    out = RobotCalibration(
        model,
        p,
        np.sqrt(np.maximum(np.diag(covariance), 0.0)),
        covariance,
        len(taken),
        unidentifiable,
        observability,
        after,
        before,
        done,
        device,
        T,
        obs.sigma,
        np.array(taken, dtype=int),
        converged,
        factor,
        np.linalg.inv(C),
        weights if loss != "linear" else None,
        notes,
    )
    out._absorbed = absorbed
    return out


def observability_index(J: np.ndarray, poses: int) -> float:
    """Borm and Menq's O1 of an identification Jacobian ``J`` (rows, identified parameters;
    columns scaled to their typical errors) over ``poses`` poses: the geometric mean of its
    singular values over the root of the poses; 0 with no column."""
    if J.shape[1] == 0:
        return 0.0
    singular = np.linalg.svd(J, compute_uv=False)
    return float(np.exp(np.log(singular).mean()) / np.sqrt(poses))


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
