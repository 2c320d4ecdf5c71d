"""Calibration tasks: calibrate a cell, simulate measurements, plan measurements."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..calibration.pipeline import CalibrationResult

from ..errors import UserError

# --------------------------------------------------------------------------- calibration


def parse_length(text: str, default_unit: str = "mm") -> float:
    """'0.05mm', '50um', '0.00005m' or a bare number in ``default_unit`` -> metres."""
    from ..units import parse_length as to_metres

    try:
        return to_metres(text, "length", default_unit)
    except ValueError as exc:
        raise UserError(str(exc)) from None


@dataclass
class CalibrationRun:
    result: CalibrationResult
    written: Path | None
    output: Path
    listed: bool  # the output is among the cell's pose files


def _protected_files(cell_file: Path, cell) -> dict[Path, str]:
    """The files calibration never writes, by resolved path, with what each is: the structure,
    the nominal pose files (those not written by 'rworld calibrate'), the meshes, and the
    programs, runs and paths beside the cell."""
    from ..schema.loader import load_pose_file_doc

    out = {cell_file.resolve(): "the cell's structure (cell.yaml)"}
    for path in cell.pose_files:
        try:
            overlay = load_pose_file_doc(path)[1].provenance is not None
        except UserError:
            overlay = False
        if not overlay:
            out[path.resolve()] = "a nominal pose file of the cell"
    shapes = [o.shape for o in cell.objects.values()] + [d.shape for d in cell.devices.values()]
    shapes += [link.shape for d in cell.devices.values() for link in d.links]
    for shape in shapes:
        if shape is not None and shape.mesh_file is not None:
            out[Path(shape.mesh_file).resolve()] = "a mesh of the cell"
    for folder, kind in (("programs", "a program"), ("runs", "a run"), ("paths", "a path")):
        for path in (cell_file.parent / folder).glob("*.y*ml"):
            out[path.resolve()] = f"{kind} file of the cell"
    return out


def calibrate_cell(
    cell_path: str,
    measurement_paths: list[str],
    frames: list[str] | None = None,
    output: str | None = None,
    csv_units: str = "mm",
    dry_run: bool = False,
) -> CalibrationRun:
    """Calibrate a cell's conditioned frames and write the overlay (unless ``dry_run`` or a
    frame is undetermined).
    """
    from ..calibration.pipeline import calibrate
    from ..schema.loader import load_cell, resolve_cell_path
    from ..schema.measurements import load_measurements
    from ..schema.poses import write_overlay

    loaded = load_cell(cell_path)
    cell = loaded.cell
    real, _ = resolve_cell_path(cell_path)
    out = Path(output) if output else real.parent / "calibrated.yaml"
    what = _protected_files(real, cell).get(out.resolve())
    if what is not None:
        raise UserError(
            f"refusing to write calibrated poses to {out}: it is {what}; write an overlay "
            "(default: calibrated.yaml beside cell.yaml)"
        )
    measured = load_measurements(measurement_paths, cell, csv_units)
    result = calibrate(cell, measured, frames)
    written = None
    if not dry_run and not result.undetermined:
        write_overlay(out, result, measured.files)
        written = out
    listed = out.resolve() in {p.resolve() for p in cell.pose_files}
    return CalibrationRun(result, written, out, listed)


def simulate_measurement_file(
    cell_path: str,
    truth_path: str,
    output: str,
    sigma: float,
    seed: int = 0,
    points: int = 10,
    frames: list[str] | None = None,
) -> dict:
    """Synthetic probe points of the conditioned features, taken on a 'true' cell, written as a
    measurement file.
    """
    from ..calibration.pipeline import simulate_measurements
    from ..schema.loader import load_cell
    from ..schema.measurements import today, write_measurements
    from ..units import MIN_POINTS

    nominal = load_cell(cell_path).cell
    truth = load_cell(truth_path).cell
    if set(nominal.features) != set(truth.features):
        raise UserError(f"the truth cell {truth_path} must have the same features as {cell_path}")
    if not (sigma >= 0 and np.isfinite(sigma)):
        raise UserError(f"sigma must be a finite length >= 0, got {sigma}")
    if points < 1:
        raise UserError(f"--points must be at least 1, got {points}")
    conditions = [c for c in nominal.conditions if frames is None or c.frame in frames]
    features = sorted({f for c in conditions for f in c.features})
    if not features:
        raise UserError(
            "no conditioned features to measure: the cell has no frame conditions (for the frames "
            "asked)"
        )
    counts = {f: max(points, MIN_POINTS[nominal.features[f].kind]) for f in features}
    probes = simulate_measurements(nominal, truth, features, counts, sigma, seed)
    write_measurements(
        output,
        probes,
        nominal.name,
        [
            "Synthetic measurements (rworld measure --simulate)",
            f"truth: {truth_path}, sigma: {sigma * 1000:g} mm, seed: {seed}",
        ],
        sigma=sigma if sigma > 0 else 1e-12,
        instrument="simulated",
        date=today(),
    )
    return {"features": features, "points": counts, "written": output}


def plan_cell_measurements(
    cell_path: str, frames: list[str] | None, sigma: float, tolerance: float
):
    """Measuring directives for a cell's conditioned frames (see calibration/plan.py)."""
    from ..calibration.plan import plan_measurements
    from ..errors import did_you_mean
    from ..schema.loader import load_cell

    cell = load_cell(cell_path).cell
    conditioned = {c.frame for c in cell.conditions}
    if not conditioned:
        raise UserError(
            f"{cell_path} has no frame conditions: nothing to measure (add 'conditions' to the "
            "cell)"
        )
    for f in frames or []:
        if f not in conditioned:
            raise UserError(
                f"'{f}' has no frame condition{did_you_mean(f, conditioned)}; conditioned frames: "
                f"{', '.join(sorted(conditioned))}"
            )
    for name, value in (("sigma", sigma), ("tolerance", tolerance)):
        if not (value > 0 and np.isfinite(value)):
            raise UserError(f"{name} must be a positive length, got {value}")
    return cell, plan_measurements(cell, frames, sigma, tolerance)


def write_measurement_template(output: str, cell_name: str, plans) -> None:
    """A measurement file whose points are the planned probe targets (nominal, world): fill in
    the measured values.
    """
    from ..model.measurements import FeatureProbes
    from ..schema.measurements import write_measurements

    features: dict = {}
    for plan in plans:
        for d in plan.directives:
            features.setdefault(d.feature, FeatureProbes(d.points, d.above, d.ordered, d.how))
    write_measurements(
        output,
        features,
        cell_name,
        [
            f"Probe targets for {cell_name} from 'rworld plan-measurements' (nominal, world, mm).",
            "Replace each point by the measured one; keep the order of ordered lines.",
        ],
        digits=3,
    )


def analyze_calibration(kind: str, trials: int, planes: int, seed: int, plot: str | None = None):
    """The report's accuracy or sensitivity comparison (calibration/analysis.py); rows per
    method, and a PNG with ``plot``.
    """
    from ..calibration.analysis import run_analysis

    rows, samples = run_analysis(kind, trials, planes, seed)
    if plot:
        from ..calibration.pictures import write_error_histogram

        write_error_histogram(kind, samples, plot)
    return rows
