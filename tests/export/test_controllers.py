"""Programs in the controller's own frames: a UR5 from Universal Robots' description (the URDF in
example-robot-data), imported as users do, with a 150 mm tool on the flange.

The exported URScript is read back by the independent reader (tests/export/readers.py) and
checked against Pinocchio's forward kinematics of the original URDF: tool data relative to the
flange `tool0`, Cartesian targets in the controller's Base frame (URDF `base`, turned by pi about
z from `base_link`), joint values as the controller counts them.
"""

from __future__ import annotations

from importlib.metadata import distribution
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

from rworld_cli.api import export_program, import_urdf
from rworld_cli.schema.programs import load_run
from rworld_cli.simulate.engine import simulate
from tests.conftest import urdf_without_meshes
from tests.export import readers

# each run's simulation made once a worker for the same files (tests/conftest.py)
pytestmark = pytest.mark.usefixtures("simulation_once")

SHARE = Path(str(distribution("example-robot-data").locate_file("cmeel.prefix/share")))
UR5 = SHARE / "example-robot-data" / "robots" / "ur_description" / "urdf" / "ur5_robot.urdf"
PROGRAM = """\
device: ur5
units: {length: mm, angle: deg}
steps:
  - move: {to: target, tcp: tip, offset: {xyz: [0, 0, -80]}}
  - move: {to: target, tcp: tip, motion: linear, speed: 0.3}
  - move: {to: target, tcp: tip, offset: {xyz: [40, -30, -60], rpy: [0, 10, 0]}, motion: linear}
"""


@pytest.fixture(scope="module")
def ur5_cell(tmp_path_factory):
    root = tmp_path_factory.mktemp("ur5") / "cell"
    imported = import_urdf(str(UR5), str(root), package_paths=[str(SHARE)])
    assert imported.device == "ur5"
    # a 150 mm tool on the flange
    _prepare(root, 0.15, {"xyz": [0.35, 0.25, 0.3], "rpy": [3.1, 0.1, 0.4]})
    return root


def _prepare(root: Path, tool_length: float, target: dict) -> str:
    """An imported robot made ready for the program: acceleration limits (URDF has none), a
    tool tip on the flange, a target frame; the controller profile as import assumed it."""
    cell = yaml.safe_load((root / "cell.yaml").read_text())
    [device] = cell["devices"]
    assert device["controller"]["flange"] == "tool0" and device["controller"]["base"] == "base"
    for joint in device["joints"]:
        joint["limits"]["acceleration"] = 10.0
    device["tcps"].append({"name": "tip", "parent": "tool0"})
    cell["frames"] = [{"name": "target"}]
    (root / "cell.yaml").write_text(yaml.safe_dump(cell, sort_keys=False))
    poses = yaml.safe_load((root / "poses.yaml").read_text())
    poses["poses"][f"{device['name']}.tip"] = {"xyz": [0.0, 0.0, tool_length]}
    poses["poses"]["target"] = target
    (root / "poses.yaml").write_text(yaml.safe_dump(poses, sort_keys=False))
    (root / "programs").mkdir()
    program = PROGRAM.replace("device: ur5", f"device: {device['name']}")
    (root / "programs" / "pick.yaml").write_text(program)
    return device["name"]


def _pinocchio_tcp(q: np.ndarray) -> np.ndarray:
    """The tool tip in the controller's Base frame (URDF 'base'), by Pinocchio alone."""
    model = pin.buildModelFromUrdf(str(UR5))
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    base = data.oMf[model.getFrameId("base")].homogeneous
    flange = data.oMf[model.getFrameId("tool0")].homogeneous
    tip = np.eye(4)
    tip[2, 3] = 0.15
    return np.linalg.solve(base, flange @ tip)


def test_urscript_targets_are_the_robots_own(ur5_cell, tmp_path):
    out = tmp_path / "out"
    export_program(str(ur5_cell), str(ur5_cell / "programs" / "pick.yaml"), "urscript", str(out))
    text = (out / "pick.script").read_text()
    assert "# tool data in the flange frame: ur5.tool0" in text
    assert "# targets in the base frame: ur5.base" in text
    [tcp] = readers.urscript_tcps(text)
    np.testing.assert_allclose(
        tcp, np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.15], [0, 0, 0, 1]]), atol=1e-9
    )
    result = simulate(
        load_run(str(ur5_cell), str(ur5_cell / "programs" / "pick.yaml")), collisions=False
    )
    moves = [r.move for r in result.resolved["ur5"] if r.move is not None]
    read = readers.urscript(text)
    assert [kind for kind, _ in read] == ["joint", "linear", "linear"]
    for (kind, value), move in zip(read, moves):
        expected = _pinocchio_tcp(move.q_goal)
        if kind == "joint":  # the controller's joint values are the URDF's
            np.testing.assert_allclose(value, move.q_goal, atol=1e-9)
            continue
        assert np.abs(value[:3, 3] - expected[:3, 3]).max() < 1e-5  # 0.01 mm
        angle = np.linalg.norm(pin.log3(value[:3, :3].T @ expected[:3, :3]))
        assert np.degrees(angle) < 1e-3
    # the Base frame is URDF 'base', turned by pi about z: x and y flip against base_link
    first = read[1][1]
    assert first[0, 3] < 0 and first[1, 3] < 0  # the target at (+0.35, +0.25) in base_link


def _with_controller(ur5_cell, tmp_path, controller: dict):
    import shutil

    root = tmp_path / "cell"
    shutil.copytree(ur5_cell, root)
    cell = yaml.safe_load((root / "cell.yaml").read_text())
    cell["devices"][0]["controller"] = controller
    (root / "cell.yaml").write_text(yaml.safe_dump(cell, sort_keys=False))
    return root


def test_the_joint_map_gives_the_controllers_axis_values(ur5_cell, tmp_path):
    axes = [{"sign": -1, "offset": 1.5707963267948966}] + [{}] * 5
    root = _with_controller(ur5_cell, tmp_path, {"flange": "tool0", "base": "base", "axes": axes})
    out = tmp_path / "out"
    export_program(str(root), str(root / "programs" / "pick.yaml"), "urscript", str(out))
    text = (out / "pick.script").read_text()
    assert "# axis values: the cell's joint map (controller.axes)" in text
    result = simulate(load_run(str(root), str(root / "programs" / "pick.yaml")), collisions=False)
    q = next(r.move for r in result.resolved["ur5"] if r.move is not None).q_goal
    [(kind, value)] = readers.urscript(text)[:1]
    assert kind == "joint"
    np.testing.assert_allclose(value, np.concatenate([[np.pi / 2 - q[0]], q[1:]]), atol=1e-9)


@pytest.mark.parametrize(
    "controller, message",
    [
        ({"flange": "tool9"}, "'tool9' is no frame of 'ur5' (did you mean 'ur5.tool0'?)"),
        ({"flange": "base"}, "the flange 'base' must be a frame on the last link"),
        ({"base": "tool0"}, "the base 'tool0' must be a frame fixed to the device's base"),
        ({"axes": [{"sign": 1}]}, "1 axis map(s) for 6 joint(s)"),
    ],
)
def test_a_wrong_controller_profile_is_located(ur5_cell, tmp_path, cli, controller, message):
    root = _with_controller(ur5_cell, tmp_path, controller)
    out = cli(["validate", str(root)])
    assert out.exit_code == 2 and message in out.output and "cell.yaml:" in out.output, out.output


KR16 = Path(__file__).parents[1] / "data" / "kuka_kr16" / "kr16_2.urdf"


@pytest.fixture(scope="module")
def kr16_cell(tmp_path_factory):
    """The KR 16-2 of ROS-Industrial (meshes stripped: not vendored), a 120 mm tool on tool0."""
    root_dir = tmp_path_factory.mktemp("kr16")
    urdf = urdf_without_meshes(KR16, root_dir / "kr16_2.urdf")
    root = root_dir / "cell"
    import_urdf(str(urdf), str(root))
    name = _prepare(root, 0.12, {"xyz": [1.2, 0.3, 0.6], "rpy": [3.0, 0.2, 0.5]})
    return root, name


def test_krl_tool_and_targets_are_kukas_own(kr16_cell, tmp_path):
    """TOOL_DATA relative to $FLANGE (tool0), E6POS in $ROBROOT (base) with A, B, C, E6AXIS the
    URDF's joint values: checked against Pinocchio's forward kinematics of the original URDF."""
    root, name = kr16_cell
    out = tmp_path / "out"
    export_program(str(root), str(root / "programs" / "pick.yaml"), "krl", str(out))
    src, dat = (out / "pick.src").read_text(), (out / "pick.dat").read_text()
    [tool] = readers.krl_tools(src)
    np.testing.assert_allclose(
        tool, np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.12], [0, 0, 0, 1]]), atol=1e-9
    )
    result = simulate(load_run(str(root), str(root / "programs" / "pick.yaml")), collisions=False)
    moves = [r.move for r in result.resolved[name] if r.move is not None]
    model = pin.buildModelFromUrdf(str(KR16))
    data = model.createData()
    read = readers.krl(src, dat)
    assert [kind for kind, _ in read] == ["joint", "linear", "linear"]
    for (kind, value), move in zip(read, moves):
        if kind == "joint":  # KUKA's A1..A6 are the URDF's joint values (in degrees there)
            np.testing.assert_allclose(value, move.q_goal, atol=1e-9)
            continue
        pin.framesForwardKinematics(model, data, move.q_goal)
        base = data.oMf[model.getFrameId("base")].homogeneous
        flange = data.oMf[model.getFrameId("tool0")].homogeneous
        tip = np.eye(4)
        tip[2, 3] = 0.12
        expected = np.linalg.solve(base, flange @ tip)
        assert np.abs(value[:3, 3] - expected[:3, 3]).max() < 1e-5  # 0.01 mm
        assert np.degrees(np.linalg.norm(pin.log3(value[:3, :3].T @ expected[:3, :3]))) < 1e-3
