"""rworld sweep"""

from __future__ import annotations

import sys

import click

from .common import ReportedExit, emit_json, handle_errors, json_option, with_progress


def _numbers(text: str, what: str, positive: bool) -> list[float]:
    """Finite numbers separated by commas, each at least 0 (above 0 when ``positive``)."""
    import math

    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise click.BadParameter(
            f"{what}: give numbers separated by commas, e.g. 0.5,1,2"
        ) from None
    if not values:
        raise click.BadParameter(f"{what}: give at least one number")
    for value in values:
        if not math.isfinite(value) or value < 0 or (positive and value == 0):
            bound = "above 0" if positive else "of at least 0"
            raise click.BadParameter(f"{what}: {value:g} is not a finite number {bound}")
    return values


@click.command()
@click.argument("cell", metavar="CELL")
@click.argument("run", metavar="RUN")
@click.option(
    "--mass",
    default=None,
    metavar="OBJECT=KG,KG,...",
    help="The masses of an object the run carries (its inertia scales with it).",
)
@click.option(
    "--speed",
    default="100",
    show_default=True,
    metavar="PERCENT,...",
    help="Speed overrides: every move's speed x p and acceleration x p^2 (same paths, slower).",
)
@click.option(
    "--pose-files",
    "variants",
    default=None,
    metavar="FILE,...",
    help="Pose-file variants, each listed after the cell's own (the cell as is: always).",
)
@click.option("--no-collisions", is_flag=True, help="Limits only.")
@click.option("--workers", type=click.IntRange(min=1), default=None, help="Local processes.")
@click.option("--scheduler", default=None, metavar="tcp://HOST:PORT", help="A Dask cluster.")
@click.option("-o", "--output", default=None, type=click.Path(dir_okay=False), help="CSV table.")
@click.option("--plot", default=None, type=click.Path(dir_okay=False), help="PNG picture.")
@json_option
@handle_errors
def sweep(
    cell,
    run,
    mass,
    speed,
    variants,
    no_collisions,
    workers,
    scheduler,
    output,
    plot,
    json_output,
):
    """Check RUN on CELL at every point of a grid: an object's mass x a controller speed
    override x pose-file variants.  Each point is 'rworld check' of the run so changed; the
    table gives whether it passed, its cycle time, its peak torque ratio, its payload capacity
    (the point mass the TCP could carry more through the run, as 'rworld plan payload' finds it
    on the run's motion) and its collisions, in grid order, the same on local processes
    (--workers) or a Dask cluster (--scheduler).

    \b
    Examples:
      rworld sweep workcells/puma560 pick_place --mass workpiece=0.5,1,2,4 --speed 50,100
      rworld sweep workcells/puma560 pick_place --speed 25,50,75,100 -o sweep.csv --plot s.png
      rworld sweep cell run --pose-files calibrated.yaml --scheduler tcp://10.0.0.5:8786 --json

    Exit codes: 0 swept (failed points are in the table), 2 bad input (a point that cannot be
    checked is named; the table is still written).
    """
    from ..api import sweep_rows, sweep_run, write_sweep

    obj, masses = None, None
    if mass is not None:
        if "=" not in mass:
            raise click.BadParameter("give OBJECT=KG,KG,...", param_hint="--mass")
        obj, _, values = mass.partition("=")
        masses = _numbers(values, "--mass", positive=False)
    speeds = [p / 100 for p in _numbers(speed, "--speed", positive=True)]
    files = [v.strip() for v in (variants or "").split(",") if v.strip()] or None
    if variants is not None and files is None:
        raise click.BadParameter("give pose files, e.g. calibrated.yaml", param_hint="--pose-files")
    result = with_progress(
        not json_output and sys.stderr.isatty(),
        lambda progress: sweep_run(
            cell,
            run,
            obj.strip() if obj else None,
            masses,
            speeds,
            files,
            not no_collisions,
            workers,
            scheduler,
            progress,
        ),
        "sweeping",
    )
    written = write_sweep(result, output, plot)
    if json_output:
        emit_json(result.as_dict() | {"written": written})
    else:
        from rich.console import Console
        from rich.table import Table

        table = Table(title=f"{cell}: {run} on {result.executor}", title_justify="left", box=None)
        for column in (
            "mass (kg)",
            "speed",
            "pose file",
            "check",
            "cycle (s)",
            "torque/limit",
            "payload (kg)",
            "collisions",
            "violations",
        ):
            table.add_column(column, justify="right")
        for row in sweep_rows(result):
            m, s, v, status, cycle, torque, payload, _, collisions, violations = row
            table.add_row(
                "" if m == "" else f"{m:g}",
                f"{100 * s:g} %",
                str(v),
                status,
                "" if cycle == "" else f"{cycle:.3f}",
                "" if torque == "" else f"{torque:.3f}",
                "" if payload == "" else f"{payload:.3f}",
                str(collisions),
                str(violations),
            )
        Console(highlight=False).print(table)
        for p in result.points:
            if p.error:
                click.echo(p.error, err=True)
        for path in written:
            click.echo(f"wrote {path}")
    if result.exit_code:
        raise ReportedExit(result.exit_code)
