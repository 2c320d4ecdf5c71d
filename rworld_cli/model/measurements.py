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
    comment: str = ""  # written after the feature's name (e.g. how to probe it)
