"""Probe measurements of features, in SI and world coordinates (read from files by
``schema/measurements.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

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
    offset: np.ndarray | None = None  # (3,) ball centres' displacement, owner frame [m]
    boss: bool = False  # circles: probed from outside

    @property
    def probing(self) -> Probing:
        return Probing(self.probe_radius, self.offset, self.boss)


@dataclass(frozen=True)
class Probing:
    """How a feature was probed, for compensation (see docs/calibration.md, Probe geometry).

    Attributes
    ----------
    radius : float
        Ball radius [m]: planes are moved back along their outside normal by it, circles'
        radii grow by it (holes) or shrink by it (bosses).
    offset : ndarray, shape (3,) or None
        The ball centres' further displacement from the feature, in the feature owner's frame
        [m]: a line probed on a face beside its edge, a circle probed below its rim.
    boss : bool
        Circles: probed from outside.
    """

    radius: float = 0.0
    offset: np.ndarray | None = None
    boss: bool = False


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
    offset: np.ndarray | None = None  # (3,) owner frame [m], see Probing
    boss: bool = False  # written after the feature's name (e.g. how to probe it)
