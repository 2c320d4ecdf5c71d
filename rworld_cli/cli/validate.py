"""rworld validate FILE..."""

from __future__ import annotations

import sys

import click

from .common import EXIT_BAD_INPUT, emit_json, handle_errors, json_option, shown_issues


@click.command()
@click.argument("files", nargs=-1, required=True, metavar="FILE...")
@click.option(
    "--cell",
    default=None,
    metavar="CELL",
    help="The cell path and measurement files are checked against (path files: default the cell "
    "whose paths/ folder holds them).",
)
@json_option
@handle_errors
def validate(files: tuple[str, ...], cell: str | None, json_output: bool) -> None:
    """Check cell files (with their pose files and meshes), and pose, program, run and path files.

    FILE is a cell.yaml, a cell directory, a pose file, a program or a run
    file (programs and runs are checked against a cell by simulate/check),
    a path file (checked against its cell: waypoints within the joints'
    ranges, and the spline between them too, exactly), or a measurement
    file (with --cell: every feature known, enough points).  Every problem of
    every file is reported at once, one line each, as
    file:line:col: location: message.  Warnings (data that is legal but
    suspicious, e.g. an inertia breaking the triangle inequality) do not fail
    the check.

    \b
    Examples:
      rworld validate workcells/*/cell.yaml
      rworld validate workcells/puma560          # the directory's cell.yaml
      rworld validate workcells/paper_fig9/programs/*.yaml
      rworld validate workcells/puma560/paths/*.yaml  # against workcells/puma560
      rworld validate --cell workcells/calibration_example measurements/calibration_example/*.yaml
      rworld validate --json workcells/paper_fig9 | jq '.files[0].errors'

    Exit codes: 0 all valid, 2 a file is invalid.
    """
    from ..api import validate_files

    reports = validate_files(list(files), cell)
    if json_output:
        emit_json({"valid": all(r.valid for r in reports), "files": [r.as_dict() for r in reports]})
    else:
        for r in reports:
            for issue in sorted(
                r.errors + shown_issues(r.warnings),
                key=lambda i: (i.file != r.file, i.file, i.line, i.column),
            ):
                click.echo(issue.format(), err=True)
            if r.valid:
                click.echo(f"ok: {r.file}: {r.summary}")
            else:
                click.echo(f"invalid: {r.file}: {len(r.errors)} error(s)", err=True)
    if not all(r.valid for r in reports):
        sys.exit(EXIT_BAD_INPUT)
