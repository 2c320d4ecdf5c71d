"""Cameras: what the image holds of each calibration board and point feature (the reading is
made by ``sensing/camera.py``; ``docs/vision.md``)."""

from __future__ import annotations

import numpy as np

from ._common import SingleCell


class Camera(SingleCell):
    name = "camera"
    words = ("sees", "sees no board or point")

    def describe(self, reading) -> list[str]:
        image = reading.image or {}
        lines = [
            f"{reading.sensor} (camera {image.get('resolution', ['?', '?'])[0]}x"
            f"{image.get('resolution', ['?', '?'])[1]} px):"
        ]
        for kind in ("boards", "points"):
            for name, seen in (image.get(kind) or {}).items():
                why = [f"{n} hidden by {body}" for body, n in seen["hidden_by"].items()]
                if seen["outside"]:
                    why.insert(0, f"{seen['outside']} outside the image")
                if seen["behind"]:
                    why.insert(0, f"{seen['behind']} behind the lens")
                lines.append(
                    f"  {name}: {seen['seen']} of {seen['total']} "
                    + ("corners" if kind == "boards" else "point")
                    + " seen"
                    + (f" ({', '.join(why)})" if why else "")
                )
        if len(lines) == 1:
            lines.append("  no calibration board or point feature in the cell")
        return lines

    def cell_grid(self, reading) -> np.ndarray:
        return np.full((1, 1, 1), reading.active)


TYPE = Camera()
