"""The static description of a cell, in SI units, as the algorithms use it.

Built once by the loader from validated files; immutable afterwards.  The
mutable state (joint values, the affixment tree as programs change it) lives
in :class:`rworld_cli.world.tree.World`.

Frame names are qualified: a primitive's natural frame has the primitive's
name (``puma``); auxiliary, link and TCP frames are ``owner.name``
(``puma.link6``, ``puma.tool``, ``block.frame3``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from .vision import BoardModel, CameraModel

PrimitiveKind = Literal["object", "sensor", "device"]
FrameKind = Literal["world", "natural", "auxiliary", "free", "link", "tcp"]
WORLD = "world"


@dataclass(frozen=True)
class Inertial:
    """Mass properties of a rigid body.

    Attributes
    ----------
    mass : float
        [kg]
    com : ndarray, shape (3,)
        Centre of mass in the body's frame [m].
    inertia : ndarray, shape (3, 3)
        Inertia tensor about the centre of mass, body-frame axes [kg m^2].
    """

    mass: float
    com: np.ndarray
    inertia: np.ndarray

    @staticmethod
    def zero() -> Inertial:
        return Inertial(0.0, np.zeros(3), np.zeros((3, 3)))

    @staticmethod
    def combine(parts: list[tuple[Inertial, np.ndarray]]) -> Inertial:
        """The mass properties of rigidly joined bodies, in one frame.

        Parameters
        ----------
        parts : list of (Inertial, ndarray (4, 4))
            Each body's mass properties with ``T_frame_body``, the body's frame in the
            common frame.

        Returns
        -------
        Inertial
            Total mass, centre of mass in the common frame, and the inertia about it
            (parallel-axis theorem).
        """
        mass = float(sum(part.mass for part, _ in parts))
        coms = [T[:3, :3] @ part.com + T[:3, 3] for part, T in parts]
        com = np.zeros(3)
        if mass > 0.0:
            com = sum((part.mass * c for (part, _), c in zip(parts, coms)), np.zeros(3)) / mass
        inertia = np.zeros((3, 3))
        for (part, T), c in zip(parts, coms):
            R = T[:3, :3]
            r = c - com
            inertia += R @ part.inertia @ R.T + part.mass * (r @ r * np.eye(3) - np.outer(r, r))
        return Inertial(float(mass), com, inertia)


@dataclass(frozen=True)
class Box:
    """An oriented box: ``T_owner_box`` places its centre; ``half_extents`` [m] along its axes."""

    T_owner_box: np.ndarray
    half_extents: np.ndarray

    def corners(self) -> np.ndarray:
        """The 8 corners in the owner's frame, shape (8, 3)."""
        signs = np.array(
            [[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float
        )
        local = signs * self.half_extents
        return local @ self.T_owner_box[:3, :3].T + self.T_owner_box[:3, 3]


@dataclass(frozen=True)
class Shape:
    """Geometry of a primitive or link, in its owner's frame.

    Attributes
    ----------
    kind : {"box", "cylinder", "sphere", "mesh"}
    T_owner_shape : ndarray, shape (4, 4)
        Pose of the shape's own frame in the owner's frame.
    size : ndarray, shape (3,)
        Box edge lengths; cylinder (2r, 2r, length); sphere (2r, 2r, 2r) [m].
    mesh_file : Path or None
        Resolved mesh path (mesh shapes).
    mesh_scale : float
        Factor from mesh-file units to metres.
    bounding_box : Box
        The second-level (prismatic) representation, in the owner's frame.
    """

    kind: str
    T_owner_shape: np.ndarray
    size: np.ndarray
    bounding_box: Box
    mesh_file: Path | None = None
    mesh_scale: float = 1.0
    closed: bool = True  # a mesh that is not watertight cannot tell inside from outside


@dataclass(frozen=True)
class JointLimits:
    """Limits of one joint, SI (rad or m based); ``inf`` where not given."""

    lower: float = -np.inf
    upper: float = np.inf
    velocity: float = np.inf
    acceleration: float = np.inf
    effort: float = np.inf


@dataclass(frozen=True)
class Joint:
    """One joint, SI: a DH row, or a joint frame.

    DH devices: revolute ``theta = q + theta``, prismatic ``d = q + d``.  Joint-frame
    devices (``DeviceModel.convention == "frames"``): ``origin`` is the joint frame's pose in
    the previous link's frame at ``q = 0`` and ``axis`` the unit axis in it; the DH numbers
    are 0.
    """

    name: str
    kind: Literal["revolute", "prismatic"]
    a: float
    alpha: float
    d: float
    theta: float
    limits: JointLimits
    origin: np.ndarray | None = None  # (4, 4) T_{i-1}_joint, joint-frame devices only
    axis: np.ndarray | None = None  # (3,) unit, in the joint frame
    # DH rows: a small pose before the row, A_i' = correction @ A_i (a calibrated robot's
    # errors, which a DH row cannot hold: a tilt between parallel axes); None: none
    correction: np.ndarray | None = None
    motor_inertia: float = 0.0  # Jm [kg m^2], motor side
    gear_ratio: float = 1.0  # G
    viscous: float = 0.0  # joint side [N m s/rad or N s/m]
    coulomb_positive: float = 0.0  # joint side [N m or N]
    coulomb_negative: float = 0.0
    # the joint's compliance under load, joint side [rad/(N m) or m/N]: the arm's joint value
    # is the commanded one plus compliance x the torque holding it (a robot calibration's
    # non-geometric error, docs/calibration.md); 0: stiff
    compliance: float = 0.0

    @property
    def armature(self) -> float:
        """Motor inertia reflected to the joint, ``Jm G^2`` [kg m^2]."""
        return self.motor_inertia * self.gear_ratio**2


@dataclass(frozen=True)
class Link:
    name: str
    inertial: Inertial
    shape: Shape | None


@dataclass(frozen=True)
class ControllerProfile:
    """How a robot controller sees a device (``docs/export.md``).

    Attributes
    ----------
    flange : str or None
        Qualified frame on the last link that tool data is given in (None: the last link).
    base : str or None
        Qualified frame fixed to the device base that Cartesian targets are given in (None: the
        device's natural frame).
    sign, offset : ndarray, shape (n,)
        ``axis = sign * q + offset`` per joint (SI) ...
    coupling : ndarray, shape (n, n)
        ... ``+ coupling @ q``: parallel linkages (ABB's and FANUC's J2-J3), zero diagonal.
    vendor : str or None
        abb, fanuc, kuka, kuka_sunrise, ur, yaskawa, staubli, doosan, franka, kinova, denso,
        epson or generic.
    pulses_per_degree, zero_pulse : list or None
        Yaskawa: each axis' encoder pulses per degree and pulse count at zero.
    """

    flange: str | None
    base: str | None
    sign: np.ndarray
    offset: np.ndarray
    coupling: np.ndarray | None = None
    vendor: str | None = None
    pulses_per_degree: list[float] | None = None
    zero_pulse: list[int] | None = None

    def axes(self, q) -> np.ndarray:
        """The controller's axis values of joint values ``q`` (..., n), SI."""
        q = np.asarray(q, dtype=float)
        out = self.sign * q + self.offset
        if self.coupling is not None:
            out = out + q @ self.coupling.T
        return out

    def joints(self, axes) -> np.ndarray:
        """The cell's joint values of the controller's axis values ``axes`` (..., n), SI: the
        inverse of :meth:`axes`."""
        axes = np.asarray(axes, dtype=float)
        M = np.diag(self.sign.astype(float))
        if self.coupling is not None:
            M = M + self.coupling
        return np.linalg.solve(M, (axes - self.offset).T).T

    @property
    def identity(self) -> bool:
        """The axis values are the cell's joint values."""
        coupled = self.coupling is not None and np.any(self.coupling)
        return bool(np.all(self.sign == 1) and not np.any(self.offset) and not coupled)


@dataclass(frozen=True)
class DeviceModel:
    """A serial-chain device.

    Attributes
    ----------
    convention : {"standard", "modified", "frames"}
        DH convention of ``joints``, or ``"frames"`` for joints given by their frames
        (origin and axis, as URDF does).
    joints, links : tuple
        ``n`` each; link *i* is moved by joint *i*, its frame is DH frame *i* (or the
        joint frame of joint *i*, moved by it).
    tcps : tuple of str
        Qualified TCP frame names; the first is the default active one.
    home : ndarray, shape (n,)
        Initial joint values (SI).
    """

    name: str
    convention: Literal["standard", "modified", "frames"]
    joints: tuple[Joint, ...]
    links: tuple[Link, ...]
    tcps: tuple[str, ...]
    home: np.ndarray
    shape: Shape | None = None
    positions: dict = field(default_factory=dict)  # name -> ndarray (n,), SI
    controller: ControllerProfile | None = None  # None: stated defaults (ControllerProfile())
    base_link: str | None = None  # the base's URDF link name, kept from an import

    @property
    def dof(self) -> int:
        return len(self.joints)

    @functools.cached_property  # asked for at every pose of a batch: built once
    def link_frames(self) -> tuple[str, ...]:
        return tuple(f"{self.name}.{link.name}" for link in self.links)

    @functools.cached_property
    def _frame_arrays(self) -> tuple[np.ndarray, ...]:
        """A joint-frame chain as arrays: origins (n, 4, 4), axes (n, 3), the axes' cross
        product matrices and outer products (n, 3, 3) each, prismatic (n,) bool."""
        origin = np.array([np.asarray(j.origin, dtype=float) for j in self.joints]).reshape(
            -1, 4, 4
        )
        axis = np.array([np.asarray(j.axis, dtype=float) for j in self.joints]).reshape(-1, 3)
        zero = np.zeros(len(axis))
        x, y, z = axis.T
        cross = np.stack(
            [np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)],
            axis=1,
        )
        outer = axis[:, :, None] * axis[:, None, :]
        prismatic = np.array([j.kind == "prismatic" for j in self.joints], dtype=bool)
        return origin, axis, cross, outer, prismatic

    def dh_arrays(self) -> dict[str, np.ndarray]:
        """The DH table as arrays of shape (n,): a, alpha, d, theta, prismatic (bool)."""
        return {
            "a": np.array([j.a for j in self.joints]),
            "alpha": np.array([j.alpha for j in self.joints]),
            "d": np.array([j.d for j in self.joints]),
            "theta": np.array([j.theta for j in self.joints]),
            "prismatic": np.array([j.kind == "prismatic" for j in self.joints]),
        }

    def joint_transforms(self, q) -> np.ndarray:
        """Link transforms ``A_i = T_{i-1}_{i}`` for joint values ``q`` (the chain's description as
        matrices).

        Parameters
        ----------
        q : array_like, shape (n,) or (N, n)
            Joint values [rad or m].

        Returns
        -------
        ndarray, shape (n, 4, 4) or (N, n, 4, 4)
            Pose of link frame *i* in frame *i-1*; frame 0 is the device's natural frame.
        """
        from .. import spatial

        q = np.asarray(q, dtype=float)
        if self.convention == "frames":
            # spatial.joint_frame for all joints at once: Rodrigues' terms in its order
            origin, axis, cross, outer, prismatic = self._frame_arrays
            c, s = np.cos(q)[..., None, None], np.sin(q)[..., None, None]
            turn = c * np.eye(3) + s * cross + (1.0 - c) * outer
            motion = np.zeros(q.shape + (4, 4))
            motion[..., 3, 3] = 1.0
            motion[..., :3, :3] = np.where(prismatic[:, None, None], np.eye(3), turn)
            motion[..., :3, 3] = np.where(prismatic[:, None], q[..., None] * axis, 0.0)
            return origin @ motion
        dh = self.dh_arrays()
        prismatic = dh["prismatic"]
        theta = dh["theta"] + np.where(prismatic, 0.0, q)
        d = dh["d"] + np.where(prismatic, q, 0.0)
        a = np.broadcast_to(dh["a"], q.shape)
        alpha = np.broadcast_to(dh["alpha"], q.shape)
        step = spatial.dh_standard if self.convention == "standard" else spatial.dh_modified
        A = step(a, alpha, d, theta)
        if any(j.correction is not None for j in self.joints):
            E = np.stack([np.eye(4) if j.correction is None else j.correction for j in self.joints])
            A = E @ A
        return A

    def joint_frames(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """The chain as joint frames (the URDF form), whatever its convention.

        Joint *i* moves link frame ``L_i`` against ``L_{i-1}`` by
        ``T_{L_{i-1}}_{L_i} = origin_i @ motion(axis_i, q_i)``.  For joint-frame devices and
        modified DH ``L_i`` is link frame *i*.  Standard DH turns first and offsets after
        (``A_i = Rz(q) C_i``, ``C_i = Rz(theta) Tz(d) Tx(a) Rx(alpha)``), so ``L_i`` is DH frame
        *i-1* turned by joint *i*, ``origin_i = C_{i-1}`` and link frame *i* is ``L_i C_i``.

        Returns
        -------
        list of (origin (4, 4), axis (3,), T_L_link (4, 4)), one per joint
        """
        from .. import spatial

        z = np.array([0.0, 0.0, 1.0])
        if self.convention == "frames":
            return [
                (np.asarray(j.origin, dtype=float), np.asarray(j.axis, dtype=float), np.eye(4))
                for j in self.joints
            ]

        def E(j) -> np.ndarray:
            return np.eye(4) if j.correction is None else np.asarray(j.correction, dtype=float)

        if self.convention == "modified":
            return [
                (E(j) @ spatial.dh_modified(j.a, j.alpha, j.d, j.theta), z, np.eye(4))
                for j in self.joints
            ]
        out = []
        previous = np.eye(4)
        for j in self.joints:
            C = spatial.dh_standard(j.a, j.alpha, j.d, j.theta)
            out.append((previous @ E(j), z, C))
            previous = C
        return out

    def limit_array(self, which: str) -> np.ndarray:
        """One limit for all joints, shape (n,): 'lower', 'upper', 'velocity', 'acceleration' or
        'effort'.
        """
        return np.array([getattr(j.limits, which) for j in self.joints], dtype=float)

    def unlimited(self) -> dict[str, list[str]]:
        """Per kind ('position', 'velocity', 'acceleration', 'torque'), the joints the cell gives no
        limit of it.

        Such a joint is unlimited in that kind, alone: every other joint keeps its limit.
        """
        kinds = {
            "position": ("lower", "upper"),
            "velocity": ("velocity",),
            "acceleration": ("acceleration",),
            "torque": ("effort",),
        }
        out = {}
        for kind, fields in kinds.items():
            free = [
                j.name
                for j in self.joints
                if all(not np.isfinite(getattr(j.limits, f)) for f in fields)
            ]
            if free:
                out[kind] = free
        return out

    @property
    def total_mass(self) -> float:
        return float(sum(link.inertial.mass for link in self.links))


@dataclass(frozen=True)
class ObjectModel:
    """A rigid object; ``board``: a calibration board's pattern on its x-y plane."""

    name: str
    inertial: Inertial
    shape: Shape | None
    board: BoardModel | None = None


@dataclass(frozen=True)
class SensorModel:
    """A box sensor; origin at the centre of its base face, sensing along +z.

    Attributes
    ----------
    size : ndarray, shape (3,)
        Edge lengths [m].
    rows, cols : int
        Tactile grid (1 x 1 otherwise).
    slices : int
        Proximity slices along +z (1 otherwise).
    force_curve : ndarray, shape (K, 2) or None
        Overlap volume [m^3] -> force [N].
    ball : float or None
        Touch probes with a ball tip: its radius [m], centred on the sensor frame's origin
        (``size`` is then the ball's bounding cube).
    camera : CameraModel or None
        A camera's intrinsics (from a pose file's ``cameras:``); its box is its housing,
        behind the lens.
    """

    name: str
    type: Literal["touch", "tactile", "proximity", "presence", "force", "camera"]
    size: np.ndarray
    rows: int = 1
    cols: int = 1
    slices: int = 1
    force_curve: np.ndarray | None = None
    ball: float | None = None
    camera: CameraModel | None = None

    @property
    def box(self) -> Box:
        """The sensing box in the sensor's frame (a ball's bounding cube for a ball tip, a
        camera's housing behind its lens)."""
        T = np.eye(4)
        if self.ball is None:
            T[2, 3] = -self.size[2] / 2 if self.type == "camera" else self.size[2] / 2
        return Box(T, self.size / 2)


@dataclass(frozen=True)
class Feature:
    """A feature in its owner's natural frame (SI).

    ``point``: the point, a point on the line or plane, or the circle's centre;
    ``direction``: unit line direction, or unit plane/circle normal; ``radius`` for circles.
    """

    name: str  # qualified: owner.feature
    owner: str
    kind: Literal["point", "line", "plane", "circle"]
    point: np.ndarray
    direction: np.ndarray | None = None
    radius: float | None = None


@dataclass(frozen=True)
class Condition:
    frame: str
    code: str  # C1..C13
    name: str  # readable name
    features: tuple[str, ...]


@dataclass(frozen=True)
class FrameDecl:
    """A declared frame.

    Attributes
    ----------
    name : str
        Qualified name.
    kind : FrameKind
    owner : str
        Owning primitive's name ('world' for free frames and world).
    parent : str or None
        Parent frame for owned frames (aux, TCP, link); ``None`` for natural
        frames, whose parent comes from the affixments.
    """

    name: str
    kind: FrameKind
    owner: str
    parent: str | None


@dataclass(frozen=True)
class AffixmentDecl:
    parent: str
    child: str
    type: Literal["rigid", "non_rigid"]
    kind: str | None = None


@dataclass(frozen=True)
class AllowedContactDecl:
    """Bodies that may touch each other (pairs between different names of ``names``).

    A name is an object, a device (all its bodies) or a link frame ``device.link``.
    """

    names: tuple[str, ...]
    reason: str


@dataclass(frozen=True)
class CellModel:
    """Everything a cell file and its pose files declare, in SI.

    Frozen: its fields are not reassigned after loading, and its dicts are read-only by
    convention (the runtime state - joint values, affixments, poses that move - lives in
    :class:`~rworld_cli.world.tree.World`).

    Attributes
    ----------
    poses : dict
        Frame -> ``T_parent_frame`` (4, 4) for every frame that is not a link frame.
    pose_sources : dict
        Frame -> the pose file that gave its pose.
    calibrated : dict
        Frame -> (the calibrated pose file that moved it, how far [m], how much [rad]): the
        frames an overlay written by ``rworld calibrate`` (one with provenance) gives another
        pose than the files before it.
    """

    name: str
    path: Path
    gravity: np.ndarray
    frames: dict[str, FrameDecl]
    objects: dict[str, ObjectModel]
    sensors: dict[str, SensorModel]
    devices: dict[str, DeviceModel]
    features: dict[str, Feature]
    conditions: list[Condition]
    affixments: list[AffixmentDecl]
    poses: dict[str, np.ndarray]
    pose_files: list[Path] = field(default_factory=list)
    pose_sources: dict[str, Path] = field(default_factory=dict)
    calibrated: dict[str, tuple[Path, float, float]] = field(default_factory=dict)
    description: str | None = None
    allowed_contacts: tuple[AllowedContactDecl, ...] = ()

    def primitive_kind(self, name: str) -> PrimitiveKind | None:
        if name in self.objects:
            return "object"
        if name in self.sensors:
            return "sensor"
        if name in self.devices:
            return "device"
        return None
