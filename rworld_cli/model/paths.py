"""Joint paths as data: waypoints in SI, their knots, the spline's boundary condition."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_BLEND = 0.5  # a blend's half-width at most this fraction of its shorter knot interval


@dataclass(frozen=True)
class PathSpec:
    """A joint-space path: a cubic spline through ``waypoints`` (K, n) [rad or m].

    ``knots`` (K,) on [0, 1] place the waypoints (None: equally spaced); ``boundary`` is
    'clamped' (at rest at both ends), 'natural', 'not-a-knot', 'segments' (straight
    joint-space segments, at rest at every waypoint) or 'blended' (those segments, corners
    cut by parabolic blends: ``blends`` (K,) each a fraction in [0, 0.5], None: all 0).
    """

    waypoints: np.ndarray
    knots: np.ndarray | None
    boundary: str
    device: str | None = None
    blends: np.ndarray | None = None
