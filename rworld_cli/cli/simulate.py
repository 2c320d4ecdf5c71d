"""rworld simulate / rworld check"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from .common import (
    EXIT_CHECK_FAILED,
    FiniteFloat,
    ReportedExit,
    emit_json,
    handle_errors,
    json_option,
    output_option,
    shown_issues,
    with_progress,
)


def _simulate(cell: str, run: str, dt: float | None, show_progress: bool, checks: dict):
    from ..api import simulate_run

    return with_progress(
        show_progress,
        lambda progress: simulate_run(cell, run, dt, progress, **checks),
        "simulating",
    )


def collision_options(fn):
    """--clearance, --collision-tolerance, --no-collisions (docs/collision.md)."""
    fn = click.option(
        "--no-collisions",
        "no_collisions",
        is_flag=True,
        help="Skip the collision, clearance and handling checks (limits only).",
    )(fn)
    fn = click.option(
        "--collision-tolerance",
        default=None,
        metavar="LENGTH",
        help="Contacts shallower than this may be missed between clock samples; deeper ones "
        "never are (default: the run file's, else 1mm).",
    )(fn)
    fn = click.option(
        "--clearance",
        default=None,
        metavar="LENGTH",
        help="Required distance between bodies that may not touch, e.g. 10mm; closer is a "
        "violation (default: the run file's, else contact only).",
    )(fn)
    return fn


def _checks(clearance, collision_tolerance, no_collisions) -> dict:
    return {
        "clearance": clearance,
        "collision_tolerance": collision_tolerance,
        "collisions": not no_collisions,
    }


@click.command()
@click.argument("cell", metavar="CELL")
@click.argument("run", metavar="RUN")
@output_option("Write timelines (CSV), events.json, summary.json here.", folder=True)
@click.option(
    "--dt",
    type=FiniteFloat(1e-4, 1.0),
    default=None,
    help="Clock step [s] (default: the run file's).",
)
@click.option(
    "--plot",
    is_flag=True,
    help="Also write PNG plots of joint positions and limit ratios (needs -o).",
)
@click.option(
    "--glb",
    "glb_path",
    default=None,
    type=click.Path(dir_okay=False),
    help="Write the run as an animated glTF binary (.glb) for any glTF viewer.",
)
@click.option(
    "--view",
    "view_path",
    default=None,
    type=click.Path(dir_okay=False),
    help="Write a self-contained HTML page that plays the run (works offline).",
)
@collision_options
@json_option
@handle_errors
def simulate(
    cell,
    run,
    output,
    dt,
    plot,
    glb_path,
    view_path,
    clearance,
    collision_tolerance,
    no_collisions,
    json_output,
):
    """Run the programs of RUN on CELL: several devices on one clock.

    RUN is a run file (or the name of CELL/runs/RUN.yaml) listing the
    programs that run together.  Prints cycle times, peak ratios of
    velocity, acceleration and torque to their limits, the events
    (grasps, releases, tool changes, syncs), any limit violations, and
    collisions and clearance violations with the steps that caused them.
    With -o it also writes collisions.json and a clearance column in the
    timelines, and the run's animated scene (run.glb, view.json) for
    'rworld view DIR'.

    --glb writes the run as an animated glTF file; --view writes one HTML
    page that plays it beside a timeline with the events, joint plots and
    each device's program line (docs/viewer.md).

    \b
    Examples:
      rworld simulate workcells/puma560 pick_place
      rworld simulate workcells/paper_fig9 transfer -o out/fig9 --plot
      rworld simulate workcells/paper_fig9 transfer --view fig9.html
      rworld simulate workcells/paper_fig9 transfer --glb fig9.glb
      rworld simulate workcells/paper_fig9 transfer --clearance 5mm
      rworld simulate workcells/paper_fig9 transfer --json | jq .cycle_time
    """
    from ..api import run_summary, write_run_outputs

    if plot and not output:
        raise click.UsageError("--plot writes PNG files: give the directory with -o DIR")
    # the 50 mm distances at every sample are -o's (the timelines' clearance column,
    # collisions.json's nearest pairs per step): without it only what decides is measured
    checks = {**_checks(clearance, collision_tolerance, no_collisions), "report": bool(output)}
    loaded, result = _simulate(cell, run, dt, not json_output and sys.stderr.isatty(), checks)
    written = write_run_outputs(result, output, plot) if output else []
    if output or glb_path or view_path:
        written += _write_view(loaded, result, output, glb_path, view_path, not json_output)
    once: dict = {}  # --glb into the -o folder: its run.glb once, named as given
    for p in written:
        once.setdefault(Path(p).resolve(), p)
    written = list(once.values())
    if json_output:
        payload = run_summary(result)
        payload["written"] = [str(p) for p in written]
        payload["warnings"] = [w.as_dict() for w in loaded.warnings]
        emit_json(payload)
        return
    for w in shown_issues(loaded.warnings):
        click.echo(w.format(), err=True)
    _render(result)
    for p in written:
        click.echo(f"wrote {p}")


def _write_view(loaded, result, directory, glb_path, view_path, show_progress) -> list:
    from ..api import run_view, write_run_view

    glb, info = with_progress(
        show_progress and sys.stderr.isatty(),
        lambda progress: run_view(loaded, result, progress),
        "scene",
    )
    return write_run_view(glb, info, glb_path, view_path, directory)


@click.command()
@click.argument("directory", metavar="RUN_OUTPUT_DIR", type=click.Path(file_okay=False))
@output_option("The HTML file to write (default RUN_OUTPUT_DIR/view.html).")
@json_option
@handle_errors
def view(directory, output, json_output):
    """Write a self-contained HTML page that plays the run in RUN_OUTPUT_DIR (the -o DIR of
    'rworld simulate'): play, pause, speed, a timeline with the events (click one to jump
    there), joint plots, orbit / pan / zoom, labels, each device's current program line.

    It reads run.glb and view.json from the directory; one missing or damaged is an error
    (exit 2) and nothing is written.  The page needs no network: open it from disk.

    \b
    Examples:
      rworld simulate workcells/paper_fig9 transfer -o out/fig9
      rworld view out/fig9                  # writes out/fig9/view.html
      rworld view out/fig9 -o fig9.html
    """
    from ..api import view_run_directory

    path = view_run_directory(directory, output)
    if json_output:
        emit_json({"directory": directory, "written": [str(path)]})
    else:
        click.echo(f"wrote {path}")


@click.command()
@click.argument("targets", nargs=-1, metavar="CELL [RUN] | CELL... --all-runs")
@click.option(
    "--dt",
    type=FiniteFloat(1e-4, 1.0),
    default=None,
    help="Clock step [s] (default: the run file's).",
)
@collision_options
@click.option(
    "--all-runs",
    is_flag=True,
    help="Check every run (runs/*.yaml) of every CELL given: a fleet of cells in one command.",
)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Local processes for a fleet (default: the cores; 1: one after the other here).",
)
@click.option(
    "--scheduler",
    default=None,
    metavar="tcp://HOST:PORT",
    help="Check on a Dask distributed cluster instead (needs 'pip install rworld[cluster]').",
)
@click.option(
    "--junit",
    "junit_path",
    default=None,
    type=click.Path(dir_okay=False),
    help="Also write JUnit XML: a testcase per run, failures with file:line.",
)
@click.option(
    "--format",
    "output_format",
    type=click.Choice(["text", "github"]),
    default="text",
    show_default=True,
    help="github: GitHub Actions annotations (::error file=...,line=...::), one per problem.",
)
@json_option
@handle_errors
def check(
    targets,
    dt,
    clearance,
    collision_tolerance,
    no_collisions,
    all_runs,
    workers,
    scheduler,
    junit_path,
    output_format,
    json_output,
):
    """For CI: exit 0 when every program of RUN runs within all limits and without collisions
    (or clearance violations), 1 with them otherwise.  RUN is a run file, a run's name
    (CELL/runs/RUN.yaml) or, when there is no such run, a program's (CELL/programs/RUN.yaml,
    run alone).

    Each collision names the pair, its time span, its depth and contact point, and the device,
    step and program line that were running.  No contact deeper than the collision tolerance
    is missed between clock samples (docs/collision.md).  A target no joint solution reaches
    fails the check too (exit 1, naming the step); bad input (files, names) exits 2 as
    everywhere.

    A fleet: --all-runs checks every run of every CELL given, on local processes (--workers)
    or a Dask cluster (--scheduler), in the order given whatever finishes first.  A bad cell is
    named and the others are still checked; exit 2 if any input is bad, else 1 if any run
    failed.  --json prints {"results": [...], "failed": N}; --junit FILE and --format github
    report to CI systems (also for one CELL RUN).

    \b
    Examples:
      rworld check workcells/paper_fig9 transfer
      rworld check workcells/puma560 pick_place --clearance 5mm --json
      rworld check workcells/puma560 through_table   # a deliberately wrong program: exit 1
      rworld check workcells/*/ --all-runs --junit report.xml
      rworld check workcells/*/ --all-runs --format github --workers 4
      rworld check cells/*/ --all-runs --scheduler tcp://10.0.0.5:8786 --json
    """
    fleet = all_runs or workers or scheduler or junit_path or output_format != "text"
    if all_runs and not targets:
        raise click.UsageError("--all-runs checks the runs of the CELLs given: name at least one")
    if not all_runs and len(targets) != 2:
        raise click.UsageError(
            "give CELL RUN (one run), or CELL... --all-runs (every run of each cell)"
        )
    checks = _checks(clearance, collision_tolerance, no_collisions)
    if fleet:
        _check_fleet(
            list(targets) if all_runs else [targets[0]],
            None if all_runs else targets[1],
            dt,
            checks,
            workers,
            scheduler,
            junit_path,
            output_format,
            json_output,
        )
        return
    cell, run = targets
    from ..api import run_summary, unlimited_notes

    # a check prints no distances: only what decides it is measured
    _, result = _simulate(cell, run, dt, False, {**checks, "report": False})
    if json_output:
        summary = run_summary(result)
        emit_json(
            {
                k: summary[k]
                for k in (
                    "cell",
                    "run",
                    "ok",
                    "cycle_time",
                    "violations",
                    "collisions",
                    "unlimited",
                )
            }
        )
        if not result.ok:
            sys.exit(EXIT_CHECK_FAILED)
        return
    from ..api import collision_notes

    for line in unlimited_notes(result) + collision_notes(result):
        click.echo(f"note: {line}", err=True)
    for e in result.events:  # what the steps found questionable, where they are
        if e.kind == "warning":
            where = result.step_where.get(e.device, [])
            at = where[e.step] if e.step is not None and e.step < len(where) else e.device
            click.echo(f"{at}: warning: {e.detail}", err=True)
    report = result.collisions
    if result.ok:
        free = (
            ", no collisions"
            + (
                f", {1000 * report.required_clearance:g} mm clearance kept"
                if report.required_clearance
                else ""
            )
            if report is not None
            else " (collisions not checked)"
        )
        click.echo(
            f"ok: {result.run}: {len(result.devices)} device(s) within all limits{free}, cycle "
            f"time {result.cycle_time:.3f} s"
        )
    else:
        for v in result.violations:
            click.echo(f"violation: {v.describe()}", err=True)
        contacts = report.contacts if report is not None else []
        for c in contacts:
            click.echo(c.describe(), err=True)
        for h in report.handling if report is not None else []:
            click.echo(h.describe(), err=True)
        parts = [f"{len(result.violations)} limit violation(s)"]
        if report is not None:
            parts += [
                f"{len(report.collisions)} collision(s)",
                f"{len(report.clearance_violations)} clearance violation(s)",
            ]
            if report.handling:
                parts.append(f"{len(report.handling)} impossible grasp(s) or placement(s)")
        click.echo(f"failed: {result.run}: {', '.join(parts)}", err=True)
    if not result.ok:
        sys.exit(EXIT_CHECK_FAILED)


def _check_fleet(
    cells, run, dt, checks, workers, scheduler, junit_path, output_format, json_output
) -> None:
    """The fleet form of ``check``: every run on the executor, then the reports."""
    from ..api import check_fleet, github_annotations, write_junit

    if dt is not None:
        raise click.UsageError("--dt applies to one run; a fleet uses each run file's clock")
    fleet = with_progress(
        not json_output and output_format == "text" and sys.stderr.isatty(),
        lambda progress: check_fleet(cells, run, workers, scheduler, progress=progress, **checks),
        "checking",
    )
    if junit_path:
        write_junit(fleet, junit_path)
    if json_output:
        emit_json(fleet.as_dict())
    elif output_format == "github":
        for line in github_annotations(fleet):
            click.echo(line)
    else:
        for r in fleet.results:
            name = f"{r.cell} {r.run}".strip()
            if r.status == "ok":
                click.echo(f"ok      {name}: cycle time {r.cycle_time:.3f} s")
                continue
            if r.status == "skipped":
                click.echo(f"skipped {name}: no runs/*.yaml in the cell")
                continue
            click.echo(f"{'FAILED' if r.status == 'failed' else 'ERROR '}  {name}")
            for p in r.problems[:5]:
                where = f"{p.file}:{p.line}: " if p.file and p.line else ""
                click.echo(f"        {where}{p.message}")
            if len(r.problems) > 5:
                click.echo(f"        ... {len(r.problems) - 5} more (--json lists them)")
        ok = sum(r.status == "ok" for r in fleet.results)
        click.echo(
            f"{len(fleet.results)} run(s) on {fleet.executor}: {ok} ok, {fleet.failed} failed, "
            f"{fleet.bad_input} with bad input"
        )
    if junit_path and not json_output and output_format == "text":
        click.echo(f"wrote {junit_path}")
    if fleet.exit_code:  # the reports stay: they name each failed run and bad cell
        raise ReportedExit(fleet.exit_code)


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
            limited = [(v, i) for i, v in enumerate(values) if v == v]  # NaN: no limit
            if not limited:
                return "n/a (no limits)"
            worst, j = max(limited)
            j += 1
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
    report = result.collisions
    if report is not None:
        from ..api import collision_notes

        console.print()
        for line in collision_notes(result):
            console.print(f"[yellow]note[/]: {line}", markup=True)
        for c in [*report.contacts, *report.handling]:
            kind, text = c.describe().split(": ", 1)
            console.print(f"[red]{kind}[/]: {text}", markup=True, soft_wrap=True)
        if not report.contacts:
            clear = (
                f", {1000 * report.required_clearance:g} mm clearance kept"
                if report.required_clearance
                else ""
            )
            console.print(
                f"no collisions deeper than {1000 * report.tolerance:g} mm{clear} "
                f"({report.queries} exact pair queries, {report.refinements} states between "
                "samples)"
            )
