"""What a sensor reads: one dataclass for every sensor type."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class SensorReading:
    """One sensor's reading.

    Attributes
    ----------
    active : bool
        Touching (touch, tactile), something in range (proximity), present (presence), loaded
        (force).
    objects : list of str
        What it senses.
    cells : ndarray of bool, shape (rows, cols) or (slices,) or None
        Tactile contact map (row 0 at -y) or proximity slices (0 = nearest the sensor).
    value : float or int or None
        Proximity: nearest slice hit, 1-based (0 when nothing is in range); force: N.
    overlap_volume : float or None
        Force sensors: the overlap volume [m^3].
    image : dict or None
        Cameras: ``resolution`` and, per calibration board (``boards``) and point feature
        (``points``): ``pixels`` (each corner's [u, v] in px, None where not seen), ``seen``,
        ``total``, ``behind``, ``outside`` and ``hidden_by`` (body -> count).
    """

    sensor: str
    type: str
    active: bool
    objects: list[str] = field(default_factory=list)
    cells: np.ndarray | None = None
    value: float | int | None = None
    overlap_volume: float | None = None
    saturated: bool = False
    image: dict | None = None

    def as_dict(self) -> dict:
        return {
            "sensor": self.sensor,
            "type": self.type,
            "active": self.active,
            "objects": self.objects,
            "cells": self.cells.astype(int).tolist() if self.cells is not None else None,
            "value": self.value,
            "overlap_volume": self.overlap_volume,
            "saturated": self.saturated,
            **({"image": self.image} if self.image is not None else {}),
        }
