"""rworld calibrate / rworld measure"""

from __future__ import annotations

import sys

import click

from .common import (
    EXIT_CHECK_FAILED,
    device_option,
    emit_json,
    frames_option,
    handle_errors,
    json_option,
    log_format_option,
    output_option,
    seed_option,
    with_progress,
)


def _solution_dict(sol) -> dict:
    import numpy as np

    dt, dr = sol.correction
    from ..units import ARCSEC as arcsec

    return {
        "frame": sol.frame,
        "condition": sol.code,
        "determined": sol.determined,
        "T_world": sol.T_world.tolist(),
        "correction_mm": dt * 1000,
        "correction_deg": float(np.degrees(dr)),
        "residual_rms_mm": sol.residual_rms * 1000,
        "condition_number": sol.condition,
        "sigma_mm": (sol.sigma_translation * 1000).tolist()
        if sol.sigma_translation is not None
        else None,
        "sigma_arcsec": (sol.sigma_rotation / arcsec).tolist()
        if sol.sigma_rotation is not None
        else None,
        "warnings": sol.warnings,
        "reason": sol.reason,
    }


@click.command()
@click.argument("cell", metavar="CELL")
@click.argument("measurements", nargs=-1, required=True, metavar="MEASUREMENTS...")
@output_option("Overlay pose file to write (default: calibrated.yaml beside cell.yaml).")
@frames_option
@click.option(
    "--csv-units",
    type=click.Choice(["mm", "m"]),
    default=None,
    help="Length unit of CSV point files that do not state it (in the header, x_mm, or a "
    "'# units: mm' line); never assumed.",
)
@click.option(
    "--max-correction",
    default="50mm",
    show_default=True,
    metavar="LENGTH",
    help="The largest plausible correction of a frame, with its unit; farther points or larger "
    "corrections are refused (a unit read wrongly, a wrong cell).",
)
@click.option("--dry-run", is_flag=True, help="Report, write nothing.")
@json_option
@handle_errors
def calibrate(cell, measurements, output, frames, csv_units, max_correction, dry_run, json_output):
    """Calibrate CELL's conditioned frames from probe-point MEASUREMENTS (YAML or CSV).

    Fits every measured feature by total least squares, solves the natural
    frames (C1, C2: the report's closed form, refined by maximum likelihood),
    then the auxiliary frames (C3-C13) in their owners' calibrated frames.
    Writes the calibrated poses as an overlay pose file (atomically; the
    nominal pose file, the cell's structure and its programs are never
    touched) with provenance: date, measurement files and their SHA-256,
    residuals.  List the overlay after the nominal file in the cell's
    pose_files to use it.

    \b
    Examples:
      rworld calibrate workcells/calibration_example measurements/calibration_example/block.yaml
      rworld calibrate workcells/calibration_example points.csv --csv-units mm --dry-run --json

    Implausible input is refused before anything is written: probe points
    far from their nominal features, a correction beyond --max-correction or
    10 deg, residuals above 10 times the instrument's sigma.  The message
    says whether the points fit when read in the other unit.

    Exit codes: 0 calibrated, 1 a requested frame is not determined by the
    measurements (nothing written), 2 bad input (implausible included).
    """
    from ..api import calibrate_cell

    run = calibrate_cell(
        cell,
        list(measurements),
        frames.split(",") if frames else None,
        output,
        csv_units,
        dry_run,
        max_correction,
    )
    res = run.result
    if json_output:
        emit_json(
            {
                "cell": res.cell,
                "written": str(run.written) if run.written else None,
                "frames": [_solution_dict(s) for s in res.solutions.values()],
                "undetermined": res.undetermined,
                "features": {
                    n: {
                        "kind": f.kind,
                        "rms_mm": f.rms * 1000,
                        "points": f.n_points,
                        "outliers": f.outliers,
                        "warnings": f.warnings,
                    }
                    for n, f in res.fits.items()
                },
            }
        )
    else:
        _render(run)
    if res.undetermined:
        sys.exit(EXIT_CHECK_FAILED)


def _render(run) -> None:
    import numpy as np
    from rich.console import Console
    from rich.table import Table

    res = run.result
    console = Console(highlight=False)
    table = Table(
        title=f"{res.cell}: calibrated frames", title_justify="left", box=None, header_style="bold"
    )
    for col in ("frame", "condition", "correction", "residual rms", "predicted sigma", "cond."):
        table.add_column(col, justify="left" if col in ("frame", "condition") else "right")
    from ..units import ARCSEC as arcsec

    for sol in res.solutions.values():
        if not sol.determined:
            continue
        dt, dr = sol.correction
        sigma = (
            ""
            if sol.sigma_translation is None
            else f"{np.linalg.norm(sol.sigma_translation) * 1000:.4f} mm, "
            f'{np.linalg.norm(sol.sigma_rotation) / arcsec:.1f}"'
        )
        table.add_row(
            sol.frame,
            sol.code,
            f"{dt * 1000:.4f} mm, {np.degrees(dr):.4f} deg",
            f"{sol.residual_rms * 1000:.4f} mm",
            sigma,
            f"{sol.condition:.3g}" if sol.code in ("C1", "C2") else "",
        )
    console.print(table)
    for name, fit in res.fits.items():
        for w in fit.warnings:
            console.print(f"[yellow]warning[/]: feature {name}: {w}")
        if fit.outliers:
            console.print(
                f"[yellow]warning[/]: feature {name}: point(s) "
                f"{', '.join(str(i + 1) for i in fit.outliers)} lie beyond 3 rms"
            )
    for sol in res.solutions.values():
        for w in sol.warnings:
            console.print(f"[yellow]warning[/]: {sol.frame}: {w}")
    for name, why in res.undetermined.items():
        console.print(f"[red]not determined[/]: {name}: {why}")
    if run.written:
        console.print(f"wrote {run.written}")
        if not run.listed:
            console.print(
                "to use it, list it after the nominal pose file: pose_files: [poses.yaml, "
                f"{run.written.name}]",
                markup=False,
            )
    elif res.undetermined:
        console.print(
            "nothing written: a requested frame is not determined (restrict with --frames, or "
            "measure more)"
        )


@click.command()
@click.argument("cell", metavar="CELL", required=False)
@click.option(
    "--cell", "cell_option", default=None, metavar="CELL", help="The cell (or give it first)."
)
@click.option(
    "--simulate",
    "simulate_flag",
    is_flag=True,
    help="Synthetic measurements from a 'true' cell (--truth).",
)
@click.option(
    "--from-log",
    "log",
    default=None,
    type=click.Path(dir_okay=False),
    metavar="LOG",
    help="Read the contacts a controller logged running an exported probe program (its log, "
    "the file the program wrote, the .dat or POSREG.VA).",
)
@click.option(
    "--run",
    default=None,
    metavar="RUN|PROGRAM",
    help="--from-log: the run (or program) that was exported.",
)
@log_format_option("--from-log: the log's language (default: the device's controller.vendor's).")
@device_option("--from-log: the probing device.")
@click.option(
    "--frame",
    "user_frame",
    default=None,
    metavar="FRAME",
    help="--from-log: the user frame the program was exported with (export program --frame).",
)
@click.option(
    "--contact-register",
    default=101,
    show_default=True,
    type=click.IntRange(1, 9999),
    help="--from-log --format fanuc: the position register, inform: the position variable of "
    "contact 1.",
)
@click.option(
    "--tolerance",
    default="2mm",
    show_default=True,
    help="--from-log: how far a contact may lie off its search's line.",
)
@click.option(
    "--truth",
    default=None,
    metavar="TRUE_CELL",
    help="--simulate: a cell whose poses are the 'real' ones (same features).",
)
@click.option(
    "--sigma",
    default=None,
    help="Probing noise, 1 sigma (mm, um or m; a bare number is mm): --simulate adds it "
    "(default 0.05mm), --from-log states it in the file.",
)
@seed_option()
@click.option(
    "--points",
    default=10,
    show_default=True,
    type=int,
    help="Points per feature (at least each kind's minimum).",
)
@click.option(
    "--frames",
    default=None,
    metavar="F1,F2,...",
    help="Only the features of these frames' conditions.",
)
@click.option(
    "--program",
    default=None,
    type=click.Path(dir_okay=False),
    help="Run this probe program (from plan-measurements --program) against the truth cell.",
)
@click.option(
    "--joint-sigma",
    default=None,
    metavar="ANGLE",
    help="--program: joint-encoder noise, 1 sigma, with its unit (0.001deg, 2e-5rad).",
)
@click.option(
    "--allow-collisions",
    is_flag=True,
    help="--program: write the measurements of a program that collides or breaks a limit "
    "(said at the top), instead of refusing it.",
)
@output_option("Measurement file to write (YAML).", required=True)
@json_option
@handle_errors
def measure(
    cell,
    cell_option,
    simulate_flag,
    log,
    run,
    fmt,
    device,
    user_frame,
    contact_register,
    tolerance,
    truth,
    sigma,
    seed,
    points,
    frames,
    program,
    joint_sigma,
    allow_collisions,
    output,
    json_output,
):
    """Probe points for 'rworld calibrate': from a robot's controller (--from-log) or
    synthetic (--simulate).

    --from-log: the contacts that an exported probe program ('rworld export
    program') reported on the real controller - UR log lines, RAPID's file,
    KRL's .dat, FANUC's POSREG.VA (docs/export.md: contact reports) - are
    matched with the run's searches (count, step, feature, each contact on
    its search's line), mapped through the controller's base frame, user
    frame and the probe's offset on its TCP into the world, and written as a
    measurement file.  Give the cell with the pose files the program was
    exported with.

    --simulate without --program: probes the features of CELL's frame
    conditions on their material, on TRUE_CELL's poses, with Gaussian noise: an
    external instrument (a CMM, a tracker), so the robot plays no part.  With
    --program: runs the probe program - the controller drives the joint values
    the nominal cell gives, they move TRUE_CELL's robot (its own DH rows or
    joint frames, base and TCP), each guarded move stops where that robot's
    ball first touches the truth cell's parts, and the point recorded is the
    controller's nominal forward kinematics at that instant - and adds the
    noise (--joint-sigma: encoder noise too).

    \b
    Examples:
      rworld measure --from-log robot.log --cell workcells/probing --run probe_features \\
          --format urscript --sigma 0.02mm -o m.yaml
      rworld measure --from-log rworld_probe.log --cell workcells/probing --run probe \\
          --format rapid -o m.yaml
      rworld measure --simulate workcells/calibration_example --truth trial/ --sigma 0.05mm \\
          --seed 1 -o m.yaml
      rworld measure --simulate workcells/probing --truth trial/ --program \\
          workcells/probing/programs/probe.yaml -o m.yaml

    Exit codes: 0 written, 1 a guarded move touches nothing on the truth cell
    (--simulate), 2 bad input (a log that does not match the program: at its line).
    """
    from ..api import (
        measure_from_log,
        parse_angle,
        parse_length,
        simulate_measurement_file,
        simulate_probe_measurements,
    )

    if cell is not None and cell_option is not None and cell != cell_option:
        raise click.UsageError(f"two cells: {cell} and --cell {cell_option}")
    cell = cell or cell_option
    if cell is None:
        raise click.UsageError("give the cell: rworld measure CELL ... (or --cell CELL)")
    if simulate_flag == (log is not None):
        raise click.UsageError("give one of --simulate and --from-log LOG")
    if log is not None:
        wrong = [
            name
            for name, value in (
                ("--truth", truth),
                ("--program", program),
                ("--joint-sigma", joint_sigma),
                ("--frames", frames),
            )
            if value is not None
        ]
        if wrong:
            raise click.UsageError(f"{', '.join(wrong)}: for --simulate, not --from-log")
        if run is None:
            raise click.UsageError("--from-log needs --run: the run or program that was exported")
        info = measure_from_log(
            cell,
            run,
            log,
            output,
            fmt,
            device,
            user_frame,
            parse_length(sigma) if sigma is not None else None,
            contact_register,
            parse_length(tolerance),
        )
        if json_output:
            emit_json(info)
            return
        click.echo(
            f"wrote {output}: {len(info['contacts'])} contact(s) of {info['device']} "
            f"({info['format']}), {len(info['features'])} feature(s)"
        )
        for c in info["contacts"]:
            click.echo(
                f"  {c['contact']:3d} {c['feature']} (step {c['step']}, {c['log']}): "
                f"{c['from_simulated_mm']:.3f} mm from the simulated contact"
            )
        for line in info["notes"]:
            click.echo(f"note: {line}", err=True)
        return
    unused = [
        name
        for name, value in (
            ("--run", run),
            ("--format", fmt),
            ("--device", device),
            ("--frame", user_frame),
        )
        if value is not None
    ]
    if unused:
        raise click.UsageError(f"{', '.join(unused)}: for --from-log, not --simulate")
    if truth is None:
        raise click.UsageError("--simulate needs --truth TRUE_CELL")
    sigma = "0.05mm" if sigma is None else sigma
    if joint_sigma is not None and program is None:
        raise click.UsageError("--joint-sigma is for --program: encoders of the probing robot")
    if allow_collisions and program is None:
        raise click.UsageError("--allow-collisions is for --program: a probe program's run")
    if program is not None:
        encoder = parse_angle(joint_sigma, "--joint-sigma") if joint_sigma is not None else 0.0
        info = with_progress(
            not json_output and sys.stderr.isatty(),
            lambda progress: simulate_probe_measurements(
                cell,
                truth,
                program,
                output,
                parse_length(sigma),
                seed,
                progress,
                encoder,
                allow_collisions,
            ),
            "running the probe program",
        )
    else:
        info = simulate_measurement_file(
            cell,
            truth,
            output,
            parse_length(sigma),
            seed,
            points,
            frames.split(",") if frames else None,
        )
    if json_output:
        emit_json(info)
    else:
        for line in info.get("warnings", []):  # first: a colliding program's is the news
            click.echo(f"warning: {line}", err=True)
        click.echo(
            f"wrote {output}: {len(info['features'])} feature(s), {sum(info['points'].values())} "
            "point(s)"
        )
