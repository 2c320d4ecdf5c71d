"""Sweeps: ``rworld sweep CELL RUN`` - one run checked over a grid of a carried object's mass,
a controller speed override and pose-file variants, on the same executors as fleets
(:mod:`.fleet`: local processes or a Dask cluster), results in grid order.

A point of the grid is the run as ``rworld check`` would check it, with
- the object's mass set (its inertia scaled with it, its centre of mass kept);
- every move's speed fraction times the override and its acceleration fraction times the
  override squared - a controller's speed override: the same paths, every move's time over
  the override (joint moves exactly: their trapezoids scale; linear moves as long as the
  joints' own limits do not slow the line);
- a pose file listed after the cell's own (a calibration overlay, a fixture moved).

Each point reports the check (pass, collisions, limit violations), the cycle time, the peak
torque ratio and the payload capacity: ``plan payload`` on the run's own motion at that point -
the largest point mass each device could carry more at its active TCP through the whole run
with every torque within its limit (exact: torque is affine in the mass; the least over the
devices, and which joint binds when).
"""

from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass, field

from ..errors import UserError


@dataclass
class SweepPoint:
    """One point of the grid and what the check found there."""

    mass: float | None  # [kg] of the swept object (None: as in the cell)
    speed: float  # override, 1 = 100 %
    variant: str | None  # the extra pose file (None: the cell's own)
    ok: bool = False
    error: str | None = None
    cycle_time: float | None = None
    peak_torque_ratio: float | None = None  # the largest |torque| / limit over devices, joints
    # [kg] more at the active TCP, least over the devices (None: no torque limit feels it);
    # negative when the point already overloads a joint
    payload: float | None = None
    payload_binding: str | None = None  # "DEVICE JOINT at T s (upper|lower)"
    collisions: int = 0
    limit_violations: int = 0
    seconds: float = 0.0

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


@dataclass
class SweepResult:
    cell: str
    run: str
    object: str | None
    points: list[SweepPoint] = field(default_factory=list)
    executor: str = ""

    @property
    def exit_code(self) -> int:
        """2 when a point could not be checked (bad input), else 0: a sweep reports, it does
        not gate (failed points are in the table)."""
        return 2 if any(p.error is not None for p in self.points) else 0

    def as_dict(self) -> dict:
        return {
            "cell": self.cell,
            "run": self.run,
            "object": self.object,
            "points": [p.as_dict() for p in self.points],
            "executor": self.executor,
        }


COLUMNS = [
    "mass_kg",
    "speed_override",
    "pose_file",
    "ok",
    "cycle_time_s",
    "peak_torque_ratio",
    "payload_kg",
    "payload_binding",
    "collisions",
    "limit_violations",
]


def sweep_point(
    cell: str,
    run: str,
    obj: str | None,
    mass: float | None,
    speed: float,
    variant: str | None,
    collisions: bool,
) -> SweepPoint:
    """Check one grid point (module docstring); bad input becomes ``error``, never raises."""
    import numpy as np

    from ..model.cell import Inertial
    from ..schema.loader import load_cell
    from ..schema.programs import load_run
    from ..simulate.engine import simulate
    from .simulation import run_path

    started = time.perf_counter()
    point = SweepPoint(mass, speed, variant)
    try:
        files = None
        if variant is not None:
            files = [str(p) for p in load_cell(cell).cell.pose_files] + [variant]
        loaded = load_run(cell, run_path(cell, run), None, files)
        model = loaded.cell
        objects = dict(model.objects)
        if obj is not None and mass is not None:
            if obj not in objects:
                from ..errors import did_you_mean

                raise UserError(f"unknown object '{obj}'{did_you_mean(obj, objects)}")
            old = objects[obj].inertial
            scale = mass / old.mass if old.mass > 0 else 0.0
            inertia = old.inertia * scale if old.mass > 0 else np.zeros((3, 3))
            objects[obj] = dataclasses.replace(
                objects[obj], inertial=Inertial(mass, old.com, inertia)
            )
        loaded.cell = dataclasses.replace(model, objects=objects)
        if speed != 1.0:  # the override: every move's speed and acceleration fractions scaled
            for program in loaded.programs:
                program.steps = [
                    dataclasses.replace(
                        step,
                        spec=step.spec.model_copy(
                            update={
                                "speed": step.spec.speed * speed,
                                "acceleration": step.spec.acceleration * speed**2,
                            }
                        ),
                    )
                    if step.kind == "move"
                    else step
                    for step in program.steps
                ]
        result = simulate(loaded, None, collisions, payload=True)
    except UserError as exc:
        point.error = "\n".join(exc.lines())
        point.seconds = time.perf_counter() - started
        return point
    ratios = [
        r
        for d in result.devices
        for r in result.peak_ratios(d).get("torque", [])
        if r is not None and np.isfinite(r)
    ]
    point.ok = bool(result.ok)
    point.cycle_time = round(float(result.cycle_time), 9)
    point.peak_torque_ratio = round(float(max(ratios)), 9) if ratios else None
    capacities = [
        (c["mass"], f"{d} {c['joint']} at {c['t']:.3f} s ({c['side']})")
        for d in result.devices
        if (c := result.payload_capacity(d)) is not None
    ]
    if capacities:
        least = min(capacities, key=lambda c: c[0])
        point.payload, point.payload_binding = round(float(least[0]), 9), least[1]
    point.limit_violations = len(result.violations)
    point.collisions = len(result.collisions.collisions) if result.collisions is not None else 0
    point.seconds = time.perf_counter() - started
    return point


def sweep_run(
    cell: str,
    run: str,
    obj: str | None = None,
    masses: list[float] | None = None,
    speeds: list[float] | None = None,
    variants: list[str] | None = None,
    collisions: bool = True,
    workers: int | None = None,
    scheduler: str | None = None,
    progress=None,
) -> SweepResult:
    """Check ``run`` at every point of masses x speeds x variants (module docstring), on
    ``workers`` local processes or the Dask cluster at ``scheduler``; points in grid order
    (mass, then speed, then variant), identical on every executor.

    Raises
    ------
    UserError
        A mass without an object (or the reverse), values out of range, a missing pose file.
    """
    from pathlib import Path

    from .fleet import run_tasks

    if (obj is None) != (masses is None):
        raise UserError("--mass takes OBJECT=KG,KG,...: name the object and its masses")
    masses_grid: list[float | None] = list(masses) if masses is not None else [None]
    speeds = list(speeds) if speeds is not None else [1.0]
    if any(not (m is None or m >= 0) for m in masses_grid):
        raise UserError("masses must be 0 or more [kg]")
    if any(not (0 < s <= 1.0) for s in speeds):
        raise UserError("speed overrides must be above 0 and at most 100 %")
    variants_grid: list[str | None] = [None] + [str(v) for v in variants or []]
    for v in variants_grid[1:]:
        if not Path(str(v)).is_file():
            raise UserError(f"{v}: no such pose file")
    grid = [(m, s, v) for m in masses_grid for s in speeds for v in variants_grid]
    points, description = run_tasks(
        sweep_point,
        # absolute paths: a cluster's workers do not share the client's working folder
        [(os.path.abspath(cell), run, obj, m, s, v, collisions) for m, s, v in grid],
        workers,
        scheduler,
        progress,
        "points",
    )
    return SweepResult(cell, run, obj, points, description)


def sweep_rows(result: SweepResult) -> list[list]:
    """The table's rows, as :data:`COLUMNS` (empty cells where not applicable)."""
    return [
        [
            "" if p.mass is None else p.mass,
            p.speed,
            p.variant or "",
            "error" if p.error else ("ok" if p.ok else "failed"),
            "" if p.cycle_time is None else p.cycle_time,
            "" if p.peak_torque_ratio is None else p.peak_torque_ratio,
            "" if p.payload is None else p.payload,
            p.payload_binding or "",
            p.collisions,
            p.limit_violations,
        ]
        for p in result.points
    ]


def write_sweep(result: SweepResult, csv: str | None = None, plot: str | None = None) -> list:
    """Write the table as CSV and the picture (cycle time, peak torque ratio and payload
    capacity against the mass, or the speed, one line per speed or variant; failed points
    marked), atomically."""
    written = []
    if csv:
        from ..schema.tables import write_records_csv

        write_records_csv(csv, COLUMNS, sweep_rows(result))
        written.append(csv)
    if plot:
        from ..simulate.output import sweep_picture

        sweep_picture(result, plot)
        written.append(plot)
    return written
