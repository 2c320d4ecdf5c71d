"""Tactile arrays: the pad split into rows x cols cells, a contact map (row 0 at -y)."""

from __future__ import annotations

import numpy as np

from ..readings import SensorReading

CONTACT, FREE = "#", "."


def text_grid(cells: np.ndarray) -> list[str]:
    """A tactile map as text: '#' in contact, '.' free; the top line is the pad's +y edge."""
    return ["".join(CONTACT if c else FREE for c in row) for row in cells[::-1]]


class Tactile:
    name = "tactile"

    def counts(self, sensor) -> tuple[int, int, int]:
        return (sensor.cols, sensor.rows, 1)

    def reading(self, name, sensor, grid, touched, overlap) -> SensorReading:
        return SensorReading(
            name, self.name, bool(grid.any()), touched, grid[:, :, 0].T.copy()
        )  # rows along y

    def cell_grid(self, reading) -> np.ndarray:
        return reading.cells.T[:, :, None]

    def describe(self, reading) -> list[str]:
        what = ", ".join(reading.objects) if reading.objects else "nothing"
        rows, cols = reading.cells.shape
        head = (
            f"{reading.sensor} (tactile {rows}x{cols}): {int(reading.cells.sum())} cell(s) in "
            f"contact with {what}"
        )
        return [head] + ["    " + row for row in text_grid(reading.cells)]

    def panel(self, reading):
        return (
            reading.cells,
            f"{reading.sensor}: {int(reading.cells.sum())} of {reading.cells.size} cells",
            "cols (x)",
            "rows (y)",
        )


TYPE = Tactile()
