"""Shared fixtures: paths, and running the real CLI in-process."""

from __future__ import annotations

import os
from pathlib import Path

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
