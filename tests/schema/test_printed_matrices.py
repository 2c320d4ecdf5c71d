"""Pose matrices printed to a few decimals (controllers' logs, data sets' text files): taken
as their nearest rotation, quietly at 6 decimals, said at 4, refused when no rotation."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from rworld_cli import spatial
from rworld_cli.errors import UserError
from rworld_cli.schema.loader import load_cell

CASE = Path(__file__).parent / "testdata" / "malformed" / "pose_bad_matrix"


def _cell_with_box_matrix(tmp_path: Path, decimals: int | None, scale: float = 1.0) -> Path:
    cell = tmp_path / "cell"
    shutil.copytree(CASE, cell)
    R = spatial.rpy_to_matrix(np.radians([17.0, -33.0, 121.0])) * scale
    if decimals is not None:
        R = np.round(R, decimals)
    rows = [[*R[i], [500.0, 20.0, -7.5][i]] for i in range(3)] + [[0, 0, 0, 1]]
    text = ", ".join("[" + ", ".join(repr(float(v)) for v in row) + "]" for row in rows)
    poses = (cell / "poses.yaml").read_text().splitlines()
    poses = [
        f"  box: {{matrix: [{text}]}}" if line.startswith("  box:") else line for line in poses
    ]
    (cell / "poses.yaml").write_text("\n".join(poses) + "\n")
    return cell


@pytest.mark.parametrize("decimals, said", [(6, False), (4, True), (3, True)])
def test_a_printed_matrix_is_its_nearest_rotation(tmp_path, decimals, said):
    cell = _cell_with_box_matrix(tmp_path, decimals)
    loaded = load_cell(str(cell))
    T = loaded.cell.poses["box"]
    exact = spatial.rpy_to_matrix(np.radians([17.0, -33.0, 121.0]))
    assert spatial.rotation_error(T[:3, :3]) < 1e-14
    # the nearest rotation is within the printing's rounding of the exact one
    assert np.abs(T[:3, :3] - exact).max() < 2 * 0.5 * 10.0**-decimals
    np.testing.assert_allclose(T[:3, 3], [0.5, 0.02, -0.0075], atol=1e-15)
    warned = [w.message for w in loaded.warnings if "from a rotation" in w.message]
    assert bool(warned) == said, warned
    if said:
        assert "printed to few decimals?" in warned[0] and "nearest rotation used" in warned[0]


def test_a_matrix_far_from_any_rotation_is_refused(tmp_path):
    cell = _cell_with_box_matrix(tmp_path, None, scale=1.01)  # 1 % too long: no rounding
    with pytest.raises(UserError) as err:
        load_cell(str(cell))
    assert "the matrix's rotation part is not a rotation" in str(err.value.issues)
