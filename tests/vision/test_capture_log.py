"""Images taken on a real cell and read back (issue 63): a planned view program's ``capture:``
steps exported in each controller language, on a vendor robot imported from its ROS package
(``camera_cells``), a stand-in controller (``tests.export.controller_logs``: scipy's rotations
and string formatting, no rworld code) logging the TCP pose the robot stood at for each image,
and ``rworld captures --from-log`` writing the capture file: each view's flange pose the
planned one to 1e-9 m; a log that is not the program's refused at its line."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from rworld_cli import spatial
from rworld_cli.api.vision import load_captures
from rworld_cli.schema.loader import load_cell
from rworld_cli.world.tree import World
from tests.export import controller_logs
from tests.export.controller_logs import Reported, reports_in
from tests.vision.camera_cells import camera_cell

# the program's simulation made once a worker for the same files (tests/conftest.py)
pytestmark = pytest.mark.usefixtures("simulation_once")

# each language on a robot of its vendor where tests/data/probe_robots has one
ROBOTS = {
    "urscript": "ur10e",
    "krl": "kr6r900sixx",
    "fanuc": "cr7ial",
    "inform": "gp12",
    "sunrise": "iiwa14",
    "rapid": "ur10e",
    "drl": "ur10e",
    "val3": "ur10e",
}
LOG_FILES = {
    "urscript": "robot.log",
    "rapid": "rworld.log",
    "krl": "views.dat",
    "fanuc": "POSREG.VA",
    "inform": "VAR.DAT",
    "drl": "tp_log.txt",
    "val3": "val3.log",
    "sunrise": "sunrise.log",
}
_PLANS: dict[str, tuple] = {}


def _planned(robot: str, root: Path):
    """The robot's camera cell and 4 planned views with their program (once a worker)."""
    if robot not in _PLANS:
        from rworld_cli.api import plan_views

        cell = camera_cell(robot, root / robot)
        program = cell / "programs" / "views.yaml"
        plan = plan_views(str(cell), "wrist_camera", 4, candidates=120, program=str(program))
        _PLANS[robot] = (cell, program, plan)
    return _PLANS[robot]


@pytest.fixture(scope="module")
def plans(tmp_path_factory):
    root = tmp_path_factory.mktemp("camera_cells")
    return lambda robot: _planned(robot, root)


def _controller_poses(cell: Path, plan, carried: str = "wrist_camera") -> list[np.ndarray]:
    """Where the controller's TCP stood at each image, in its base frame: the planned joints'
    forward kinematics (the program's TCP: the device's first, the carried frame's mount)."""
    model = load_cell(str(cell)).cell
    world = World(model)
    device = plan.device
    dev = model.devices[device]
    tcp = world.parent(carried)
    base = dev.controller.base if dev.controller is not None and dev.controller.base else device
    out = []
    for q in plan.joints:
        world.set_joints(device, q)
        out.append(world.T(base, tcp))
    return out


def _exported(cli, cell, program, fmt, out) -> str:
    r = cli(["export", "program", str(cell), str(program), "--format", fmt, "-o", str(out)])
    assert r.exit_code == 0, r.output
    if fmt == "val3":
        return next(out.glob("*/start.pgx")).read_text()
    files = {p.suffix: p.read_text() for p in out.iterdir()}
    if fmt == "sunrise":
        return files[".java"]
    return files.get(".dat") if fmt == "krl" else next(iter(files.values()))


def _log(fmt: str, exported: str, reports: list[Reported]) -> str:
    if fmt == "urscript":
        return controller_logs.urscript_log(reports)
    if fmt == "rapid":
        return controller_logs.rapid_file(reports)
    if fmt == "krl":
        return controller_logs.krl_dat(exported, reports, prefix="RWV")
    if fmt == "drl":
        return controller_logs.drl_log(exported, reports)
    if fmt == "val3":
        return controller_logs.val3_log(exported, reports)
    if fmt == "sunrise":
        return controller_logs.sunrise_log(exported, reports)
    if fmt == "inform":
        tools = controller_logs.inform_contact_tools(exported)
        return controller_logs.inform_var_dat(reports, 151, (9, 9), tools, size=200)
    return controller_logs.fanuc_posreg(reports, 151, 9)


def _write_log(cli, plans, fmt, tmp_path, shift=None) -> tuple[Path, Path, object, list[str]]:
    cell, program, plan = plans(ROBOTS[fmt])
    exported = _exported(cli, cell, program, fmt, tmp_path / "exported")
    poses = _controller_poses(cell, plan)
    if shift is not None:
        poses[shift[0]] = poses[shift[0]].copy()
        poses[shift[0]][:3, 3] += shift[1]
    fields = reports_in(exported) if fmt not in ("fanuc", "inform") else [""] * len(poses)
    assert len(fields) == len(poses) == 4
    assert all(f.startswith("rworld capture ") for f in fields if f)
    log = tmp_path / LOG_FILES[fmt]
    log.write_text(_log(fmt, exported, [Reported(f, T) for f, T in zip(fields, poses)]))
    images = []
    for k in range(4):
        image = tmp_path / "shots" / f"shot{k + 1}.png"
        image.parent.mkdir(exist_ok=True)
        image.write_bytes(b"")  # the command reads only their names; calibrate-camera reads them
        images.append(str(image))
    return cell, program, plan, log, images


@pytest.mark.parametrize("fmt", list(ROBOTS))
def test_each_languages_capture_log_gives_the_planned_flange_poses(cli, plans, tmp_path, fmt):
    cell, program, plan, log, _ = _write_log(cli, plans, fmt, tmp_path)
    out = tmp_path / "captures.yaml"
    args = ["captures", str(cell), "--from-log", str(log), "--run", str(program)]
    args += ["--images", str(tmp_path / "shots" / "*.png"), "--format", fmt, "-o", str(out)]
    r = cli(args + ["--json"])
    assert r.exit_code == 0, r.output
    captures = load_captures(str(out))
    assert captures.setup == "eye-in-hand"
    assert [Path(v).name for v in captures.images] == [f"shot{k}.png" for k in range(1, 5)]
    for T, planned in zip(captures.T_base_flange, plan.T_base_flange, strict=True):
        assert np.abs(T[:3, 3] - planned[:3, 3]).max() < 1e-9
        assert np.linalg.norm(spatial.rotation_vector(planned[:3, :3].T @ T[:3, :3])) < 1e-9
    # the controller's joints: its inverse kinematics of each logged pose, the planned ones
    assert captures.device == plan.device
    assert np.abs(captures.joints - plan.joints).max() < 1e-8
    assert captures.camera.name == "wrist_camera"
    assert captures.board.name == "board"
    # the trigger: set, the pose logged, held for the exposure, reset - in each language
    text = "".join(p.read_text() for p in (tmp_path / "exported").rglob("*") if p.is_file())
    trigger = {
        "urscript": r"set_digital_out\(3, True\)",
        "krl": r"\$OUT\[3\] = TRUE",
        "rapid": r"SetDO do_3, 1;",
        "fanuc": r"DO\[3\]=ON",
        "inform": r"DOUT OT#\(3\) ON",
        "drl": r"set_digital_output\(3, ON\)",
        "val3": r"dCamera = true",
        "sunrise": r"setCameraTrigger\(true\);",
    }[fmt]
    assert len(re.findall(trigger, text)) == 4


def test_the_clis_log_formats_are_the_readers():
    from rworld_cli.cli.common import LOG_FORMATS
    from rworld_cli.schema.contactlog import LANGUAGES

    assert LOG_FORMATS == LANGUAGES


def test_a_pose_far_from_its_capture_is_refused_at_its_line(cli, plans, tmp_path):
    cell, program, _, log, images = _write_log(
        cli, plans, "urscript", tmp_path, shift=(1, np.array([0.0, 0.012, 0.0]))
    )
    out = tmp_path / "captures.yaml"
    args = ["captures", str(cell), "--from-log", str(log), "--run", str(program), "-o", str(out)]
    r = cli(args + [x for image in images for x in ("--images", image)])
    assert r.exit_code == 2
    assert f"{log}:4: capture 2 (wrist_camera, step 5) lies 12.000 mm and 0.000 deg" in r.output
    assert not out.exists()
    # one image short: refused before anything is written
    r = cli(args[:-2] + ["--format", "urscript", "-o", str(out)] + ["--images", images[0]])
    assert r.exit_code == 2
    assert "1 image(s) given for the 4 capture(s) of 'wrist_camera'" in r.output
    assert not out.exists()


def test_a_capture_with_a_sensor_that_is_not_a_camera_is_refused_at_its_line(cli, tmp_path):
    import shutil

    from tests.vision.test_sense_camera import CELL

    cell = tmp_path / "cell"
    shutil.copytree(CELL, cell)
    program = cell / "programs" / "bad.yaml"
    program.write_text(
        "device: ur5\nsteps:\n  - move: {to: view1, tcp: wrist_camera}\n  - capture: post\n"
    )
    r = cli(["check", str(cell), str(program)])
    assert r.exit_code == 2
    assert "bad.yaml:4:" in r.output and "'post' is not a camera sensor" in r.output
    program.write_text("device: ur5\nsteps:\n  - capture: wrist_camera\n")
    r = cli(["export", "program", str(cell), str(program), "--format", "krl", "-o", str(tmp_path)])
    assert r.exit_code == 2
    assert "a capture before the program's first move" in r.output


def test_a_fixed_cameras_captures_give_the_board_holders_poses_on_a_kuka(cli, tmp_path):
    """Eye-to-hand on the KR 6 R900 sixx from its vendor package (``camera_cells``, fixed):
    4 views planned for the board it holds in front of a camera beside it, exported in KRL, the
    .dat's poses read back: each view's flange - the board's holder, the TCP - at the plan's
    to 1e-9 m, the capture file eye-to-hand with the camera in the robot's base."""
    from rworld_cli.api import plan_views

    cell = camera_cell("kr6r900sixx", tmp_path / "kr6", fixed=True)
    program = cell / "programs" / "views.yaml"
    plan = plan_views(str(cell), "wrist_camera", 4, candidates=200, program=str(program))
    assert plan.setup == "eye-to-hand" and plan.board == "hand_board"
    exported = _exported(cli, cell, program, "krl", tmp_path / "exported")
    fields = reports_in(exported)
    poses = _controller_poses(cell, plan, "hand_board")
    log = tmp_path / "views.dat"
    log.write_text(
        controller_logs.krl_dat(
            exported, [Reported(f, T) for f, T in zip(fields, poses)], prefix="RWV"
        )
    )
    for k in range(4):
        (tmp_path / f"shot{k + 1}.png").write_bytes(b"")
    out = tmp_path / "captures.yaml"
    args = ["captures", str(cell), "--from-log", str(log), "--run", str(program), "-o", str(out)]
    r = cli(args + ["--format", "krl", "--images", str(tmp_path / "shot*.png")])
    assert r.exit_code == 0, r.output
    captures = load_captures(str(out))
    assert captures.setup == "eye-to-hand" and captures.holder == plan.mount
    assert captures.mount == plan.device and captures.board.name == "hand_board"
    for T, planned in zip(captures.T_base_flange, plan.T_base_flange, strict=True):
        assert np.abs(T[:3, 3] - planned[:3, 3]).max() < 1e-9
        assert np.linalg.norm(spatial.rotation_vector(planned[:3, :3].T @ T[:3, :3])) < 1e-9
