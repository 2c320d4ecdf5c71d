"""Sensor types, one module each, behind one small protocol (:class:`SensorType`).

A type says how its box is split into cells, turns the interference of those cells into a
reading, and describes the reading as text and as a picture.  Adding a type: a module here
with a ``TYPE`` object, its entry in :data:`SENSOR_TYPES`, and its keys in the cell schema
(``schema/models.py``, ``schema/loader.py``).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from . import camera, force, presence, proximity, tactile, touch


class SensorType(Protocol):
    name: str

    def counts(self, sensor) -> tuple[int, int, int]:
        """Cells along the sensor box's x, y and z axes."""

    def reading(self, name: str, sensor, grid: np.ndarray, touched: list[str], overlap) -> object:
        """The SensorReading of the cells' interference.

        ``grid``: counts-shaped, bool; ``touched``: what the cells touch; ``overlap()`` gives
        the exact overlap volume with the touched bodies [m^3] (costly: call only if needed).
        """

    def cell_grid(self, reading) -> np.ndarray:
        """The reading back on the cells, counts-shaped (bool): what to colour as sensing."""

    def describe(self, reading) -> list[str]:
        """Lines for a terminal: the reading in words, then any text picture."""

    def panel(self, reading):
        """(cells 2D bool, title, x label, y label) for a picture, or None when the type has no
        map.
        """


SENSOR_TYPES: dict[str, SensorType] = {
    t.TYPE.name: t.TYPE for t in (touch, tactile, proximity, presence, force, camera)
}


def sensor_type(name: str) -> SensorType:
    return SENSOR_TYPES[name]
