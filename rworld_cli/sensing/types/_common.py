"""What several sensor types share: a single cell that is on or off."""

from __future__ import annotations

import numpy as np

from ..readings import SensorReading


class SingleCell:
    """A sensor whose whole box is one cell: sensing something or not."""

    name = ""
    words = ("sensing", "nothing")

    def counts(self, sensor) -> tuple[int, int, int]:
        return (1, 1, 1)

    def reading(self, name, sensor, grid, touched, overlap) -> SensorReading:
        return SensorReading(name, self.name, bool(grid.any()), touched)

    def cell_grid(self, reading) -> np.ndarray:
        return np.full((1, 1, 1), reading.active)

    def describe(self, reading) -> list[str]:
        what = ", ".join(reading.objects) if reading.objects else "nothing"
        return [
            f"{reading.sensor} ({self.name}): "
            + (f"{self.words[0]} - {what}" if reading.active else self.words[1])
        ]

    def panel(self, reading):
        return None
