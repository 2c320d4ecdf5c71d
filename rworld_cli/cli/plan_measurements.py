"""rworld plan-measurements"""

from __future__ import annotations

import sys

import click

from ..units import ARCSEC
from .common import (
    EXIT_CHECK_FAILED,
    device_option,
    emit_json,
    frames_option,
    handle_errors,
    json_option,
    output_option,
    with_progress,
)


def _plan_dict(plan) -> dict:
    import numpy as np

    return {
        "frame": plan.frame,
        "condition": plan.code,
        "determined": plan.determined,
        "reason": plan.reason,
        "predicted_sigma_mm": plan.sigma_translation * 1000
        if np.isfinite(plan.sigma_translation)
        else None,
        "predicted_sigma_arcsec": plan.sigma_rotation / ARCSEC
        if np.isfinite(plan.sigma_rotation)
        else None,
        "condition_number": plan.condition if np.isfinite(plan.condition) else None,
        "uniform_sigma_mm": plan.uniform_sigma_translation * 1000
        if np.isfinite(plan.uniform_sigma_translation)
        else None,
        "uniform_sigma_arcsec": plan.uniform_sigma_rotation / ARCSEC
        if np.isfinite(plan.uniform_sigma_rotation)
        else None,
        "refused": plan.dropped,
        "warnings": plan.warnings,
        "directives": [
            {
                "feature": d.feature,
                "kind": d.kind,
                "how": d.how,
                "points_mm": (d.points * 1000).tolist(),  # ball centres at contact
                "contacts_mm": (d.contacts * 1000).tolist(),  # the surface points touched
                "normals": d.normals.tolist(),  # outward: the ball comes in along -normal
                "offset_mm": (d.offset * 1000).tolist() if d.offset is not None else None,
                "depth_mm": d.candidates.depth * 1000 if d.candidates.depth is not None else None,
                "above_mm": (d.above * 1000).tolist() if d.above is not None else None,
                "ordered": d.ordered,
            }
            for d in plan.directives
        ],
    }


@click.command("plan-measurements")
@click.argument("cell", metavar="CELL")
@frames_option
@click.option(
    "--sigma",
    default="0.05mm",
    show_default=True,
    help="Probing noise, 1 sigma (mm, um or m; a bare number is mm).",
)
@click.option(
    "--tolerance", default="0.1mm", show_default=True, help="Wanted pose accuracy at 2 sigma."
)
@click.option(
    "--program",
    default=None,
    type=click.Path(dir_okay=False),
    help="Write a probe program for the robot (checked in simulation first).",
)
@device_option("The device that probes (default: the one with a ball-tip probe).")
@click.option(
    "--tcp", default=None, help="The probe's TCP (default: the frame the probe sensor is on)."
)
@click.option(
    "--sensor", default=None, help="The ball-tip touch sensor (default: the device's only one)."
)
@click.option(
    "--start",
    default=None,
    help="Named position the program starts and ends at (default: 'ready', else 'home').",
)
@click.option(
    "--probe-radius",
    default=None,
    help="Ball radius for targets without a program (default: the probe sensor's, else 0).",
)
@click.option(
    "--margin",
    default=None,
    help="Least distance of a target from a face's edges and holes (default: ball radius + 1mm).",
)
@click.option(
    "--depth",
    "depths",
    multiple=True,
    metavar="[FEATURE=]LENGTH",
    help="Probing depth below a circle's rim (repeatable; default: the middle of the wall).",
)
@click.option(
    "--clearance",
    default="0mm",
    show_default=True,
    help="Required distance of the robot from what it may not touch.",
)
@output_option("Write the probe targets as a measurement-file template.")
@json_option
@handle_errors
def plan_measurements(
    cell,
    frames,
    sigma,
    tolerance,
    program,
    device,
    tcp,
    sensor,
    start,
    probe_radius,
    margin,
    depths,
    clearance,
    output,
    json_output,
):
    """Measuring directives for CELL's frame conditions: which features, how many points, where, in
    what order - and, with --program, a probe program for the robot.

    Targets lie on material: on each feature's face, hole wall or beside its edge, in the owner's
    geometry, at least the margin from edges and holes.  Natural frames (C1, C2) take theirs by
    greedy D-optimal choice (the most information about the pose); their number is the smallest
    that brings the predicted pose error (the Cramer-Rao bound for the probe noise) within the
    tolerance.  Holes are probed on their wall below the rim, edges by a ball coming in between
    their two faces; the template (-o) gives ball centres, offsets and depths.

    With --program, every target's approach, contact and guarded end are solved by IK within the
    joint limits and checked collision-free (a target that fails is replaced, the reasons listed);
    the stops are ordered by nearest neighbour and 2-opt; the program (approach, a guarded move
    until the probe touches, 'probe: feature', retract) is simulated with the collision check and
    written only if it passes.

    \b
    Examples:
      rworld plan-measurements workcells/calibration_example
      rworld plan-measurements workcells/calibration_example --sigma 0.02mm -o targets.yaml
      rworld plan-measurements workcells/probing --program workcells/probing/programs/probe.yaml
      rworld plan-measurements workcells/probing --depth plate.hole1=4mm --json

    Exit codes: 0 every frame can be determined (and the program passes), 1 a frame cannot be
    determined or probed, or the program fails its check (nothing written), 2 bad input.
    """
    from ..api import parse_length, plan_cell_measurements, write_measurement_template

    parsed_depths = {}
    for item in depths:
        name, _, value = item.rpartition("=")
        parsed_depths[name or "*"] = parse_length(value)
    result = with_progress(
        program is not None and not json_output and sys.stderr.isatty(),
        lambda progress: plan_cell_measurements(
            cell,
            frames.split(",") if frames else None,
            parse_length(sigma),
            parse_length(tolerance),
            probe_radius=parse_length(probe_radius) if probe_radius is not None else None,
            margin=parse_length(margin) if margin is not None else None,
            depths=parsed_depths,
            device=device,
            tcp=tcp,
            sensor=sensor,
            program=program,
            start=start,
            clearance=parse_length(clearance),
            progress=progress,
        ),
        "planning the probe program",
    )
    plans = result.plans
    if output and all(p.determined for p in plans):
        write_measurement_template(output, result.cell.name, plans, result.radius)
    elif output:
        output = None
    if json_output:
        emit_json(
            {
                "cell": result.cell.name,
                "probe_radius_mm": result.radius * 1000,
                "frames": [_plan_dict(p) for p in plans],
                "written": output,
                "program": str(result.program) if result.program else None,
                "probe": result.probe,
                "stops": result.stops if result.program else None,
                "touches": result.touches if result.program else None,
                "cycle_time_s": result.cycle_time,
            }
        )
    else:
        _render(result, output)
    if not all(p.determined for p in plans):
        sys.exit(EXIT_CHECK_FAILED)


def _render(result, output) -> None:
    from rich.console import Console

    console = Console(highlight=False)
    console.print(f"[bold]{result.cell.name}[/]: measuring directives", markup=True)
    if result.radius:
        console.print(f"for a ball of radius {result.radius * 1000:g} mm")
    for p in result.plans:
        if p.determined:
            sigma = f"predicted sigma {p.sigma_translation * 1000:.4f} mm"
            if p.code in ("C1", "C2"):
                sigma += (
                    f", {p.sigma_rotation / ARCSEC:.1f} arcsec (condition number {p.condition:.3g})"
                )
            console.print(f"\n[bold]{p.frame}[/] ({p.code}): {sigma}")
            if (
                p.code in ("C1", "C2")
                and p.uniform_sigma_translation == p.uniform_sigma_translation
            ):
                console.print(
                    f"  the same numbers of points spread uniformly: "
                    f"{p.uniform_sigma_translation * 1000:.4f} mm, "
                    f"{p.uniform_sigma_rotation / ARCSEC:.1f} arcsec"
                )
        else:
            console.print(
                f"\n[bold]{p.frame}[/] ({p.code}): [red]cannot be determined[/]: {p.reason}"
            )
        for k, d in enumerate(p.directives, start=1):
            console.print(f"  {k}. {d.feature} ({d.kind}): {d.how}", markup=False)
        for w in p.warnings:
            console.print(f"  [yellow]warning[/]: {w}")
        if p.dropped:
            console.print(f"  {len(p.dropped)} target(s) the robot cannot probe, replaced; e.g.:")
            for why in p.dropped[:3]:
                console.print(f"    {why}", markup=False)
    if output:
        console.print(f"\nwrote {output} (probe targets; fill in the measured points)")
    if result.program:
        console.print(
            f"\nwrote {result.program}: {result.touches} touches at {result.stops} stop(s) (a "
            "hole's touches are one stop), cycle time "
            f"{result.cycle_time:.2f} s in simulation (limits and collisions checked)"
        )
