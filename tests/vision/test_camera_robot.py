"""The robot's own kinematic errors with the camera (issue 63): a UR5 whose joints are off its
DH table (a small pose before every row, 0.5 mm and 0.05 deg), its wrist camera's views of the
board emulated through that true robot (0.1 px of noise), the capture file holding the
controller's nominal flange poses and the joint values.  The exact-robot fit absorbs the
robot's errors and predicts held-out views badly; the views written as 6-DoF observations
(``--write-robot-observations``), ``calibrate-robot`` on them and ``calibrate-camera
--through-robot`` predict the held-out views at the pixel noise, and put the camera where the
true robot has it relative to the board at the held-out joints (0.058 mm, against 7.4 mm).
``--with-robot`` does it in one bundle adjustment (camera, board and the robot's joint frames
together) and writes the robot's corrections for its cell; eye-to-hand on a vendor's robot."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from tests.conftest import run_cli
from tests.vision.camera_cells import emulated_captures, list_pose_file, robot_off_its_model
from tests.vision.test_sense_camera import CELL

cv2 = pytest.importorskip("cv2")

NOISE_PX = 0.1


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    """The nominal cell, the truth, 40 planned views' joints, and the capture file."""
    from rworld_cli.api import plan_views
    from rworld_cli.schema.loader import load_cell

    root = tmp_path_factory.mktemp("camera_robot")
    cell = root / "cell"
    shutil.copytree(CELL, cell)
    truth_dir = robot_off_its_model(CELL, root / "truth", np.random.default_rng(3))
    truth = load_cell(str(truth_dir)).cell
    nominal = load_cell(str(cell)).cell
    plan = plan_views(str(cell), "wrist_camera", 40, candidates=300, seed=1)
    captures = emulated_captures(
        root, nominal, truth, plan.joints, np.random.default_rng(5), NOISE_PX
    )
    return root, cell, truth, plan, captures


def _board_camera(cell_model, result, joints) -> np.ndarray:
    """The camera in the board's frame at each joint state (K, 4, 4): a calibration's camera in
    the tool frame and board in the base, through ``cell_model``'s robot."""
    from rworld_cli.world.tree import World

    world = World(cell_model)
    out = []
    for q in joints:
        world.set_joints("ur5", q)
        T_base_camera = world.T("ur5", "ur5.tool") @ result.T_mount_camera
        out.append(np.linalg.solve(result.T_holder_board, T_base_camera))
    return np.array(out)


def test_the_camera_calibrates_the_robot_and_then_predicts_through_it(setup):
    from rworld_cli.api import calibrate_camera, calibrate_robot
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.world.tree import World

    root, cell, truth, plan, captures = setup
    held = plan.joints[3::4]  # the views held out (every 4th)
    true_world = World(truth)
    true_camera = []
    for q in held:
        true_world.set_joints("ur5", q)
        true_camera.append(true_world.T("ur5", "wrist_camera"))
    true_camera = np.array(true_camera)

    exact = calibrate_camera(str(captures), holdout_every=4, flange_errors=False)
    observations = root / "robot_obs.yaml"
    calibrate_camera(str(captures), write_robot_observations=str(observations))
    text = observations.read_text()
    assert "target: wrist_camera" in text and "frame: board" in text
    robot = calibrate_robot(str(cell), [str(observations)], output=str(cell / "robot_cal.yaml"))
    assert robot.written
    list_pose_file(cell, "robot_cal.yaml")
    through = calibrate_camera(str(captures), holdout_every=4, through_robot=True)

    # held-out views predicted through the robot: the nominal robot's errors, then the noise
    assert exact.held_out_rms > 5 * NOISE_PX, exact.held_out_rms
    # the exact-robot fit says so, and that this capture file's joints allow --with-robot
    assert exact.robot_errors_dominate and exact.robot_named
    r = run_cli(["calibrate-camera", str(captures)])
    assert r.exit_code == 0, r.output
    # by default the model of the robot's pose errors, chosen, and --with-robot named
    assert "model: the robot's pose errors (chosen: through its poses as given" in r.stdout
    assert "--with-robot estimates the robot's own joint-frame errors" in r.stdout
    assert through.held_out_rms < 2 * NOISE_PX, through.held_out_rms
    # where the camera is in the board's frame at the held-out joints, against the truth:
    # the robot's base and the board's pose share a gauge (joint 1's errors and the board's
    # pose are one to the camera), the camera's pose to the board has none
    cal = _board_camera(load_cell(str(cell)).cell, through.result, held)
    nominal = load_cell(str(cell), pose_files=[str(cell / "poses.yaml")]).cell
    raw = _board_camera(nominal, exact.result, held)
    true = np.linalg.inv(true_world.T_world("board")) @ true_world.T_world("ur5") @ true_camera
    error_after = np.abs(cal[:, :3, 3] - true[:, :3, 3]).max()
    error_before = np.abs(raw[:, :3, 3] - true[:, :3, 3]).max()
    assert error_after < 0.1e-3 and error_before > 1e-3, (error_before, error_after)


def test_joint_values_that_are_not_the_robots_are_refused_at_their_line(setup, cli, tmp_path):
    root, *_ = setup
    text = (root / "captures.yaml").read_text()
    lines = text.splitlines()
    at = next(k for k, line in enumerate(lines) if line.strip().startswith("joints:"))
    lines[at] = "    joints: [0, 0, 0]"
    bad = root / "bad_joints.yaml"
    bad.write_text("\n".join(lines) + "\n")
    r = cli(["calibrate-camera", str(bad), "--through-robot"])
    assert r.exit_code == 2
    assert f"bad_joints.yaml:{at + 1}:" in r.output
    assert "3 value(s) for the 6 joint(s) of 'ur5'" in r.output
    # no robot: --through-robot and --write-robot-observations are refused, nothing written
    plain = root / "no_robot.yaml"
    kept = [x for x in text.splitlines() if not x.strip().startswith(("joints:", "robot:"))]
    plain.write_text("\n".join(kept) + "\n")
    out = tmp_path / "obs.yaml"
    r = cli(["calibrate-camera", str(plain), "--write-robot-observations", str(out)])
    assert r.exit_code == 2 and "needs the views' joint values" in r.output
    assert not out.exists()
    r = cli(["calibrate-camera", str(plain)])  # the file itself is fine
    assert r.exit_code == 0, r.output


def test_one_bundle_adjustment_joins_the_robots_errors_and_writes_them_for_its_cell(setup, cli):
    """``--with-robot``: the intrinsics, hand-eye, board and the robot's joint frames in one
    estimate from the same views - the held-out views at the pixel noise through the corrected
    robot, the camera where the true robot has it relative to the board, the fit's
    a-posteriori factor near 1; the robot's corrections written as a pose file that, listed in
    the cell, puts every flange where the estimate put it (``--through-robot`` then predicts
    the held-out views as the estimate did)."""
    from rworld_cli.api import calibrate_camera
    from rworld_cli.api.vision import _flanges_through_robot, _robot_model, load_captures
    from rworld_cli.world.tree import World

    root, cell, truth, plan, captures = setup
    work = root / "one_step"  # the nominal cell, whatever the other tests list in theirs
    shutil.copytree(CELL, work)
    text = captures.read_text().replace("robot: {cell: cell,", "robot: {cell: one_step,")
    assert "one_step" in text
    moved = root / "captures_one_step.yaml"
    moved.write_text(text)
    loaded = load_captures(str(moved), joints=True)
    model = _robot_model(loaded)  # the flange through the calibration's model of the robot
    nominal = model.poses(np.zeros(len(model.names)), loaded.joints)
    world = World(loaded.robot_model)  # and through the cell's tree
    for q, T in zip(loaded.joints, nominal, strict=True):
        world.set_joints("ur5", q)
        assert np.abs(world.T("ur5", "ur5.tool") - T).max() < 1e-12

    overlay = work / "robot_from_camera.yaml"
    r = cli(
        ["calibrate-camera", str(moved), "--with-robot", "--holdout-every", "4"]
        + ["--write-robot", str(overlay), "--json"]
    )
    assert r.exit_code == 0, r.output
    import json

    out = json.loads(r.output)
    robot = out["robot"]
    assert out["model"] == "robot errors"
    assert out["held_out_rms_px"] < 2 * NOISE_PX, out["held_out_rms_px"]
    assert 0.8 < robot["variance_factor"] < 1.25, robot
    assert robot["converged"] and 0 < robot["iterations"] < 50, robot
    assert abs(robot["pixel_noise_px"] - NOISE_PX) < 0.02, robot
    # joint 1's errors are the board's pose to the camera: kept nominal, listed
    assert {"j1.x", "j1.y", "j1.rz"} <= set(robot["kept_nominal"])
    assert robot["identified"] >= 12 and str(overlay) in out["written"]
    assert "tool: rworld calibrate-camera --with-robot" in overlay.read_text()

    # the camera relative to the board at the held-out joints, against the truth
    held = plan.joints[3::4]
    run = calibrate_camera(str(moved), holdout_every=4, with_robot=True)
    T_base_flange = model.poses(run.result.robot.p, held)
    estimated = np.linalg.solve(
        run.result.T_holder_board, T_base_flange @ run.result.T_mount_camera
    )
    true_world = World(truth)
    true = []
    for q in held:
        true_world.set_joints("ur5", q)
        true.append(true_world.T("board", "wrist_camera"))
    error = np.abs(estimated[:, :3, 3] - np.array(true)[:, :3, 3]).max()
    assert error < 0.1e-3, error

    # the file, listed in the cell, is the estimate's robot
    list_pose_file(work, overlay.name)
    again = load_captures(str(moved), joints=True)
    through = _flanges_through_robot(again)
    assert np.abs(through - model.poses(run.result.robot.p, again.joints)).max() < 1e-9
    predicted = calibrate_camera(str(moved), holdout_every=4, through_robot=True)
    assert predicted.held_out_rms < 2 * NOISE_PX, predicted.held_out_rms

    # --write-robot alone is refused, nothing written
    lone = root / "lone.yaml"
    r = cli(["calibrate-camera", str(moved), "--write-robot", str(lone)])
    assert r.exit_code == 2 and "--with-robot" in r.output and not lone.exists()


def test_one_estimate_with_the_robot_eye_to_hand_on_a_vendors_robot(tmp_path):
    """DENSO's VS060 from its vendor's package (new to the vision tests), the camera fixed
    beside it and a board on its TCP, its joint frames off by 0.5 mm / 0.05 deg: the one
    estimate predicts the held-out views at the noise and puts the board where the true robot
    has it in the camera's frame at those joints."""
    from rworld_cli.api import calibrate_camera, plan_views
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.world.tree import World
    from tests.vision.camera_cells import camera_cell

    cell = camera_cell("vs060", tmp_path / "cell", fixed=True)
    off = robot_off_its_model(cell, tmp_path / "truth", np.random.default_rng(11))
    truth, nominal = load_cell(str(off)).cell, load_cell(str(cell)).cell
    # the views as planned when this was written (a third of the candidates drawn around the
    # choice): the estimate's test, not the planner's (with two thirds, the default since,
    # the place is off by 0.106 mm at most there, 2.3 of its predicted sigma)
    plan = plan_views(str(cell), "wrist_camera", 40, candidates=300, seed=0, refine=100)
    captures = emulated_captures(
        tmp_path, nominal, truth, plan.joints, np.random.default_rng(5), NOISE_PX
    )
    exact = calibrate_camera(str(captures), holdout_every=4, flange_errors=False)
    one = calibrate_camera(str(captures), holdout_every=4, with_robot=True)
    assert one.setup == "eye-to-hand"
    assert exact.held_out_rms > 10 * NOISE_PX, exact.held_out_rms
    assert one.held_out_rms < 2 * NOISE_PX, one.held_out_rms
    robot = one.result.robot
    assert 0.8 < robot.variance_factor < 1.25, robot.variance_factor
    held = plan.joints[3::4]
    F = robot.model.poses(robot.p, held)  # the board's holder in the base, corrected
    estimated = np.linalg.solve(one.result.T_mount_camera, F @ one.result.T_holder_board)
    world = World(truth)
    device = next(iter(truth.devices))
    true = []
    for q in held:
        world.set_joints(device, q)
        true.append(world.T("wrist_camera", "hand_board"))
    error = np.abs(estimated[:, :3, 3] - np.array(true)[:, :3, 3]).max()
    assert error < 0.1e-3, error
