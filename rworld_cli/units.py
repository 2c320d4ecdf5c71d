"""Shared constants and unit factors: each fact written once.

Files are converted to SI at the boundary (``schema/``) with these factors and never again.
"""

from __future__ import annotations

import math

LENGTH = {"m": 1.0, "mm": 1e-3}  # length unit -> metres
ANGLE = {"rad": 1.0, "deg": math.pi / 180.0}  # angle unit -> radians
ARCSEC = math.pi / 648000.0  # one second of arc [rad]

# The most clock samples one run may take, and one straight line's IK track: the work (and the
# memory: 1.1 GB peak at 490 000 samples of a Puma run, 2.2 kB a sample) is bounded before it is
# allocated; a slower speed, a longer wait or a finer clock step beyond it is refused (exit 2),
# naming the number (docs/simulation.md).  300 000 samples: 50 minutes of motion at dt 10 ms.
MAX_SAMPLES = 300_000

# Probe points a feature of each kind needs at the least (a point: 1; a line: 2; a plane or circle:
# 3).
MIN_POINTS = {"point": 1, "line": 2, "plane": 3, "circle": 3}

SENSING_TOLERANCE = 1e-6  # m: surfaces this close to a sensor cell touch it (docs/sensing.md)

# Cartesian limits of a linear move at speed = acceleration = 1 (docs/simulation.md); the
# exporters write a move too short to measure at these, scaled by its step's fractions
LINEAR_SPEED = 0.25  # m/s
LINEAR_ACCELERATION = 1.0  # m/s^2
ANGULAR_SPEED = 1.0  # rad/s
ANGULAR_ACCELERATION = 2.0  # rad/s^2

# Collision checking (docs/collision.md): contacts shallower than this may be missed between
# two simulated instants; everything deeper is found.
COLLISION_TOLERANCE = 1e-3  # m

LENGTH_WORDS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "in": 0.0254}  # -> metres
_UNIT_NAMES = {"m": "metres", "mm": "millimetres"}
TIME_WORDS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}  # -> seconds
ANGLE_WORDS = {"rad": 1.0, "deg": math.pi / 180.0}  # -> radians


def parse_quantity(text, words: dict[str, float], default_unit: str) -> float:
    """'10mm', '8 ms' or a bare number in ``default_unit`` -> SI, by the factors in ``words``;
    NaN when the text is not a number with one of those units.
    """
    import re

    m = re.fullmatch(r"\s*([0-9.eE+-]+)\s*([a-z]+)?\s*", str(text))
    if not m or (m.group(2) or default_unit) not in words:
        return float("nan")
    try:
        return float(m.group(1)) * words[m.group(2) or default_unit]
    except ValueError:
        return float("nan")


def parse_length(text, what: str = "length", default_unit: str = "m") -> float:
    """'10mm', '0.01 m', '1cm' or a bare number in ``default_unit`` -> metres.

    Raises ``ValueError`` with a message naming ``what`` when the text is not a finite length
    of at least 0.
    """
    value = parse_quantity(text, LENGTH_WORDS, default_unit)
    if not (value >= 0 and math.isfinite(value)):
        raise ValueError(
            f"{what} '{text}' is not a length of at least 0: write e.g. 10mm, 0.01m or a bare "
            f"number ({_UNIT_NAMES.get(default_unit, default_unit)})"
        )
    return value


def parse_speed(text, what: str = "speed", default_unit: str = "m") -> float:
    """'20mm/s', '0.02 m/s' or a bare number in ``default_unit`` per second -> m/s (above 0);
    ``ValueError`` naming ``what`` otherwise."""
    body = str(text).strip()
    body = body[:-2] if body.endswith("/s") else body
    value = parse_quantity(body, LENGTH_WORDS, default_unit)
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(
            f"{what} '{text}' is not a positive speed: write e.g. 20mm/s, 0.02m/s or a bare "
            f"number ({_UNIT_NAMES.get(default_unit, default_unit)} per second)"
        )
    return value


def parse_angle_value(text, what: str = "angle", default_unit: str = "rad") -> float:
    """'90deg', '1.57 rad' or a bare number in ``default_unit`` -> radians (finite);
    ``ValueError`` naming ``what`` otherwise."""
    value = parse_quantity(text, ANGLE_WORDS, default_unit)
    if not math.isfinite(value):
        raise ValueError(f"{what} '{text}' is not an angle: write e.g. 90deg, 1.57rad")
    return value


def parse_duration(text, what: str = "duration") -> float:
    """'8ms', '0.004s' or a bare number of seconds -> seconds (above 0); ``ValueError`` naming
    ``what`` otherwise."""
    value = parse_quantity(text, TIME_WORDS, "s")
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(
            f"{what} '{text}' is not a positive duration: write e.g. 8ms, 0.004s or 0.002"
        )
    return value
