"""Any wrong scalar or deleted key in an example program or run file: a clean answer, never a
traceback.

Loading (schema and the checks against the cell) runs for every mutant; the
ones that still load are simulated too.
"""

from __future__ import annotations

import copy
import shutil

import pytest
import yaml

from rworld_cli.errors import UserError
from rworld_cli.schema.programs import load_run
from rworld_cli.simulate.engine import simulate
from tests.conftest import WORKCELLS
from tests.schema.test_mutations import _set, mutants

pytestmark = pytest.mark.slow  # the mutation sweeps take half the suite's time; CI runs them

CASES = [
    ("puma560", "programs/pick_place.yaml", "runs/pick_place.yaml"),
    ("paper_fig9", "programs/robot.yaml", "runs/transfer.yaml"),
    ("paper_fig9", "programs/hand_b.yaml", "runs/transfer.yaml"),
    ("paper_fig9", "runs/transfer.yaml", "runs/transfer.yaml"),
]


@pytest.mark.parametrize(
    "cell_name, file_name, run_name", CASES, ids=[f"{c}-{f}" for c, f, _ in CASES]
)
def test_every_program_mutation_is_reported_cleanly(cell_name, file_name, run_name, tmp_path):
    work = tmp_path / cell_name
    shutil.copytree(WORKCELLS / cell_name, work)
    original = yaml.safe_load((WORKCELLS / cell_name / file_name).read_text())
    cases = mutants(original)
    refused = 0
    for path, value, delete in cases:
        data = copy.deepcopy(original)
        _set(data, path, value, delete)
        (work / file_name).write_text(yaml.safe_dump(data, sort_keys=False))
        try:
            simulate(load_run(str(work), str(work / run_name)))
        except UserError as exc:  # the located, exit-2 kind of failure
            refused += 1
            assert exc.lines() and all(line.strip() for line in exc.lines())
    assert refused > 0.5 * len(cases)
