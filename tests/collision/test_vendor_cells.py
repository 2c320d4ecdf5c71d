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


def test_a_second_check_reads_meshes_parts_and_trees_from_the_cache(tmp_path):
    """The GP7 cell checked twice in fresh processes with an empty cache: the second neither
    imports trimesh nor fits a hull or a tree (all read back, authenticated), and reports the
    same."""
    import os
    import subprocess
    import sys

    probe = (
        "import json, sys\n"
        "from rworld_cli.collision import bvh, parts\n"
        "fitted = []\n"
        "build, hulls = bvh._build, parts._hull_parts\n"
        "bvh._build = lambda p: (len(p) >= bvh.CACHED_LEAVES and fitted.append('tree'))"
        " or build(p)\n"
        "parts._hull_parts = lambda *a: fitted.append('hull') or hulls(*a)\n"
        "from rworld_cli.cli import main\n"
        "sys.argv = ['rworld', 'check', sys.argv[1], 'tour', '--json']\n"
        "try:\n"
        "    main()\n"
        "except SystemExit:\n"
        "    pass\n"
        "print(json.dumps({'trimesh': 'trimesh' in sys.modules, 'fitted': sorted(set(fitted))}))\n"
    )
    env = os.environ | {"RWORLD_CACHE_DIR": str(tmp_path / "cache"), "RWORLD_CELL_CACHE": "0"}

    def run() -> dict:
        out = subprocess.run(
            [sys.executable, "-c", probe, str(CELLS / "gp7")],
            env=env,
            capture_output=True,
            text=True,
        )
        assert out.returncode == 0, out.stderr
        *report, probed = out.stdout.strip().splitlines()
        return json.loads("\n".join(report)), json.loads(probed)

    (first, fitted), (second, read) = run(), run()
    assert fitted["trimesh"] and fitted["fitted"] == ["hull", "tree"]
    assert not read["trimesh"] and read["fitted"] == []
    assert first["ok"] and second == first
