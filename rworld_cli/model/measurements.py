"""Probe measurements of features, in SI and world coordinates (read from files by
``schema/measurements.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Measurement:
    """One feature's probe points (SI, world)."""

    feature: str
    points: np.ndarray  # (K, 3) ball centres [m]
    above: np.ndarray | None  # a point outside the object (planes, circles) [m]
    ordered: bool  # lines: first -> last along the direction
    probe_radius: float  # [m]
    source: str  # the file it came from
    offset: np.ndarray | None = None  # lines: (3,) ball centres from the edge, owner frame [m]
    boss: bool = False  # circles: probed from outside
    depth: float | None = None  # circles: probed on the wall this far below the rim [m]

    @property
    def probing(self) -> Probing:
        return Probing(self.probe_radius, self.offset, self.boss, self.depth)


@dataclass(frozen=True)
class Probing:
    """How a feature was probed, for compensation (see docs/calibration.md, Probe geometry).

    Attributes
    ----------
    radius : float
        Ball radius [m]: planes are moved back along their outside normal by it, circles'
        radii grow by it (holes) or shrink by it (bosses); a line with an ``offset`` was
        touched at its edge, the ball centres ``radius`` from it.
    offset : ndarray, shape (3,) or None
        Lines touched by a ball: the ball centres' displacement from the edge at contact, in
        the owner's frame [m] (the radius along the approach), for the line's fit.
    boss : bool
        Circles: probed from outside.
    depth : float or None
        Circles probed on their wall, this far below the rim [m]: a wall gives the distance
        from the axis only, not the position along it.
    """

    radius: float = 0.0
    offset: np.ndarray | None = None
    boss: bool = False
    depth: float | None = None


@dataclass
class MeasurementSet:
    measurements: dict[str, Measurement]
    files: list[dict]  # provenance: path, sha256, date, instrument
    sigma: float | None  # known probing noise [m], if the files give it


@dataclass
class FeatureProbes:
    """What a measurement file says of one feature (SI, world): its points, and orientation
    information.
    """

    points: np.ndarray  # (K, 3)
    above: np.ndarray | None = None
    ordered: bool = False
    comment: str = ""
    offset: np.ndarray | None = None  # lines, (3,) owner frame [m], see Probing
    boss: bool = False
    depth: float | None = (
        None  # circles [m], see Probing  # written after the feature's name (e.g. how to probe it)
    )


@dataclass
class RobotObservations:
    """Points an instrument measured on a device frame (SI).

    Attributes
    ----------
    device, target, frame : str
        The device, the measured frame (on one of its links), the frame the points are in.
    q : ndarray, shape (K, n)
        Joint values of each observation [rad or m].
    points : ndarray, shape (K, 3)
        The measured points in ``frame`` [m] (the frame's origin, for full poses).
    sigma : float
        1 sigma per coordinate [m].
    lines : list of str
        ``file:line`` of each observation, for messages.
    """

    device: str
    target: str
    frame: str
    q: np.ndarray
    points: np.ndarray
    sigma: float
    lines: list[str] = field(default_factory=list)
    instrument: str = ""
    rotations: np.ndarray | None = None  # (K, 3, 3): full poses measured (6-DoF), else None
    sigma_angle: float = 0.0  # [rad], 1 sigma per axis of the rotations
    # self-calibration: the robot's ball touched a known surface at each state (``points`` is
    # then unused); see :class:`Surfaces`
    surfaces: Surfaces | None = None


@dataclass
class Surfaces:
    """The known surfaces a ball probe touched, one per observation (world frame, SI).

    ``kind``: 'plane' (point on it, outward normal), 'sphere' (centre, radius), 'line' (point,
    direction: an edge), 'circle' (centre, axis, radius: a hole's wall, touched from inside).
    The ball's centre is then at ``ball`` from the surface.
    """

    kind: list[str]
    point: np.ndarray  # (K, 3)
    direction: np.ndarray  # (K, 3) (unused for spheres)
    radius: np.ndarray  # (K,) sphere or hole radius (0 otherwise)
    ball: float  # the probe ball's radius [m]
    names: list[str] = field(default_factory=list)
    owners: list[str] = field(default_factory=list)  # set: point, direction in their frames

    def placed(self, T_world) -> Surfaces:
        """The surfaces in world, ``T_world(owner)`` giving each owner's pose (4, 4)."""
        if not self.owners:
            return self
        T = np.array([T_world(owner) for owner in self.owners])
        return Surfaces(
            self.kind,
            np.einsum("kij,kj->ki", T[:, :3, :3], self.point) + T[:, :3, 3],
            np.einsum("kij,kj->ki", T[:, :3, :3], self.direction),
            self.radius,
            self.ball,
            self.names,
        )

    def gaps(self, centres: np.ndarray) -> np.ndarray:
        """Distance from each ball centre to where touching puts it (K,) [m]: 0 on contact."""
        v = centres - self.point
        along = np.einsum("ki,ki->k", v, self.direction)
        radial = np.linalg.norm(v - along[:, None] * self.direction, axis=1)
        out = np.empty(len(v))
        for kind, rows in (
            ("plane", along - self.ball),
            ("sphere", np.linalg.norm(v, axis=1) - self.radius - self.ball),
            ("line", radial - self.ball),
            ("circle", radial - (self.radius - self.ball)),
        ):
            mask = np.array([k == kind for k in self.kind])
            out[mask] = rows[mask]
        return out
