"""rworld simulate / rworld check"""

from __future__ import annotations

import sys

import click

from .common import EXIT_CHECK_FAILED, emit_json, handle_errors, json_option


def _simulate(cell: str, run: str, dt: float | None, show_progress: bool):
    from ..api import simulate_run

    if not show_progress:
        return simulate_run(cell, run, dt)
    from rich.progress import Progress

    with Progress(transient=True) as bar:
        task = bar.add_task("simulating", total=None)

        def progress(done, total, what):
            bar.update(task, completed=done, total=total, description=what)

        return simulate_run(cell, run, dt, progress)


@click.command()
@click.argument("cell", metavar="CELL")
@click.argument("run", metavar="RUN")
@click.option(
    "-o",
    "--output",
    default=None,
    type=click.Path(file_okay=False),
    help="Write timelines (CSV), events.json, summary.json here.",
)
@click.option(
    "--dt",
    type=click.FloatRange(1e-4, 1.0),
    default=None,
    help="Clock step [s] (default: the run file's).",
)
@click.option(
    "--plot",
    is_flag=True,
    help="Also write PNG plots of joint positions and limit ratios (needs -o).",
)
@json_option
@handle_errors
def simulate(cell, run, output, dt, plot, json_output):
    """Run the programs of RUN on CELL: several devices on one clock.

    RUN is a run file (or the name of CELL/runs/RUN.yaml) listing the
    programs that run together.  Prints cycle times, peak ratios of
    velocity, acceleration and torque to their limits, the events
    (grasps, releases, tool changes, syncs) and any limit violations.

    \b
    Examples:
      rworld simulate workcells/puma560 pick_place
      rworld simulate workcells/paper_fig9 transfer -o out/fig9 --plot
      rworld simulate workcells/paper_fig9 transfer --json | jq .cycle_time
    """
    from ..api import run_summary, write_run_outputs

    if plot and not output:
        raise click.UsageError("--plot writes PNG files: give the directory with -o DIR")
    loaded, result = _simulate(cell, run, dt, not json_output and sys.stderr.isatty())
    written = write_run_outputs(result, output, plot) if output else []
    if json_output:
        payload = run_summary(result)
        payload["written"] = [str(p) for p in written]
        payload["warnings"] = [w.as_dict() for w in loaded.warnings]
        emit_json(payload)
        return
    for w in loaded.warnings:
        click.echo(w.format(), err=True)
    _render(result)
    for p in written:
        click.echo(f"wrote {p}")


@click.command()
@click.argument("cell", metavar="CELL")
@click.argument("run", metavar="RUN")
@click.option(
    "--dt",
    type=click.FloatRange(1e-4, 1.0),
    default=None,
    help="Clock step [s] (default: the run file's).",
)
@json_option
@handle_errors
def check(cell, run, dt, json_output):
    """For CI: exit 0 when every program of RUN runs within all limits, 1 with the violations
    otherwise.

    Bad input (files, names, unreachable targets) exits 2 as everywhere.

    \b
    Example:
      rworld check workcells/paper_fig9 transfer
    """
    from ..api import run_summary, unlimited_notes

    _, result = _simulate(cell, run, dt, False)
    if json_output:
        summary = run_summary(result)
        emit_json(
            {k: summary[k] for k in ("cell", "run", "ok", "cycle_time", "violations", "unlimited")}
        )
        if not result.ok:
            sys.exit(EXIT_CHECK_FAILED)
        return
    for line in unlimited_notes(result):
        click.echo(f"note: {line}", err=True)
    if result.ok:
        click.echo(
            f"ok: {result.run}: {len(result.devices)} device(s) within all limits, cycle time "
            f"{result.cycle_time:.3f} s"
        )
    else:
        for v in result.violations:
            click.echo(f"violation: {v.describe()}", err=True)
        click.echo(f"failed: {result.run}: {len(result.violations)} limit violation(s)", err=True)
    if not result.ok:
        sys.exit(EXIT_CHECK_FAILED)


def _render(result) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console(highlight=False)
    table = Table(
        title=f"{result.cell}: {result.run}", title_justify="left", box=None, header_style="bold"
    )
    for col, justify in (
        ("device", "left"),
        ("cycle time [s]", "right"),
        ("steps", "right"),
        ("peak |torque|/limit", "right"),
        ("peak |velocity|/limit", "right"),
        ("violations", "right"),
    ):
        table.add_column(col, justify=justify)
    for name, tl in result.devices.items():
        peaks = result.peak_ratios(name)
        n_viol = sum(1 for v in result.violations if v.device == name)

        def fmt(values):
            worst = max(values) if values else 0.0
            j = int(max(range(len(values)), key=lambda i: values[i])) + 1 if values else 0
            style = "red" if worst > 1 else ("yellow" if worst > 0.9 else "")
            text = f"{worst:.2f} (joint {j})"
            return f"[{style}]{text}[/]" if style else text

        table.add_row(
            name,
            f"{tl.cycle_time:.3f}",
            str(len(result.step_texts[name])),
            fmt(peaks["torque"]),
            fmt(peaks["velocity"]),
            f"[red]{n_viol}[/]" if n_viol else "0",
        )
    console.print(table)
    console.print(
        f"total cycle time {result.cycle_time:.3f} s, clock step {result.dt} s, "
        f"{len(result.times)} samples"
    )
    from ..api import unlimited_notes

    for line in unlimited_notes(result):
        console.print(f"[yellow]note[/]: {line}", markup=True)
    console.print()
    events = Table(title="Events", title_justify="left", box=None, header_style="bold")
    for col in ("t [s]", "device", "step", "event"):
        events.add_column(col, justify="right" if col == "t [s]" else "left")
    for e in result.events:
        events.add_row(
            f"{e.t:.3f}",
            e.device,
            str(e.step + 1) if e.step is not None else "",
            f"{e.kind}: {e.detail}",
        )
    console.print(events)
    if result.violations:
        console.print()
        for v in result.violations:
            console.print(f"[red]violation[/]: {v.describe()}", markup=True)
