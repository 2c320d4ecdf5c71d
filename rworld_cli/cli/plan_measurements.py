"""rworld plan-measurements"""

from __future__ import annotations

import sys

import click

from ..units import ARCSEC
from .common import EXIT_CHECK_FAILED, emit_json, frames_option, handle_errors, json_option


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
        "warnings": plan.warnings,
        "directives": [
            {
                "feature": d.feature,
                "kind": d.kind,
                "how": d.how,
                "points_mm": (d.points * 1000).tolist(),
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
    "-o",
    "--output",
    default=None,
    type=click.Path(dir_okay=False),
    help="Write the probe targets as a measurement-file template.",
)
@json_option
@handle_errors
def plan_measurements(cell, frames, sigma, tolerance, output, json_output):
    """Measuring directives for CELL's frame conditions: which features, how many points, where, in
    what order.

    Points are spread over each feature's face using its owner's geometry;
    their number is the smallest that brings the predicted pose error (the
    Cramer-Rao bound for the probe noise) within the tolerance.  Planes get
    one extra point above the surface and lines are probed first -> last,
    which carries the orientation information C2 needs.

    \b
    Examples:
      rworld plan-measurements workcells/calibration_example
      rworld plan-measurements workcells/calibration_example --sigma 0.02mm --tolerance 0.05mm -o
      targets.yaml

    Exit codes: 0 every frame can be determined, 1 a frame's conditions cannot determine it, 2 bad
    input.
    """
    from ..api import parse_length, plan_cell_measurements, write_measurement_template

    cell_model, plans = plan_cell_measurements(
        cell, frames.split(",") if frames else None, parse_length(sigma), parse_length(tolerance)
    )
    if output:
        write_measurement_template(output, cell_model.name, plans)
    if json_output:
        emit_json(
            {"cell": cell_model.name, "frames": [_plan_dict(p) for p in plans], "written": output}
        )
    else:
        _render(cell_model.name, plans, output)
    if not all(p.determined for p in plans):
        sys.exit(EXIT_CHECK_FAILED)


def _render(name, plans, output) -> None:
    from rich.console import Console

    console = Console(highlight=False)
    console.print(f"[bold]{name}[/]: measuring directives")
    for p in plans:
        if p.determined:
            sigma = f"predicted sigma {p.sigma_translation * 1000:.4f} mm"
            if p.code in ("C1", "C2"):
                sigma += (
                    f", {p.sigma_rotation / ARCSEC:.1f} arcsec (condition number {p.condition:.3g})"
                )
            console.print(f"\n[bold]{p.frame}[/] ({p.code}): {sigma}")
        else:
            console.print(
                f"\n[bold]{p.frame}[/] ({p.code}): [red]cannot be determined[/]: {p.reason}"
            )
        for k, d in enumerate(p.directives, start=1):
            console.print(f"  {k}. {d.feature} ({d.kind}): {d.how}", markup=False)
        for w in p.warnings:
            console.print(f"  [yellow]warning[/]: {w}")
    if output:
        console.print(f"\nwrote {output} (probe targets; fill in the measured points)")
