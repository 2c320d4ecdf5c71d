"""Shared fixtures: paths, running the real CLI in-process, and the example runs simulated once
per test process (the suite runs on every core with pytest-xdist: each worker is one process)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

# One BLAS thread a test process: the suite runs a worker on every core (pytest-xdist), and
# OpenBLAS's own threads on a core another process keeps busy wait for it - a 417 x 417 solve
# (the flange-error fit's normal equations) took 170 ms against 6 ms on one thread here.
# Set before numpy loads OpenBLAS (the workers inherit it); a variable already set is kept.
if "numpy" not in sys.modules:
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pytest
from click.testing import CliRunner

REPO = Path(__file__).resolve().parents[1]
WORKCELLS = REPO / "workcells"
EXAMPLE_CELLS = sorted(p.name for p in WORKCELLS.iterdir() if (p / "cell.yaml").is_file())
REFERENCE = REPO / "tests" / "data" / "reference"  # copied from shared/reference with provenance


def run_cli(args: list[str], cwd: Path | None = None):
    """Run ``rworld ARGS`` in-process; returns click's Result (stdout, stderr, exit_code)."""
    from rworld_cli.cli import main

    old = os.getcwd()
    if cwd is not None:
        os.chdir(cwd)
    try:
        return CliRunner().invoke(main, args, catch_exceptions=False)
    finally:
        os.chdir(old)


@pytest.fixture
def cli():
    return run_cli


@pytest.fixture(params=EXAMPLE_CELLS)
def example_cell(request) -> Path:
    return WORKCELLS / request.param


@pytest.fixture(scope="session")
def example_run():
    """``example_run(cell, run)`` -> ``simulate_run``'s (Run, SimulationResult) for an example
    cell, simulated once per test process and shared: tests read the result, never change it."""
    from rworld_cli.api import simulate_run

    done: dict[tuple[str, str], tuple] = {}

    def get(cell: str, run: str):
        if (cell, run) not in done:
            done[cell, run] = simulate_run(str(WORKCELLS / cell), run)
        return done[cell, run]

    return get


_SIMULATED: dict[str, tuple] = {}  # simulation_once's results, by the inputs' digest


def _inputs_digest(cell: str, run: str, dt, pose_files) -> str:
    """A digest of everything ``api.export._simulate`` reads: every file under the cell's
    folder (contents), the run's file, the period and the pose files."""
    import hashlib

    h = hashlib.blake2b(repr((cell, run, dt, pose_files)).encode(), digest_size=20)
    folder = Path(cell) if Path(cell).is_dir() else Path(cell).parent
    files = sorted(p for p in folder.rglob("*") if p.is_file())
    files += [Path(p) for p in [run, *(pose_files or [])] if Path(p).is_file()]
    for path in files:
        h.update(str(path).encode())
        h.update(path.read_bytes())
    return h.hexdigest()


@pytest.fixture
def simulation_once(monkeypatch):
    """The simulation behind ``export program``, ``measure --from-log`` and ``captures
    --from-log`` (``api.export._simulate``) made once a test process for the same files - the
    real one, keyed by the digest of every file it reads, its result shared read-only (as
    ``example_run``'s). The contact-log tests read the same program back dozens of times."""
    from rworld_cli.api import export

    simulate_now = export._simulate

    def simulate_once(cell: str, run: str, dt, pose_files):
        key = _inputs_digest(cell, run, dt, pose_files)
        if key not in _SIMULATED:
            _SIMULATED[key] = simulate_now(cell, run, dt, pose_files)
        return _SIMULATED[key]

    monkeypatch.setattr(export, "_simulate", simulate_once)


def urdf_without_meshes(source: Path, target: Path) -> Path:
    """A copy of a vendor's URDF without its visual and collision elements (their meshes are
    not vendored): the kinematics and inertials stay as they are."""
    from lxml import etree

    tree = etree.parse(str(source))
    for el in tree.xpath("//visual | //collision"):
        el.getparent().remove(el)
    tree.write(str(target))
    return target
