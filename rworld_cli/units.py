"""Shared constants and unit factors: each fact written once.

Files are converted to SI at the boundary (``schema/``) with these factors and never again.
"""

from __future__ import annotations

import math

LENGTH = {"m": 1.0, "mm": 1e-3}  # length unit -> metres
ANGLE = {"rad": 1.0, "deg": math.pi / 180.0}  # angle unit -> radians
ARCSEC = math.pi / 648000.0  # one second of arc [rad]

# Probe points a feature of each kind needs at the least (a point: 1; a line: 2; a plane or circle:
# 3).
MIN_POINTS = {"point": 1, "line": 2, "plane": 3, "circle": 3}

SENSING_TOLERANCE = 1e-6  # m: surfaces this close to a sensor cell touch it (docs/sensing.md)
