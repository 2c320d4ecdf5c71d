"""Programs and runs as data: resolved steps per device, the programs that run together on a
cell.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import Issue
from .cell import CellModel


@dataclass
class Step:
    """One resolved program step.

    Attributes
    ----------
    index : int
        0-based position in its program.
    kind : str
        move | grasp | release | place | attach_tool | detach_tool | wait | sync
    spec : object
        The step's parameters, by attribute as in ``docs/simulation.md`` (``to``, ``tcp``,
        ``speed``,
        ``object``, ...); fractions, times [s] and names - lengths and angles are in ``T_offset``.
    where : str
        ``file:line`` of the step, for messages.
    T_offset : ndarray, shape (4, 4)
        Move offsets in SI (identity when none).
    """

    index: int
    kind: str
    spec: Any
    where: str
    T_offset: np.ndarray = field(default_factory=lambda: np.eye(4))

    def describe(self) -> str:
        s = self.spec
        if self.kind == "move":
            return (
                f"move to {s.to}"
                + (" (linear)" if s.motion == "linear" else "")
                + (f" until {s.until}" if s.until else "")
            )
        if self.kind in ("grasp", "release"):
            return f"{self.kind} {s.object}"
        if self.kind == "place":
            return f"place {s.object} on {s.on}"
        if self.kind in ("attach_tool", "detach_tool"):
            return f"{self.kind} {s.tool}"
        if self.kind == "wait":
            return f"wait {s.time} s" if s.time is not None else f"wait for {s.for_}"
        if self.kind == "sense":
            return f"sense {s}"
        return f"sync {s}"


@dataclass
class Program:
    device: str
    file: str
    steps: list[Step]


@dataclass
class Run:
    """A cell and the programs that run together on it."""

    cell: CellModel
    programs: list[Program]
    dt: float
    file: str
    warnings: list[Issue] = field(default_factory=list)
    clearance: float = 0.0  # required distance between bodies that may not touch [m]
    collision_tolerance: float = 1e-3  # contacts shallower may be missed between instants [m]
