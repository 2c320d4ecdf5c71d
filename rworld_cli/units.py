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

# Collision checking (docs/collision.md): contacts shallower than this may be missed between
# two simulated instants; everything deeper is found.
COLLISION_TOLERANCE = 1e-3  # m

_LENGTH_WORDS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "in": 0.0254}


def parse_length(text, what: str = "length") -> float:
    """'10mm', '0.01 m', '1cm' or a bare number of metres -> metres.

    Raises ``ValueError`` with a message naming ``what`` when the text is not a finite length
    of at least 0.
    """
    import re

    m = re.fullmatch(r"\s*([0-9.eE+-]+)\s*([a-z]+)?\s*", str(text))
    value = float("nan")
    if m and (m.group(2) or "m") in _LENGTH_WORDS:
        try:
            value = float(m.group(1)) * _LENGTH_WORDS[m.group(2) or "m"]
        except ValueError:
            pass
    if not (value >= 0 and math.isfinite(value)):
        raise ValueError(
            f"{what} '{text}' is not a length of at least 0: write e.g. 10mm, 0.01m or 0.01 "
            "(metres)"
        )
    return value
