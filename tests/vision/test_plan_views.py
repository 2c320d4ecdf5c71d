"""rworld plan-views, and the whole loop on the test cell: planned views, their program checked
in simulation, the images rendered at them, the corners found, the camera calibrated back to
the cell's own pose of it."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import run_cli

cv2 = pytest.importorskip("cv2")

CELL = Path(__file__).resolve().parents[1] / "data" / "vision" / "cell"


def test_planned_views_beat_random_ones_and_the_camera_sees_the_board_whole_at_each():
    r = run_cli(["plan-views", str(CELL), "--camera", "wrist_camera", "--views", "10", "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert len(out["views"]) == 10 and out["usable"] >= 150
    # the issue's figure: the planned views' predicted error at least 2x smaller than random
    assert out["random_error_mm"] / out["predicted_error_mm"] >= 2.0
    from rworld_cli.api import sense

    for view in out["views"][:3]:  # the camera sees every corner there, by the sensing room
        _, readings = sense(str(CELL), {"ur5": np.radians(view["joints_deg"]).tolist()})
        seen = next(x for x in readings if x.sensor == "wrist_camera").image["boards"]["board"]
        assert seen["seen"] == seen["total"] == 54


def test_the_loop_plan_simulate_render_detect_calibrate_finds_the_cells_camera(tmp_path):
    cell = tmp_path / "cell"
    shutil.copytree(CELL, cell)
    captures, program = cell / "captures.yaml", cell / "programs" / "views.yaml"
    r = run_cli(
        [
            "plan-views",
            str(cell),
            "--camera",
            "wrist_camera",
            "--views",
            "6",
            "--candidates",
            "150",
            "--captures",
            str(captures),
            "--program",
            str(program),
            "--json",
        ]
    )
    assert r.exit_code == 0, r.output
    views = json.loads(r.stdout)["views"]
    # the program visits each view from home and reads the camera: free of collisions
    (cell / "runs" / "views.yaml").write_text("programs: [../programs/views.yaml]\ndt: 0.01\n")
    r = run_cli(["check", str(cell), str(cell / "runs" / "views.yaml")])
    assert r.exit_code == 0, r.output
    # the images the camera would take at each view, then calibrate-camera on them
    from rworld_cli.api import render_camera

    for k, view in enumerate(views):
        joints = {"ur5": np.radians(view["joints_deg"]).tolist()}
        render_camera(str(cell), "wrist_camera", str(cell / f"view{k + 1:02d}.png"), joints, seed=k)
    r = run_cli(["calibrate-camera", str(captures), "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert all(v["refused"] is None for v in out["views"])
    assert out["reprojection_rms_px"] < 0.1
    # the cell's camera: 60 mm along the tool's y and 30 mm along its z, not turned
    xyz = np.array(out["camera_pose"]["xyz_mm"])
    assert np.abs(xyz - [0.0, 60.0, 30.0]).max() < 0.2, xyz
    assert np.abs(out["camera_pose"]["rpy_deg"]).max() < 0.05
    assert abs(out["camera"]["intrinsics"]["fx"] - 1050.0) < 1.0


def test_a_start_on_a_singularity_does_not_end_the_plan():
    """600 candidates with seed 0 give the batched IK a start whose damped normal matrix is
    singular to the machine: an exit 3 (numpy's LinAlgError) before the pseudo-inverse fallback
    of kinematics/inverse.py."""
    from rworld_cli.api import plan_views

    run = plan_views(str(CELL / "cell.yaml"), "wrist_camera", 10, candidates=600, seed=0)
    assert run.usable > 400
    assert run.figures["random_error"] / run.figures["error"] >= 2.0
