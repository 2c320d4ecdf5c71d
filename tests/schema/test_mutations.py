"""Any wrong scalar or deleted key in an example gives exit 0 or 2 with located lines.

Every scalar of every example file (cell and poses) is replaced in turn by
a value of the wrong kind, and every key is deleted in turn; the validator
must answer with exit 0 or exit 2 and only ``file:line:col`` lines - never a
traceback, never another exit code.
"""

from __future__ import annotations

import copy
import multiprocessing
import os
import re
import shutil
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pytest
import yaml

from tests.conftest import EXAMPLE_CELLS, WORKCELLS, run_cli

pytestmark = pytest.mark.slow  # the mutation sweeps take half the suite's time; CI runs them

WRONG_VALUES = ["oops", -1, 0, None, [1, 2], {"k": 1}, True, 1e300, ""]
DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)  # libyaml's: a third of the time
LINE = re.compile(r"^\S+?(:\d+:\d+)?: (warning: )?\S+: .+$")


def _paths(data, prefix=()):
    """Every path to a scalar, and every path to a mapping key."""
    scalars, keys = [], []
    if isinstance(data, dict):
        for k, v in data.items():
            keys.append(prefix + (k,))
            s, ks = _paths(v, prefix + (k,))
            scalars += s
            keys += ks
    elif isinstance(data, list):
        for i, v in enumerate(data):
            s, ks = _paths(v, prefix + (i,))
            scalars += s
            keys += ks
    else:
        scalars.append(prefix)
    return scalars, keys


def _set(data, path, value=None, delete=False):
    for part in path[:-1]:
        data = data[part]
    if delete:
        del data[path[-1]]
    else:
        data[path[-1]] = value


def mutants(original):
    """One wrong value per scalar, rotating through the kinds (each kind meets every part of
    the file; two a scalar until 2026-11-29, 35 s of the suite's time), and every key
    deleted.
    """
    scalars, keys = _paths(original)
    n = len(WRONG_VALUES)
    out = [(p, WRONG_VALUES[i % n], False) for i, p in enumerate(scalars)]
    return out + [(p, None, True) for p in keys]


def _check(result):
    assert result.exit_code in (0, 2), (result.exit_code, result.output)
    assert "Traceback" not in result.output
    lines = [l for l in result.stderr.splitlines() if not l.startswith("invalid: ")]
    for line in lines:
        assert LINE.match(line), line
    if result.exit_code == 2:
        assert lines


def sweep(cell_name: str, file_name: str, cases: list, work: Path) -> int:
    """Validate each mutant of ``file_name`` in a copy of the cell at ``work``; the number
    refused (exit 2).  Every answer is checked as it comes."""
    shutil.copytree(WORKCELLS / cell_name, work)
    original = yaml.safe_load((WORKCELLS / cell_name / file_name).read_text())
    invalid = 0
    for path, value, delete in cases:
        data = copy.deepcopy(original)
        _set(data, path, value, delete)
        (work / file_name).write_text(yaml.dump(data, Dumper=DUMPER, sort_keys=False))
        result = run_cli(["validate", str(work / "cell.yaml")])
        _check(result)
        invalid += result.exit_code == 2
    return invalid


@pytest.mark.parametrize("cell_name", EXAMPLE_CELLS)
@pytest.mark.parametrize("file_name", ["cell.yaml", "poses.yaml"])
def test_every_mutation_is_reported_cleanly(cell_name, file_name, tmp_path):
    original = yaml.safe_load((WORKCELLS / cell_name / file_name).read_text())
    cases = mutants(original)
    # the sweep is split over the CPUs (fresh interpreters, each on its own copy of the cell):
    # on a 2-core machine the twelve sweeps take about 135 s instead of 200
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    workers = min(cpus or 1, 4) if len(cases) > 200 else 1
    if workers == 1:
        invalid = sweep(cell_name, file_name, cases, tmp_path / cell_name)
    else:
        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = [
                pool.submit(sweep, cell_name, file_name, cases[k::workers], tmp_path / f"w{k}")
                for k in range(workers)
            ]
            invalid = sum(future.result() for future in futures)
    # the mutations are not toothless: nearly half of them must be refused (some wrong kinds
    # are values a field takes: 0, -1, 1e300, True; ur5's cell.yaml refuses 98 of 197)
    assert invalid > 0.45 * len(cases), (invalid, len(cases))
