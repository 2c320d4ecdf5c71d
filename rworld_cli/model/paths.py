"""Joint paths as data: waypoints in SI, their knots, the spline's boundary condition."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PathSpec:
    """A joint-space path: a cubic spline through ``waypoints`` (K, n) [rad or m].

    ``knots`` (K,) on [0, 1] place the waypoints (None: equally spaced); ``boundary`` is
    'clamped' (at rest at both ends), 'natural', 'not-a-knot' or 'segments' (straight
    joint-space segments, at rest at every waypoint).
    """

    waypoints: np.ndarray
    knots: np.ndarray | None
    boundary: str
    device: str | None = None
