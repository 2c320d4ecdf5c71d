"""Calibration tasks: calibrate a cell, simulate measurements, plan measurements."""

from __future__ import annotations

from dataclasses import dataclass, field
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


def parse_angle(text: str, what: str = "angle") -> float:
    """'0.001deg', '2e-5rad' -> radians (>= 0); the unit is required: rworld never guesses it."""
    import math

    from ..units import ANGLE_WORDS, parse_quantity

    value = parse_quantity(text, ANGLE_WORDS, "")
    if not (value >= 0 and math.isfinite(value)):
        raise UserError(
            f"{what} '{text}' is not an angle of at least 0 with its unit: write e.g. 0.001deg"
        )
    return value


def overlay_output(cell_path: str, cell, output: str | None, default: str, what: str) -> Path:
    """Where an overlay goes: ``output``, or ``default`` beside cell.yaml; never one of the
    cell's own files (UserError naming which)."""
    from ..schema.loader import resolve_cell_path

    real, _ = resolve_cell_path(cell_path)
    out = Path(output) if output else real.parent / default
    mine = _protected_files(real, cell).get(out.resolve())
    if mine is not None:
        raise UserError(
            f"refusing to write {what} to {out}: it is {mine}; write an overlay (default: "
            f"{default} beside cell.yaml)"
        )
    return out


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
    csv_units: str | None = None,
    dry_run: bool = False,
    max_correction: float | str = "50mm",
) -> CalibrationRun:
    """Calibrate a cell's conditioned frames and write the overlay (unless ``dry_run`` or a
    frame is undetermined).

    ``max_correction``: the largest plausible correction (metres, or text with its unit such
    as '50mm'); implausible measurements or corrections raise :class:`UserError`.
    """
    from ..calibration.pipeline import calibrate
    from ..schema.loader import load_cell
    from ..schema.measurements import load_measurements
    from ..schema.poses import write_overlay
    from ..units import LENGTH_WORDS, parse_quantity

    loaded = load_cell(cell_path)
    cell = loaded.cell
    out = overlay_output(cell_path, cell, output, "calibrated.yaml", "calibrated poses")
    measured = load_measurements(measurement_paths, cell, csv_units)
    limit = (
        float(max_correction)
        if isinstance(max_correction, (int, float))
        else parse_quantity(max_correction, LENGTH_WORDS, "")
    )
    if not limit > 0:
        raise UserError(
            f"--max-correction '{max_correction}' is not a length above 0 with its unit, e.g. 50mm"
        )
    result = calibrate(cell, measured, frames, limit)
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


@dataclass
class MeasurementPlan:
    """What ``rworld plan-measurements`` found (see :func:`plan_cell_measurements`).

    Attributes
    ----------
    plans : list of FramePlan
    radius : float
        The probe ball's radius the targets are for [m].
    probe : dict or None
        Device, TCP, sensor and start position of the probe program.
    program : Path or None
        The probe program written (it passed the simulation check).
    stops, cycle_time :
        The program's stops (a hole counts once) and simulated cycle time [s].
    """

    cell: object
    plans: list
    radius: float = 0.0
    probe: dict | None = None
    program: Path | None = None
    stops: int = 0
    touches: int = 0  # the guarded touches (probe: steps) the program makes
    cycle_time: float | None = None
    rig: object = field(default=None, repr=False)  # the ProbeRig with every target solved


def plan_cell_measurements(
    cell_path: str,
    frames: list[str] | None,
    sigma: float,
    tolerance: float,
    *,
    probe_radius: float | None = None,
    margin: float | None = None,
    depths: dict[str, float] | None = None,
    device: str | None = None,
    tcp: str | None = None,
    sensor: str | None = None,
    program: str | None = None,
    start: str | None = None,
    clearance: float = 0.0,
    ordered: bool = True,
    progress=None,
) -> MeasurementPlan:
    """Measuring directives for a cell's conditioned frames (calibration/plan.py) and, with
    ``program``, the probe program for ``device``'s ball-tip probe (calibration/probing.py),
    written only when every frame is determined and the program passes the simulation check
    (limits, collisions, every guarded move touching).

    Parameters
    ----------
    depths : dict, optional
        Circle feature -> probing depth below the rim [m]; the key ``"*"`` for every circle.
    progress : callable(done, total, what), optional
        Called as targets are solved and the program is simulated (the CLI draws a bar).

    Raises
    ------
    UserError
        Bad input (exit 2): unknown names, a probe that does not fit, a depth outside the wall.
    CheckFailed
        The program does not pass the check (exit 1); nothing written.
    """
    from ..calibration.plan import ProbeGeometry, plan_measurements
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
    depths = dict(depths or {})
    circles = [n for n, f in cell.features.items() if f.kind == "circle"]
    for name, value in depths.items():
        if name != "*" and name not in circles:
            raise UserError(
                f"--depth {name}: not a circle feature{did_you_mean(name, circles)}; circles: "
                f"{', '.join(circles) or 'none'}"
            )
        if not (value > 0 and np.isfinite(value)):
            raise UserError(f"--depth {name}: a depth below the rim must be positive, got {value}")
    if not clearance >= 0:
        raise UserError(f"--clearance must be >= 0, got {clearance}")
    rig = None
    if program is not None or device is not None:
        rig = _probe_rig(cell, device, tcp, sensor, start, clearance)
        if probe_radius is not None and abs(probe_radius - rig.radius) > 1e-12:
            raise UserError(
                f"--probe-radius {probe_radius * 1000:g} mm differs from the radius of "
                f"'{rig.sensor}' ({rig.radius * 1000:g} mm) in the cell"
            )
        probe_radius = rig.radius
    if probe_radius is not None and not probe_radius >= 0:
        raise UserError(f"--probe-radius must be >= 0, got {probe_radius}")
    if margin is not None and not margin >= (probe_radius or 0.0):
        raise UserError(
            f"--margin {margin * 1000:g} mm is less than the ball radius "
            f"({(probe_radius or 0) * 1000:g} mm): the ball would hang over an edge"
        )
    geometry = ProbeGeometry(
        probe_radius or 0.0,
        margin,
        {k: v for k, v in depths.items() if k != "*"},
        depths.get("*"),
    )
    feasible = None
    if rig is not None:
        tried = [0]

        def feasible(cand, k, T):
            tried[0] += 1
            if progress is not None:
                progress(tried[0], None, f"probe targets: {tried[0]} solved (IK, collisions)")
            return rig.solve(cand, k, T)

    plans = plan_measurements(cell, frames, sigma, tolerance, geometry, feasible)
    out = MeasurementPlan(cell, plans, geometry.radius, rig=rig)
    if rig is not None:
        out.probe = {"device": rig.device, "tcp": rig.tcp, "sensor": rig.sensor, "start": rig.start}
    if program is None or rig is None or not all(p.determined for p in plans):
        return out
    out.program, out.stops, out.cycle_time, out.touches = _write_probe_program(
        cell_path, rig, plans, Path(program), ordered, progress
    )
    return out


def _probe_rig(cell, device, tcp, sensor, start, clearance):
    from ..calibration.probing import ProbeRig, find_probe
    from ..errors import did_you_mean

    if device is None:  # the one device that carries a ball-tip probe
        from ..world.tree import World

        world = World(cell)
        balls = [s for s, m in cell.sensors.items() if m.type == "touch" and m.ball is not None]
        carriers = [d for d in cell.devices if set(balls) & set(world.subtree(d))]
        if not carriers:
            raise UserError(
                "no device carries a ball-tip touch probe: give a touch sensor 'ball: RADIUS' "
                "and affix it to a device's TCP (docs/calibration.md)"
            )
        if len(carriers) > 1:
            raise UserError(
                f"several devices carry a ball-tip probe ({', '.join(carriers)}): name one "
                "with --device"
            )
        device = carriers[0]
    full_tcp, sensor = find_probe(cell, device, tcp, sensor)
    dev = cell.devices[device]
    if start is None:
        start = "ready" if "ready" in dev.positions else "home"
    elif start != "home" and start not in dev.positions:
        raise UserError(
            f"--start {start}: not a named position of '{device}'"
            f"{did_you_mean(start, list(dev.positions) + ['home'])}; positions: "
            f"{', '.join(list(dev.positions) + ['home'])}"
        )
    return ProbeRig(cell, device, full_tcp, sensor, start=start, clearance=clearance)


def _write_probe_program(
    cell_path: str, rig, plans, out: Path, ordered: bool = True, progress=None
):
    """Write the probe program to ``out`` after it passes the simulation check; (path, stops,
    cycle time, touches)."""
    from ..calibration.probing import probe_program
    from ..errors import CheckFailed
    from ..fileio import atomic_write_text, temporary_path, write_scratch
    from ..schema.programs import load_run, program_text
    from ..simulate.engine import simulate

    if not out.parent.is_dir():
        raise UserError(f"cannot write {out}: no folder {out.parent}")
    doc, stops = probe_program(rig, plans, ordered)
    from .cells import installed_schemas

    schemas = installed_schemas()
    text = program_text(doc, None if schemas is None else str(schemas))
    trial = temporary_path(out, ".yaml")  # beside it: the program names files relative to it
    try:
        write_scratch(trial, text.encode("utf-8"))
        run = load_run(cell_path, str(trial))
        run.clearance = rig.clearance
        try:
            result = simulate(run, progress, report=False)
        except UserError as exc:  # said of the file it would have been: the trial is gone
            kind = CheckFailed if exc.exit_code == 1 else UserError
            raise kind(
                f"cannot plan the probe program: {exc.message.replace(str(trial), str(out))}; "
                f"nothing written to {out}"
            ) from None
        first = _run_problems(result)
        if first:
            # said of the file it would have been: the trial file is gone by now
            first = [line.replace(str(trial), str(out)) for line in first]
            raise CheckFailed(
                f"cannot plan the probe program: the program does not pass the check "
                f"({len(first)} problem(s)); the first: {first[0]}; nothing written to {out}"
            )
        atomic_write_text(out, text)
    finally:
        trial.unlink(missing_ok=True)
    return out, stops, result.cycle_time, doc["touches"]


def _run_problems(result) -> list[str]:
    """A probe run's problems in words, as ``rworld check`` reports them: limit violations,
    collisions, handling errors, guarded moves that touched nothing."""
    untouched = [e for e in result.events if e.kind == "guard" and "did not" in e.detail]
    report = result.collisions
    return (
        [v.describe() for v in result.violations]
        + ([c.describe() for c in report.contacts] if report is not None else [])
        + ([h.describe() for h in report.handling] if report is not None else [])
        + [f"{e.detail} (step {(e.step or 0) + 1})" for e in untouched]
    )


def simulate_probe_measurements(
    cell_path: str,
    truth_path: str,
    program_path: str,
    output: str,
    sigma: float,
    seed: int = 0,
    progress=None,
    joint_sigma: float = 0.0,
    allow_collisions: bool = False,
) -> dict:
    """Run a probe program against a 'true' cell and write the probed points as a measurement
    file (``rworld measure --simulate --program``).

    The program is checked as ``rworld check`` checks it (on the nominal cell): one that
    collides or breaks a limit is refused and nothing written, unless ``allow_collisions``
    (then the problems are the result's first warnings).

    The program runs on the nominal cell (its targets are where the robot believes the parts
    are); the same joint values move the truth cell's device (its own DH rows or joint frames,
    base and TCP), each guarded move's contact is found on the truth cell's parts, and the
    point recorded is what the controller reports: its nominal forward kinematics at the
    contact's joint values (:func:`~rworld_cli.calibration.probe_run.probe_run`), with
    joint-encoder noise ``joint_sigma`` [rad] and Gaussian noise ``sigma`` [m].

    Raises
    ------
    UserError
        Bad input; the truth cell differs in its features or probe.
    CheckFailed
        The program collides or breaks a limit (without ``allow_collisions``); a guarded move
        touches nothing on the truth cell (the part is farther from its nominal place than
        the move's overtravel); nothing written.
    """
    from ..calibration.probe_run import measurement_features, probe_run
    from ..errors import CheckFailed
    from ..schema.loader import load_cell
    from ..schema.measurements import today, write_measurements
    from ..schema.programs import load_run
    from ..simulate.engine import simulate

    if not (sigma >= 0 and np.isfinite(sigma)):
        raise UserError(f"sigma must be a finite length >= 0, got {sigma}")
    run = load_run(cell_path, program_path)
    nominal = run.cell
    truth = load_cell(truth_path).cell
    if set(nominal.features) != set(truth.features) or set(nominal.sensors) != set(truth.sensors):
        raise UserError(
            f"the truth cell {truth_path} must have the same features and sensors as {cell_path}"
        )
    if not (joint_sigma >= 0 and np.isfinite(joint_sigma)):
        raise UserError(f"the joint sigma must be a finite angle >= 0, got {joint_sigma}")
    result = simulate(run, progress, report=False)
    problems = _run_problems(result)
    if problems and not allow_collisions:
        raise CheckFailed(
            f"{program_path} does not pass the check ({len(problems)} problem(s); 'rworld "
            f"check' lists them): the first: {problems[0]}; nothing written (--allow-collisions "
            "writes the measurements anyway)"
        )
    probed = probe_run(result, run, truth, joint_sigma, seed)
    if not probed:
        raise UserError(f"{program_path} has no 'probe:' steps: nothing is measured")
    missing = [p for p in probed if p.true is None]
    if missing:
        lines = [f"{p.feature} at {p.where}" for p in missing]
        raise CheckFailed(
            f"{len(missing)} guarded move(s) touch nothing on the truth cell (the part is farther "
            "from its nominal place than the move's overtravel): " + "; ".join(lines)
        )
    radii = {float(truth.sensors[s].ball or 0.0) for s in truth.sensors if truth.sensors[s].ball}
    radius = radii.pop() if len(radii) == 1 else 0.0
    features = measurement_features(nominal, probed, sigma, seed)
    write_measurements(
        output,
        features,
        nominal.name,
        [
            "Synthetic measurements (rworld measure --simulate --program)",
            f"program: {program_path}, truth: {truth_path}, sigma: {sigma * 1000:g} mm, joint "
            f"sigma: {np.degrees(joint_sigma):g} deg, seed: {seed}",
        ],
        sigma=sigma if sigma > 0 else 1e-12,
        probe_radius=radius,
        instrument="simulated probe program",
        date=today(),
    )
    deviation = max(float(np.linalg.norm(p.true - p.nominal)) for p in probed)
    robot = max(
        float(np.linalg.norm(p.reported - p.true))
        for p in probed
        if p.reported is not None and p.true is not None
    )
    warnings = (
        [
            f"{program_path} does not pass the check ({len(problems)} problem(s)); the first: "
            f"{problems[0]}"
        ]
        if problems
        else []
    )
    off = [p for p in probed if p.off_edge]
    if off:
        warnings.append(
            f"{len(off)} edge probe(s) landed on a face, not on the edge ("
            + ", ".join(f"{p.feature} at {p.where}" for p in off[:3])
            + "): the part lies farther from its nominal place than the ball can bridge (its "
            "radius times the sine of half the faces' angle); use a larger ball, or better "
            "nominal poses first"
        )
    return {
        "warnings": warnings,
        "features": sorted(features),
        "points": {k: len(v.points) for k, v in features.items()},
        "written": output,
        "largest_deviation_mm": deviation * 1000,
        "largest_robot_error_mm": robot * 1000,  # recorded against true contacts
    }


def write_measurement_template(output: str, cell_name: str, plans, radius: float = 0.0) -> None:
    """A measurement file whose points are the planned probe targets (nominal, world): fill in
    the measured values.
    """
    from ..model.measurements import FeatureProbes
    from ..schema.measurements import write_measurements

    features: dict = {}
    for plan in plans:
        for d in plan.directives:
            features.setdefault(
                d.feature,
                FeatureProbes(
                    d.points,
                    d.above,
                    d.ordered,
                    d.how,
                    offset=d.offset,
                    boss=d.candidates.boss,
                    depth=d.candidates.depth,
                ),
            )
    write_measurements(
        output,
        features,
        cell_name,
        [
            f"Probe targets for {cell_name} from 'rworld plan-measurements' (nominal, world, mm).",
            "Replace each point by the measured one (the ball's centre); keep the order of ordered",
            "lines.",
        ],
        probe_radius=radius,
        digits=3,
    )


def analyze_calibration(
    kind: str,
    trials: int,
    planes: int,
    seed: int,
    plot: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress=None,
):
    """The report's accuracy or sensitivity comparison (calibration/analysis.py): (rows per
    method, the executor's description), and a PNG with ``plot``.

    The trials run in blocks (``analysis.BLOCK``) on ``workers`` local processes (default:
    the cores when there is more than one block, else this process) or the Dask cluster at
    ``scheduler``, the executors of fleet checks; every block has its own seed, so the
    result is the same on each.  ``progress(done, total, what)`` as blocks finish.
    """
    from ..calibration.analysis import analysis_block, blocks, summarize
    from .fleet import run_tasks

    sizes = blocks(trials)
    if workers is None and scheduler is None and len(sizes) == 1:
        workers = 1
    parts, executor = run_tasks(
        analysis_block,
        [(kind, n, planes, seed, i) for i, n in enumerate(sizes)],
        workers,
        scheduler,
        progress,
        what="trial blocks",
    )
    rows, samples = summarize(parts)
    if plot:
        from ..calibration.pictures import write_error_histogram

        write_error_histogram(kind, samples, plot)
    return rows, executor
