"""Force sensors: the exact overlap volume of sensor and objects, through the calibration curve
to a force.
"""

from __future__ import annotations

import numpy as np

from ..readings import SensorReading
from ._common import SingleCell


class Force(SingleCell):
    name = "force"

    def reading(self, name, sensor, grid, touched, overlap) -> SensorReading:
        volume = overlap() if touched else 0.0
        curve = sensor.force_curve
        force = float(np.interp(volume, curve[:, 0], curve[:, 1]))
        return SensorReading(
            name, self.name, volume > 0, touched, None, force, volume, bool(volume > curve[-1, 0])
        )

    def describe(self, reading) -> list[str]:
        what = ", ".join(reading.objects) if reading.objects else "nothing"
        line = (
            f"{reading.sensor} (force): {reading.value:.4g} N from "
            f"{reading.overlap_volume * 1e9:.4g} mm^3 of overlap with {what}"
        )
        return [line + (" (beyond the calibration curve: clamped)" if reading.saturated else "")]


TYPE = Force()
