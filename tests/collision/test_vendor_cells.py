"""`rworld check` on the vendor cells of issue 47 (tests/data/vendor_cells: the vendors' own
ROS meshes - non-convex, some open - with a table and a holed plate): the tour passes, and the
same tour taken through the plate fails at the step and pair where it goes through.

Their time and memory are figures, not assertions: ``python bench/collision.py --vendor``.
"""

from __future__ import annotations

import json
import shutil

import pytest

from tests.conftest import REPO

CELLS = REPO / "tests" / "data" / "vendor_cells"


@pytest.mark.parametrize("cell", ["tx2_60", "iiwa14", "gp7"])
def test_the_vendor_tours_pass(cli, cell):
    result = cli(["check", str(CELLS / cell), "tour", "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["ok"] and report["collisions"]["collisions"] == []
    # the TX2-60's base and first link are open meshes: listed, checked as surfaces
    expected_open = ["staubli_tx2_60", "staubli_tx2_60.link_1"] if cell == "tx2_60" else []
    assert sorted(report["collisions"]["open_meshes"]) == expected_open


def test_a_tour_through_the_plate_fails_at_its_step(cli, tmp_path):
    cell = tmp_path / "iiwa14"
    shutil.copytree(CELLS / "iiwa14", cell)
    (cell / "programs" / "down.yaml").write_text(
        "device: kuka_lbr_iiwa_14_r820\n"
        "units: {angle: deg}\n"
        "steps:\n"
        "  - move: {joints: [0, 40, 0, -80, 0, 50, 0]}\n"
        "  - move: {joints: [0, 40, 0, -90, 0, 50, 0]}\n"
    )
    result = cli(["check", str(cell), "down"])
    assert result.exit_code == 1, result.output
    first = next(line for line in result.output.splitlines() if line.startswith("collision:"))
    assert first.startswith("collision: plate with kuka_lbr_iiwa_14_r820.link_7")
    assert "step 2 (move to joint values)" in first
