"""Proximity sensors: the range box split into slices along +z; the nearest slice that meets
something.
"""

from __future__ import annotations

import numpy as np

from ..readings import SensorReading


class Proximity:
    name = "proximity"

    def counts(self, sensor) -> tuple[int, int, int]:
        return (1, 1, sensor.slices)

    def reading(self, name, sensor, grid, touched, overlap) -> SensorReading:
        slices = grid[0, 0, :].copy()
        nearest = int(np.argmax(slices)) + 1 if slices.any() else 0
        return SensorReading(name, self.name, bool(slices.any()), touched, slices, nearest)

    def cell_grid(self, reading) -> np.ndarray:
        return reading.cells[None, None, :]

    def describe(self, reading) -> list[str]:
        what = ", ".join(reading.objects) if reading.objects else "nothing"
        found = (
            f"slice {reading.value} of {len(reading.cells)} - {what}"
            if reading.value
            else "nothing in range"
        )
        return [f"{reading.sensor} (proximity): {found}"]

    def panel(self, reading):
        title = (
            f"{reading.sensor}: slice {reading.value} of {len(reading.cells)}"
            if reading.value
            else f"{reading.sensor}: nothing in range"
        )
        return (
            reading.cells[:, None],
            title,
            "",
            "slices (+z, away from the sensor)",
        )  # a column, nearest at the bottom


TYPE = Proximity()
