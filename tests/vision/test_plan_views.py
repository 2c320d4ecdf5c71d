"""rworld plan-views, and the whole loop on the test cell: planned views, their program checked
in simulation and exported, the controller's log of the poses at its captures (a stand-in:
``tests.export.controller_logs``) and the images rendered at them read back into a capture
file, the corners found, the camera calibrated back to the cell's own pose of it."""

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
    assert len(out["views"]) == 10 and out["usable"] >= 140
    # the planned views' predicted error against random usable ones (the issue's 2x): 2.49x
    # with two thirds of the candidates drawn around the first choice, 1.91x from the first
    # candidates alone (docs/performance.md section 6)
    assert out["refine"] == 666 and out["refined_usable"] > 0
    assert out["random_error_mm"] / out["predicted_error_mm"] >= 2.0
    from rworld_cli.api import sense

    for view in out["views"][:3]:  # the camera sees every corner there, by the sensing room
        _, readings = sense(str(CELL), {"ur5": np.radians(view["joints_deg"]).tolist()})
        seen = next(x for x in readings if x.sensor == "wrist_camera").image["boards"]["board"]
        assert seen["seen"] == seen["total"] == 54


def _loop(cell: Path, camera: str, tmp_path: Path, candidates: int = 150) -> tuple[dict, dict]:
    """plan-views (6 views), check, export (URScript), the controller's log of the TCP pose at
    each capture (a stand-in: the planned joints' forward kinematics), the images rendered
    there, captures --from-log, calibrate-camera: (the plan's JSON, the calibration's)."""
    from rworld_cli.api import render_camera
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.world.tree import World
    from tests.export.controller_logs import Reported, reports_in, urscript_log

    captures, program = cell / "captures.yaml", cell / "programs" / "views.yaml"
    args = ["plan-views", str(cell), "--camera", camera, "--views", "6"]
    args += ["--candidates", str(candidates), "--captures", str(captures)]
    r = run_cli(args + ["--program", str(program), "--json"])
    assert r.exit_code == 0, r.output
    plan = json.loads(r.stdout)
    # the capture file names the robot and each view's joints as the program commands them
    from rworld_cli.api.vision import load_captures

    planned = load_captures(str(captures), joints=True)
    commanded = np.radians([view["joints_deg"] for view in plan["views"]])
    assert planned.device == "ur5" and np.abs(planned.joints - commanded).max() < 1e-7
    # the program visits each view from home and takes an image: free of collisions
    (cell / "runs").mkdir(exist_ok=True)
    (cell / "runs" / "views.yaml").write_text("programs: [../programs/views.yaml]\ndt: 0.01\n")
    r = run_cli(["check", str(cell), str(cell / "runs" / "views.yaml")])
    assert r.exit_code == 0, r.output
    # exported; the controller logs the TCP pose at each capture (its forward kinematics)
    args = ["export", "program", str(cell), str(program), "--format", "urscript"]
    r = run_cli(args + ["-o", str(tmp_path / "ur")])
    assert r.exit_code == 0, r.output
    script = (tmp_path / "ur" / "views.script").read_text()
    world = World(load_cell(str(cell)).cell)
    joints = [np.radians(view["joints_deg"]) for view in plan["views"]]
    poses = []
    for q in joints:
        world.set_joints("ur5", q)
        poses.append(world.T("ur5", "ur5.tool"))
    log = tmp_path / "robot.log"
    log.write_text(urscript_log([Reported(f, T) for f, T in zip(reports_in(script), poses)]))
    # the images the camera took at each, then captures --from-log and calibrate-camera
    for k, q in enumerate(joints):
        image = tmp_path / "shots" / f"shot{k + 1}.png"
        render_camera(str(cell), camera, str(image), {"ur5": q.tolist()}, seed=k)
    logged = tmp_path / "logged.yaml"
    args = ["captures", str(cell), "--from-log", str(log), "--run", str(program)]
    args += ["--format", "urscript", "--images", str(tmp_path / "shots" / "*.png")]
    r = run_cli(args + ["-o", str(logged)])
    assert r.exit_code == 0, r.output
    r = run_cli(["calibrate-camera", str(logged), "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert all(v["refused"] is None for v in out["views"])
    assert out["reprojection_rms_px"] < 0.1
    # an exact robot (the simulator's): the corners through it as near as in each picture
    assert out["reprojection_rms_px"] < 1.5 * out["pictures_rms_px"]
    assert out["robot_errors_dominate"] is False
    # so the robot's poses are taken as exact, chosen by the data
    assert out["model"] == "exact robot" and out["model_chosen"] is True
    assert out["exact_robot_ratio"] < 1.5
    return plan, out


def test_the_loop_plan_simulate_render_detect_calibrate_finds_the_cells_camera(tmp_path):
    cell = tmp_path / "cell"
    shutil.copytree(CELL, cell)
    plan, out = _loop(cell, "wrist_camera", tmp_path)
    assert plan["setup"] == "eye-in-hand" and out["setup"] == "eye-in-hand"
    # the cell's camera: 60 mm along the tool's y and 30 mm along its z, not turned
    xyz = np.array(out["camera_pose"]["xyz_mm"])
    assert np.abs(xyz - [0.0, 60.0, 30.0]).max() < 0.2, xyz
    assert np.abs(out["camera_pose"]["rpy_deg"]).max() < 0.05
    assert abs(out["camera"]["intrinsics"]["fx"] - 1050.0) < 1.0


def test_a_fixed_camera_is_calibrated_from_a_board_the_robot_holds(tmp_path):
    """Eye-to-hand (``tests/data/vision/cell_eye_to_hand``): the test cell's overhead camera
    (lowered to 0.9 m over the table's near half) and a 7 x 5 board on the UR5's flange, 50 mm
    out, facing away from it; the views planned for the board in front of the camera, the
    whole loop as above: the camera's pose in the robot's base comes back."""
    cell = tmp_path / "cell"
    shutil.copytree(CELL.parent / "cell_eye_to_hand", cell)
    plan, out = _loop(cell, "overhead", tmp_path, candidates=200)
    assert plan["setup"] == "eye-to-hand" and plan["mount"] == "ur5.tool"
    assert plan["random_error_mm"] / plan["predicted_error_mm"] > 1.5
    assert out["setup"] == "eye-to-hand" and out["camera_pose"]["parent"] == "ur5"
    xyz = np.array(out["camera_pose"]["xyz_mm"])
    assert np.abs(xyz - [450.0, 0.0, 900.0]).max() < 0.2, xyz
    turned = np.array(out["camera_pose"]["rpy_deg"]) - [180.0, 0.0, 0.0]
    assert np.abs((turned + 180.0) % 360.0 - 180.0).max() < 0.05, out["camera_pose"]
    assert out["board_pose"]["parent"] == "ur5.tool"
    assert np.abs(np.array(out["board_pose"]["xyz_mm"]) - [-75.0, 50.0, 50.0]).max() < 0.2


def test_a_start_on_a_singularity_does_not_end_the_plan():
    """600 candidates with seed 0 give the batched IK a start whose damped normal matrix is
    singular to the machine: an exit 3 (numpy's LinAlgError) before the pseudo-inverse fallback
    of kinematics/inverse.py."""
    from rworld_cli.api import plan_views

    # refine: the draws as when this was found (a third of the candidates then the default)
    run = plan_views(
        str(CELL / "cell.yaml"), "wrist_camera", 10, candidates=600, seed=0, refine=200
    )
    assert run.usable > 300
    assert run.figures["random_error"] / run.figures["error"] >= 1.5


def test_candidates_drawn_around_a_choice_stay_within_the_first_ones_bounds():
    """``refined_candidates``: near the chosen views (a few degrees, a few centimetres), from
    the board's printed side, within the tilt and the distances the first candidates had."""
    from rworld_cli import spatial
    from rworld_cli.model.vision import BoardModel
    from rworld_cli.vision.plan import camera_candidates, refined_candidates

    board = BoardModel(name="board", pattern="chessboard", columns=9, rows=6, square=0.03)
    rng = np.random.default_rng(4)
    tilt, distance = np.radians(40.0), (0.3, 0.7)
    chosen = camera_candidates(rng, board, 8, distance, tilt, np.radians(30.0))
    around = refined_candidates(rng, board, chosen, 400, distance, tilt)
    assert 100 < len(around) <= 400
    axis = around[:, :3, 2]
    assert np.degrees(np.arccos(axis[:, 2])).max() <= 40.0 + 1e-9
    away = np.linalg.norm(around[:, :3, 3] - board.centre, axis=1)
    assert away.min() >= 0.3 and away.max() <= 0.7 and (around[:, 2, 3] < 0).all()
    # each near one of the chosen: within 5 sigma of the spread drawn
    gap = np.linalg.norm(around[:, None, :3, 3] - chosen[None, :, :3, 3], axis=2).min(axis=1)
    turn = np.array(
        [
            min(np.linalg.norm(spatial.rotation_vector(c[:3, :3].T @ a[:3, :3])) for c in chosen)
            for a in around
        ]
    )
    assert gap.max() < 5 * 0.05 * 0.5 * np.sqrt(3) and np.degrees(turn.max()) < 5 * 4 * np.sqrt(3)


def _ur5_views(count: int = 12):
    """The test cell's UR5, its wrist camera and board as plan-views sees them, and ``count``
    of its planned views: (camera, board, X, Z, robot, joints, flanges)."""
    from rworld_cli.api import plan_views
    from rworld_cli.api.cells import load_world
    from rworld_cli.api.vision import flange_robot

    run = plan_views(str(CELL / "cell.yaml"), "wrist_camera", count, candidates=150, refine=0)
    world, _ = load_world(str(CELL / "cell.yaml"))
    cell = world.cell
    robot = flange_robot(world, "ur5", run.mount)
    X, Z = world.T(run.mount, "wrist_camera"), world.T("ur5", "board")
    camera, board = cell.sensors["wrist_camera"].camera, cell.objects["board"].board
    return camera, board, X, Z, robot, run.joints, run.T_base_flange


def test_the_robots_columns_are_how_its_errors_move_the_corners():
    """``robot_information``: each column is the corners' move when that joint-frame error is
    made (0.2 of its typical error, corners projected by the sensing room's ``seen_corners``
    through the moved robot), per typical error and pixel sigma; and the robot model's
    flange at no error is the cell's."""
    from rworld_cli import spatial
    from rworld_cli.vision.emulate import seen_corners
    from rworld_cli.vision.plan import robot_information

    camera, board, X, Z, robot, joints, flanges = _ur5_views(4)
    P = len(robot.names)
    assert np.abs(robot.poses(np.zeros(P), joints) - flanges).max() < 1e-12
    R = robot_information(camera, board, X, Z, robot, joints, 0.1)
    assert R.shape == (4, 2 * 54, 36)

    def corners(p):
        C = spatial.invert_transform(X) @ spatial.invert_transform(robot.poses(p, joints)) @ Z
        return seen_corners(camera, board, C).reshape(4, -1)

    for k in (1, 4, 13, 29, 35):  # lengths and angles, near the base and at the wrist
        p = np.zeros(P)
        p[k] = 0.2 * robot.scales[k]
        moved = (corners(p) - corners(-p)) / (2 * 0.2 * 0.1)
        assert np.abs(moved - R[:, :, k]).max() < 1e-4 * np.abs(R[:, :, k]).max() + 1e-6, k


def test_the_place_weight_gives_the_mean_squared_error_of_the_camera_to_board_pose():
    """``place_weight``: trace(W Cov) is the mean over the poses of the camera-to-board pose's
    squared error (position, and rotation at the lever) - against 4000 draws of the camera's
    and the robot's parameters from a covariance, each moved exactly (within 4 %)."""
    from rworld_cli import spatial
    from rworld_cli.vision.calibrate import _perturbed
    from rworld_cli.vision.plan import place_weight

    camera, board, X, Z, robot, joints, _ = _ur5_views(6)
    columns = np.array([6, 7, 8, 20, 33])
    W = place_weight(camera, X, Z, robot, joints, columns, 0.3)
    rng = np.random.default_rng(2)
    n = 21 + len(columns)
    A = rng.normal(size=(n, n)) * np.r_[np.zeros(9), np.full(12, 2e-4), np.full(len(columns), 0.3)]
    cov = A.T @ A  # intrinsics move no pose: zero rows
    draws = rng.multivariate_normal(np.zeros(n), cov, 4000)
    P = len(robot.names)

    def place(x):  # the camera in the board's frame
        p = np.zeros(P)
        p[columns] = x[21:] * robot.scales[columns]
        F = robot.poses(p, joints)
        return np.linalg.solve(_perturbed(Z, x[15:21]), F @ _perturbed(X, x[9:15]))

    base = place(np.zeros(n))
    squared = []
    for x in draws:
        T = place(x)
        turn = spatial.rotation_vector(np.swapaxes(base[:, :3, :3], 1, 2) @ T[:, :3, :3])
        d = T[:, :3, 3] - base[:, :3, 3]
        squared.append(np.mean(np.sum(d**2, axis=1) + 0.09 * np.sum(turn**2, axis=1)))
    assert np.trace(W @ cov) == pytest.approx(np.mean(squared), rel=0.04)


def test_views_planned_with_the_robot_count_its_errors_and_beat_random_ones():
    """plan-views --with-robot: the robot's 18 joint-frame parameters the test cell's views
    determine beside the camera's (calibrate-camera --with-robot identifies the same 18 in
    docs/performance.md section 7), the camera-to-board error at its poses below random
    choices' and the views chosen for the camera alone, said in text and JSON."""
    args = ["plan-views", str(CELL), "--camera", "wrist_camera", "--views", "12"]
    args += ["--candidates", "150", "--refine", "50", "--with-robot"]
    r = run_cli(args + ["--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["with_robot"] is True and len(out["robot_parameters"]) == 18
    # joint 1's six are the board's pose in the base, seen by the camera as one
    names = out["robot_parameters"]
    assert all(n[:1] == "j" for n in names) and not any(n.startswith("j1.") for n in names)
    assert out["random_error_mm"] / out["predicted_error_mm"] >= 1.5
    # the views chosen for the camera alone from the same candidates, by the same figure
    assert out["camera_choice_error_mm"] > out["predicted_error_mm"]
    r = run_cli(args)
    assert r.exit_code == 0, r.output
    assert "18 of its joint-frame parameters" in r.output
    assert "the camera-to-board pose at the robot's poses" in r.output
    # eye-to-hand: the board on the flange, the overhead camera
    cell = CELL.parent / "cell_eye_to_hand"
    args = ["plan-views", str(cell), "--camera", "overhead", "--views", "12"]
    r = run_cli(args + ["--candidates", "150", "--refine", "0", "--with-robot", "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["setup"] == "eye-to-hand" and len(out["robot_parameters"]) == 18
    assert out["random_error_mm"] / out["predicted_error_mm"] >= 1.5
    assert out["camera_choice_error_mm"] > out["predicted_error_mm"]
