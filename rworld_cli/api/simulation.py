"""Simulation tasks: run a cell's programs together (simulate, check), and write what the run
gives.
"""

from __future__ import annotations

from pathlib import Path


def run_path(cell: str, run: str) -> str:
    """RUN may be a file, or the name of CELL/runs/RUN.yaml."""
    p = Path(run)
    if p.is_file() or p.suffix:
        return run
    base = Path(cell) if Path(cell).is_dir() else Path(cell).parent
    candidate = base / "runs" / f"{run}.yaml"
    return str(candidate) if candidate.is_file() else run


def simulate_run(cell: str, run: str, dt: float | None = None, progress=None):
    """Load RUN's programs on CELL (located errors) and simulate them on one clock.

    Parameters
    ----------
    progress : callable(done, total, what), optional
        Called as the work proceeds.

    Returns
    -------
    (Run, SimulationResult)
    """
    from ..schema.programs import load_run
    from ..simulate.engine import simulate

    loaded = load_run(cell, run_path(cell, run), dt)
    return loaded, simulate(loaded, progress)


def write_run_outputs(result, directory: str, plots: bool = False) -> list[Path]:
    """Timelines (CSV, JSON), events, summary and (``plots``) PNG plots of a run, written
    atomically.
    """
    from ..schema.results import write_results
    from ..simulate.output import output_files, write_plots

    written = write_results(directory, *output_files(result))
    if plots:
        written += write_plots(result, Path(directory))
    return written


def run_summary(result) -> dict:
    """The stable JSON summary of a run (docs/simulation.md)."""
    from ..simulate.output import summary_dict

    return summary_dict(result)


def unlimited_notes(result) -> list[str]:
    """One line per device naming the joints the cell gives no limit of a kind."""
    from ..simulate.output import unlimited_lines

    return unlimited_lines(result.unlimited)
