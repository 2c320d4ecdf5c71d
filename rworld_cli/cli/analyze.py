"""rworld analyze accuracy|sensitivity"""

from __future__ import annotations

import sys

import click

from .common import emit_json, handle_errors, json_option, seed_option, with_progress


@click.command()
@click.argument("kind", type=click.Choice(["accuracy", "sensitivity"]))
@click.option("--trials", default=1000, show_default=True, type=click.IntRange(1, 1_000_000))
@click.option(
    "--planes",
    default=5,
    show_default=True,
    type=click.IntRange(4, 1000),
    help="Random planes per trial.",
)
@seed_option()
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Local processes (default: the cores, or 1 for a single block of 500 trials).",
)
@click.option("--scheduler", default=None, metavar="tcp://HOST:PORT", help="A Dask cluster.")
@click.option(
    "--plot",
    default=None,
    type=click.Path(dir_okay=False),
    help="PNG histogram of the element errors.",
)
@json_option
@handle_errors
def analyze(kind, trials, planes, seed, workers, scheduler, plot, json_output):
    """The report's proposed comparison of computing T with and without orthogonality assured.

    accuracy: random T, random planes, exact data.  sensitivity: every plane
    coefficient off by 0.1 .. 1 %.  For both methods - R orthogonal by SVD
    (eq. 13) and t by least squares, or all 16 elements by plain least
    squares (4.1.3.3) - the relative element errors and ||R^T R - I||.

    \b
    Examples:
      rworld analyze accuracy
      rworld analyze sensitivity --trials 5000 --seed 1 --plot sensitivity.png
      rworld analyze sensitivity --trials 1000000 --scheduler tcp://10.0.0.5:8786

    The trials run in blocks of 500, each with its own seed drawn from --seed, so the
    figures are the same on one process, --workers N or a Dask cluster (--scheduler).
    """
    from ..api import analyze_calibration

    rows, executor = with_progress(
        not json_output and sys.stderr.isatty(),
        lambda progress: analyze_calibration(
            kind, trials, planes, seed, plot, workers, scheduler, progress
        ),
        "analysing",
    )
    if json_output:
        emit_json(
            {
                "kind": kind,
                "trials": trials,
                "planes": planes,
                "seed": seed,
                "executor": executor,
                "methods": [r.__dict__ for r in rows],
                "plot": plot,
            }
        )
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(
        title=f"{kind}: {trials} trials, {planes} planes each, seed {seed}, on {executor}",
        title_justify="left",
        box=None,
        header_style="bold",
    )
    for col in (
        "method",
        "median rel. element error",
        "max rel. element error",
        "median |R^T R - I|",
        "max |R^T R - I|",
    ):
        table.add_column(col, justify="left" if col == "method" else "right")
    for r in rows:
        table.add_row(
            r.method,
            f"{r.median_element_error:.3g}",
            f"{r.max_element_error:.3g}",
            f"{r.median_orthogonality:.3g}",
            f"{r.max_orthogonality:.3g}",
        )
    Console(highlight=False).print(table)
    if plot:
        click.echo(f"wrote {plot}")
