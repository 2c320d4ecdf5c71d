"""Per vendor, a robot from the vendor's ROS description package, imported as users do, with a
tool on its flange, joint and linear moves and a user frame: every target the exported program
holds is read back by the independent readers (tests/export/readers.py: regex and scipy) and
checked against Pinocchio's forward kinematics of the original URDF in the controller's own
conventions - flange `tool0`, base `base`, UR rotation vector, KUKA A B C, ABB quaternion,
FANUC W P R, mm and degrees, the controller's axis values (ABB's and FANUC's J2-J3 linkage, as
ROS-Industrial's drivers convert them) - and configuration data consistent with the solution.
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

DATA = Path(__file__).parents[1] / "data"
REPO = Path(__file__).parents[2]
SHARE = Path(str(distribution("example-robot-data").locate_file("cmeel.prefix/share")))


def _undo_linkage(axes: np.ndarray, vendor: str) -> np.ndarray:
    """The URDF's joint values of the controller's axis values, as ROS-Industrial's state
    relays compute them: ``J3 = J3' + factor J2'`` with factor -1 for the coupled ABB arms
    (abb_driver, J23_coupled) and +1 for FANUC (fanuc_driver, J23_factor 1)."""
    q = np.array(axes, dtype=float)
    factor = {"abb": -1.0, "fanuc": 1.0}.get(vendor, 0.0)
    q[2] = q[2] + factor * q[1]
    return q


# name: (URDF, format, vendor, a target for the tool tip (world = base_link), the user frame)
VENDORS = {
    "ur5": (
        SHARE / "example-robot-data" / "robots" / "ur_description" / "urdf" / "ur5_robot.urdf",
        "urscript",
        "ur",
        {"xyz": [0.35, 0.25, 0.3], "rpy": [3.1, 0.1, 0.4]},
    ),
    "kr16": (
        DATA / "kuka_kr16" / "kr16_2.urdf",
        "krl",
        "kuka",
        {"xyz": [1.2, 0.3, 0.6], "rpy": [3.0, 0.2, 0.5]},
    ),
    "irb2400": (
        DATA / "abb_irb2400" / "irb2400.urdf",
        "rapid",
        "abb",
        {"xyz": [1.0, 0.25, 0.6], "rpy": [3.0, 0.15, 0.4]},
    ),
    "lrmate200id": (
        DATA / "fanuc_lrmate200id" / "lrmate200id.urdf",
        "fanuc",
        "fanuc",
        {"xyz": [0.45, 0.1, 0.25], "rpy": [3.0, 0.1, 0.3]},
    ),
    "gp7": (  # the vendor's xacro, expanded as import does (ros-industrial/motoman)
        DATA / "motoman" / "motoman_gp7_support" / "urdf" / "gp7.xacro",
        "inform",
        "yaskawa",
        {"xyz": [0.5, 0.1, 0.3], "rpy": [3.0, 0.1, 0.3]},
    ),
    "m1013": (  # doosan-robotics/doosan-robot2: no tool0, the flange is link6
        DATA / "doosan" / "dsr_description2" / "urdf" / "m1013.white.urdf",
        "drl",
        "doosan",
        {"xyz": [0.7065, 0.1407, 0.1154], "rpy": [-3.1412, -0.2002, -3.0673]},
    ),
    "iiwa14": (  # ros-industrial/kuka_experimental: the 7-axis LBR, KUKA Sunrise
        DATA / "kuka_iiwa" / "kuka_lbr_iiwa_support" / "urdf" / "lbr_iiwa_14_r820.xacro",
        "sunrise",
        "kuka_sunrise",
        {"xyz": [0.55, 0.1, 0.3], "rpy": [3.0, 0.1, 0.3]},
    ),
    "tx2_60": (  # ros-industrial/staubli_experimental
        DATA / "staubli" / "staubli_tx2_60_support" / "urdf" / "tx2_60.xacro",
        "val3",
        "staubli",
        {"xyz": [0.45, 0.1, 0.25], "rpy": [3.0, 0.1, 0.3]},
    ),
}
PACKAGES = {  # what a xacro finds
    "gp7": DATA / "motoman",
    "tx2_60": DATA / "staubli",
    "iiwa14": DATA / "kuka_iiwa",
}
FLANGE = {"m1013": "link6"}  # the controller's flange where the URDF has no tool0
HOME = {"m1013": [0.0, 0.35, 1.75, 0.0, 1.05, 0.0]}  # its zero pose is straight up: singular
TIP = {"xyz": [0.01, -0.02, 0.12], "rpy": [0.0, 0.2, 0.1]}  # the tool on tool0 [m, rad]
USER = {"xyz": [0.3, -0.2, 0.1], "rpy": [0.0, 0.0, 0.5]}  # the user frame "fixture"
PROGRAM = """\
device: {device}
units: {{length: mm, angle: deg}}
steps:
  - move: {{to: target, tcp: tip, offset: {{xyz: [0, 0, -80]}}, config: {{elbow: up}}}}
  - move: {{to: target, tcp: tip, motion: linear, speed: 0.3}}
  - move: {{to: target, tcp: tip, offset: {{xyz: [40, -30, -60], rpy: [0, 10, 0]}}, motion: linear}}
  - move: {{to: target, tcp: tip, offset: {{xyz: [0, 0, -100]}}, config: {{wrist: flip}}}}
  - move: {{to: target, tcp: tip, offset: {{xyz: [0, 30, -100]}}, motion: linear}}
"""
PROGRAM_7 = PROGRAM.replace("config: {{elbow: up}}", "config: {{arm_angle: 30deg}}").replace(
    "config: {{wrist: flip}}", "config: {{arm_angle: -45deg}}"
)  # a 7-axis arm: its arm angle (shoulder, elbow and wrist name a 6-axis arm's solutions)
ARM_ANGLES = [30.0, None, None, -45.0, None]  # [deg] asked of each move


def _T(pose: dict) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = pin.rpy.rpyToMatrix(*pose.get("rpy", [0, 0, 0]))
    T[:3, 3] = pose["xyz"]
    return T


@pytest.fixture(scope="module", params=list(VENDORS))
def vendor_cell(request, tmp_path_factory):
    """The vendor's robot (meshes stripped: not vendored) with a tool, a target, a user frame
    and the program, as import left it plus what a user adds."""
    key = request.param
    urdf_path, fmt, vendor, target = VENDORS[key]
    folder = tmp_path_factory.mktemp(key)
    if urdf_path.suffix == ".xacro":  # expanded to URDF, for Pinocchio and for import
        from rworld_cli.schema.urdf import expand_xacro

        expanded = folder / (urdf_path.stem + "_expanded.urdf")
        expanded.write_bytes(expand_xacro(urdf_path, urdf_path.name, [PACKAGES[key]]))
        urdf_path = expanded
    urdf = urdf_without_meshes(urdf_path, folder / urdf_path.name)
    root = folder / "cell"
    imported = import_urdf(str(urdf), str(root))
    cell = yaml.safe_load((root / "cell.yaml").read_text())
    [device] = cell["devices"]
    assert device["controller"]["vendor"] == vendor
    if key not in FLANGE:
        assert device["controller"]["flange"] == "tool0"
        assert device["controller"]["base"] == "base"
    for joint in device["joints"]:
        joint["limits"]["acceleration"] = 10.0
    device["tcps"].append({"name": "tip", "parent": FLANGE.get(key, "tool0")})
    if key in HOME:
        device["home"] = HOME[key]
    if key == "m1013":  # the URDF gives every joint +-150 deg; axes 4 and 6 turn a full turn
        for j in (3, 5):  # and more, which the wrist flip the program asks for needs
            device["joints"][j]["limits"]["position"] = [-6.283, 6.283]
    cell["frames"] = [{"name": "target"}, {"name": "fixture"}]
    (root / "cell.yaml").write_text(yaml.safe_dump(cell, sort_keys=False))
    poses = yaml.safe_load((root / "poses.yaml").read_text())
    poses["poses"][f"{imported.device}.tip"] = TIP
    poses["poses"]["target"] = target
    poses["poses"]["fixture"] = USER
    (root / "poses.yaml").write_text(yaml.safe_dump(poses, sort_keys=False))
    (root / "programs").mkdir()
    text = PROGRAM_7 if fmt == "sunrise" else PROGRAM
    (root / "programs" / "pick.yaml").write_text(text.format(device=imported.device))
    return key, root, imported.device, urdf


def _pinocchio(urdf: Path, q: np.ndarray) -> np.ndarray:
    """The tool tip in the controller's base frame (URDF 'base'), by Pinocchio alone."""
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    base = data.oMf[model.getFrameId("base")].homogeneous
    flange_frame = "tool0" if model.existFrame("tool0") else "link6"
    flange = data.oMf[model.getFrameId(flange_frame)].homogeneous
    return np.linalg.solve(base, flange @ _T(TIP))


def _geometry(urdf: Path, q: np.ndarray) -> tuple[bool, bool]:
    """(wrist centre in front of axis 1, elbow up) by Pinocchio's joint placements: the wrist
    centre is joint 5's origin; seen in the frame that turns with joint 1 (x forward, z up), the
    elbow is up when joint 3 lies above the line from joint 2 to the wrist centre."""
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    frame1 = data.oMi[1]
    P2, P3, W = (frame1.actInv(data.oMi[k]).translation for k in (2, 3, 5))
    a, b = W - P2, P3 - P2
    return bool(W[0] >= 0), bool(a[0] * b[2] - a[2] * b[0] > 0)


def _read(fmt: str, out: Path) -> tuple[list, list]:
    if fmt == "urscript":
        text = (out / "pick.script").read_text()
        return readers.urscript(text), readers.urscript_tcps(text)
    if fmt == "krl":
        src, dat = (out / "pick.src").read_text(), (out / "pick.dat").read_text()
        return readers.krl(src, dat), readers.krl_tools(src)
    if fmt == "rapid":
        text = (out / "pick.mod").read_text()
        return readers.rapid(text), readers.rapid_tools(text)
    if fmt == "inform":
        text = (out / "PICK.JBI").read_text()
        return readers.inform(text), readers.inform_tools(text)
    if fmt == "val3":
        dtx, pgx = (out / "pick" / "pick.dtx").read_text(), (out / "pick" / "start.pgx").read_text()
        return readers.val3(dtx, pgx), readers.val3_tools(dtx)
    if fmt == "drl":
        text = (out / "pick.drl").read_text()
        return readers.drl(text), readers.drl_tools(text)
    if fmt == "sunrise":
        text = (out / "Pick.java").read_text()
        return readers.sunrise(text), readers.sunrise_tools(text)
    text = (out / "PICK.ls").read_text()
    return readers.fanuc(text), readers.fanuc_tools(text)


def test_every_target_is_the_robots_own(vendor_cell, tmp_path):
    key, root, device, urdf = vendor_cell
    _, fmt, vendor, _ = VENDORS[key]
    out = tmp_path / "out"
    result_export = export_program(
        str(root), str(root / "programs" / "pick.yaml"), None, str(out), frame="fixture"
    )
    assert result_export.format == fmt  # the controller's vendor picks the language
    read, tools = _read(fmt, out)
    np.testing.assert_allclose(tools[0], _T(TIP), atol=1e-6)  # tool data in tool0
    result = simulate(load_run(str(root), str(root / "programs" / "pick.yaml")), collisions=False)
    moves = [r.move for r in result.resolved[device] if r.move is not None]
    assert [kind for kind, _ in read] == ["joint", "linear", "linear", "joint", "linear"]
    worst = {"mm": 0.0, "deg": 0.0, "joint deg": 0.0}
    for (kind, value), move in zip(read, moves):
        if kind == "joint" and value.shape == (4, 4):
            pass  # a joint move to a Cartesian position (INFORM without pulses): the pose
        elif kind == "joint":  # the controller's axes, back through the driver's linkage
            q = _undo_linkage(value, vendor)
            worst["joint deg"] = max(worst["joint deg"], np.degrees(np.abs(q - move.q_goal)).max())
            value = _pinocchio(urdf, q)
        expected = _pinocchio(urdf, move.q_goal)
        worst["mm"] = max(worst["mm"], 1000 * np.abs(value[:3, 3] - expected[:3, 3]).max())
        angle = np.degrees(np.linalg.norm(pin.log3(value[:3, :3].T @ expected[:3, :3])))
        worst["deg"] = max(worst["deg"], angle)
    print(f"{key}: {worst}")  # pytest -s
    assert worst["mm"] < 0.01 and worst["deg"] < 0.001 and worst["joint deg"] < 1e-6, worst


def test_configuration_data_is_the_solutions(vendor_cell, tmp_path):
    """RAPID confdata, KRL Status and Turn, FANUC CONFIG: consistent with the joint solution
    each target was reached with (Pinocchio's geometry, the controller's axis values); the
    step's config (elbow up, then wrist flip) is the solution taken."""
    key, root, device, urdf = vendor_cell
    _, fmt, vendor, _ = VENDORS[key]
    out = tmp_path / "out"
    export_program(str(root), str(root / "programs" / "pick.yaml"), fmt, str(out))
    result = simulate(load_run(str(root), str(root / "programs" / "pick.yaml")), collisions=False)
    moves = [r.move for r in result.resolved[device] if r.move is not None]
    if fmt == "sunrise":  # the 7-axis LBR: its arm angle, E1, Status and Turn
        _check_lbr(urdf, out, moves)
        return
    # the controller's axes [deg]: the inverse of the driver's relay
    factor = {"abb": 1.0, "fanuc": -1.0}.get(vendor, 0.0)
    axes = []
    for m in moves:
        a = m.q_goal.copy()
        a[2] = m.q_goal[2] + factor * m.q_goal[1]
        axes.append(np.degrees(a))
    geometry = [_geometry(urdf, m.q_goal) for m in moves]
    assert geometry[0][1]  # config: {elbow: up}
    # config: {wrist: flip}: axis 5 turned against the noflip sense (KUKA A5 < 0, ABB axis 5 < 0,
    # FANUC J5 > 0: the tool bent up from a forearm reaching forward)
    flip_sign = {
        "kuka": -1,
        "abb": -1,
        "fanuc": 1,
        "ur": None,
        "yaskawa": 1,
        "staubli": None,
        "doosan": None,
    }[vendor]
    if flip_sign is not None:
        assert np.sign(axes[3][4]) == flip_sign
    if fmt == "rapid":
        text = (out / "pick.mod").read_text()
        for cf, a, (front, up) in zip(readers.rapid_configurations(text), axes, geometry):
            quarters = [int(np.floor(a[i] / 90.0)) for i in (0, 3, 5)]
            cfx = 4 * (not front) + 2 * (not up) + (a[4] < 0)
            assert cf == quarters + [cfx]
    elif fmt == "krl":
        dat = (out / "pick.dat").read_text()
        import re

        found = [tuple(map(int, st)) for st in re.findall(r"S (\d+), T (\d+)", dat)]
        linear = [(a, g) for a, g, m in zip(axes, geometry, moves) if m.motion == "linear"]
        assert len(found) == len(linear) == 3
        for (status, turn), (a, (front, up)) in zip(found, linear):
            assert status == (not front) + 2 * up + 4 * (a[4] <= 0)
            assert turn == sum(1 << i for i in range(6) if a[i] < 0)
    elif fmt == "inform":
        text = (out / "PICK.JBI").read_text()
        configs = readers.inform_configurations(text)
        assert len(configs) == len(moves) == 5
        for config, a, (front, up) in zip(configs, axes, geometry):
            flip, lower, rear, r180, t180, s180, *_ = config
            assert flip == int(a[4] < 0)  # 0: flip (B > 0, as config wrist: flip gives it)
            assert lower == int(not up) and rear == int(not front)
            assert [r180, t180, s180] == [int(abs(a[i]) >= 180) for i in (3, 5, 0)]
    elif fmt == "val3":
        dtx, pgx = (out / "pick" / "pick.dtx").read_text(), (out / "pick" / "start.pgx").read_text()
        linear = [(a, g) for a, g, m in zip(axes, geometry, moves) if m.motion == "linear"]
        shapes = readers.val3_configurations(dtx, pgx)
        assert len(shapes) == len(linear) == 3
        for shape, (a, (front, up)) in zip(shapes, linear):
            assert shape["shoulder"] == ("righty" if front else "lefty")
            assert shape["elbow"] == ("epositive" if a[2] >= 0 else "enegative")
            assert shape["wrist"] == ("wpositive" if a[4] >= 0 else "wnegative")
    elif fmt == "drl":
        import re

        text = (out / "pick.drl").read_text()
        sols = [int(k) for k in re.findall(r"# sol (\d)$", text, re.M)]
        linear = [(a, g) for a, g, m in zip(axes, geometry, moves) if m.motion == "linear"]
        assert len(sols) == len(linear) == 3
        for sol, (a, (front, up)) in zip(sols, linear):
            assert sol >> 2 == int(not front) and (sol >> 1) & 1 == int(not up)
        # the wrist bit: the linear moves keep the joint move's before them - not flipped
        # after the first, flipped after 'config: {wrist: flip}' (with axis 4 free over a
        # turn, axis 5's sign alone does not tell)
        assert [sol & 1 for sol in sols] == [0, 0, 1]
    elif fmt == "fanuc":
        text = (out / "PICK.ls").read_text()
        linear = [(a, g) for a, g, m in zip(axes, geometry, moves) if m.motion == "linear"]
        configs = readers.fanuc_configurations(text)
        assert len(configs) == len(linear) == 3
        for config, (a, (front, up)) in zip(configs, linear):
            letters, *turns = [part.strip() for part in config.split(",")]
            flip, elbow, side = letters.split()
            assert flip == ("F" if a[4] > 0 else "N")
            assert elbow == ("U" if up else "D") and side == ("T" if front else "B")
            # the turn number k: -180 < angle - 360 k <= 180
            assert [int(t) for t in turns] == [int(np.ceil((a[i] - 180) / 360)) for i in (3, 4, 5)]


def _arm_angle_by_pinocchio(urdf: Path, q: np.ndarray) -> float:
    """The arm angle of an LBR state by Pinocchio's joint placements alone: S at joint 2's
    origin, E at joint 4's, W at joint 6's (where the LBR's axes meet); the turn of the plane
    S, E, W about S -> W from the vertical plane through S -> W [deg]."""
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    S, E, W = (data.oMi[k].translation for k in (2, 4, 6))
    axis = (W - S) / np.linalg.norm(W - S)
    up = np.array([0.0, 0.0, 1.0]) - axis[2] * axis
    elbow = (E - S) - ((E - S) @ axis) * axis
    return float(np.degrees(np.arctan2(np.cross(up, elbow) @ axis, up @ elbow)))


def _check_lbr(urdf: Path, out: Path, moves) -> None:
    """The joint moves took the arm angles asked (Pinocchio's geometry); each Cartesian
    frame's E1 is axis A3, its Status and Turn the solution's (A4 < 0, A6 <= 0, the axes'
    signs)."""
    for asked, move in zip(ARM_ANGLES, moves):
        if asked is not None:
            assert abs(_arm_angle_by_pinocchio(urdf, move.q_goal) - asked) < 1e-6
    text = (out / "Pick.java").read_text()
    linear = [m for m in moves if m.motion == "linear"]
    redundancy = readers.sunrise_redundancy(text)
    assert len(redundancy) == len(linear) == 3
    for (e1, status, turn), move in zip(redundancy, linear):
        q = move.q_goal
        assert abs(e1 - q[2]) < 1e-9
        assert (status >> 1) & 1 == int(q[3] < 0) and (status >> 2) & 1 == int(q[5] <= 0)
        assert turn == sum(1 << i for i in range(7) if q[i] < 0)


def test_import_states_the_vendors_linkage():
    """What import assumed, per ROS-Industrial's drivers: ABB's coupled IRB 2400 adds joint 2 to
    axis 3, FANUC subtracts it; KUKA and UR are uncoupled."""
    from rworld_cli.schema.urdf_vendors import vendor_conventions

    assert vendor_conventions("abb_irb2400") == ("abb", 1.0)
    assert vendor_conventions("abb_irb4600_60_205") == ("abb", None)
    assert vendor_conventions("fanuc_lrmate200id") == ("fanuc", -1.0)
    assert vendor_conventions("fanuc_m430ia2f") == ("fanuc", 1.0)
    assert vendor_conventions("kuka_kr16_2") == ("kuka", None)
    assert vendor_conventions("ur5") == ("ur", None)
    assert vendor_conventions("my_robot") == (None, None)


@pytest.mark.parametrize(
    "step, code, message",
    [
        ("{to: ready, config: {elbow: up}}", 2, "'ready' is a joint position"),
        ("{to: workpiece.grasp, tcp: probe, config: {near: [0, 0, 0]}}", 2, "3 value(s) for the 6"),
        ("{to: workpiece.grasp, tcp: probe, config: {elbow: sideways}}", 2, "'up' or 'down'"),
        (
            "{to: workpiece.grasp, tcp: probe, motion: linear, config: {near: [0, 0, 0, 0, 0, 0]}}",
            2,
            "'near' is for joint moves",
        ),
        (
            "{to: workpiece.grasp, tcp: probe, offset: {xyz: [0, 0, -100]}, config: {wrist: flip}}",
            1,
            "with wrist flip (one with shoulder front, elbow up, wrist noflip does)",
        ),
    ],
)
def test_a_configuration_that_cannot_be_is_located(tmp_path, cli, step, code, message):
    """Bad config: exit 2 at its line; one no solution within the limits has (the Puma's
    joint 4 spans 280 deg: no flip here) fails the check, exit 1, naming the step and the
    configuration that reaches, as 'check' does for every unreachable target."""
    import shutil

    from tests.conftest import WORKCELLS

    cell = tmp_path / "puma"
    shutil.copytree(WORKCELLS / "puma560", cell)
    program = cell / "programs" / "config.yaml"
    program.write_text(
        "device: puma\nunits: {length: mm, angle: deg}\nsteps:\n  - move: {to: ready}\n"
        f"  - move: {step}\n"
    )
    out = cli(["check", str(cell), str(program)])
    assert out.exit_code == code, out.output
    assert message in out.output and "config.yaml:5" in out.output, out.output


def test_inform_writes_joint_targets_in_pulses_when_the_cell_gives_them(vendor_cell, tmp_path):
    """With ``controller.pulses_per_degree`` and ``zero_pulse`` (robot parameters read off
    the controller; here plausible values), an INFORM job's joint moves go to pulse
    positions: read back through those parameters, each is the simulation's joint solution to
    half a pulse, and Pinocchio puts the tool where the Cartesian moves say."""
    import shutil

    key, root, device, urdf = vendor_cell
    if key != "gp7":
        pytest.skip("INFORM: the Yaskawa robot")
    cell_root = tmp_path / "cell"
    shutil.copytree(root, cell_root)
    cell = yaml.safe_load((cell_root / "cell.yaml").read_text())
    pulses = [1456.0, 1456.0, 1210.0, 820.0, 820.0, 520.0]
    zero = [0, 0, 0, 12000, 0, -3000]
    cell["devices"][0]["controller"]["pulses_per_degree"] = pulses
    cell["devices"][0]["controller"]["zero_pulse"] = zero
    (cell_root / "cell.yaml").write_text(yaml.safe_dump(cell, sort_keys=False))
    out = tmp_path / "out"
    program = str(cell_root / "programs" / "pick.yaml")
    export_program(str(cell_root), program, None, str(out), frame="fixture")
    text = (out / "PICK.JBI").read_text()
    assert "///POSTYPE PULSE" in text
    read = readers.inform(text, pulses, zero)
    result = simulate(load_run(str(cell_root), program), collisions=False)
    moves = [r.move for r in result.resolved[device] if r.move is not None]
    assert [kind for kind, _ in read] == ["joint", "linear", "linear", "joint", "linear"]
    for (kind, value), move in zip(read, moves):
        if kind == "joint":
            assert value.shape == (6,)
            assert np.degrees(np.abs(value - move.q_goal)).max() <= 0.5 / min(pulses) + 1e-12
            value = _pinocchio(urdf, value)
        expected = _pinocchio(urdf, move.q_goal)
        assert 1000 * np.abs(value[:3, 3] - expected[:3, 3]).max() < 0.01


@pytest.mark.parametrize(
    "name, vendor",
    [
        ("motoman_gp7", "yaskawa"),
        ("motoman_mh5", "yaskawa"),
        ("staubli_tx2_60", "staubli"),
        ("tx60l", "staubli"),
        ("kuka_lbr_iiwa_14_r820", "kuka_sunrise"),
        ("lbr_med7", "kuka_sunrise"),
        ("kuka_kr16_2", "kuka"),
        ("m1013", "doosan"),
        ("fanuc_m2000ia", "fanuc"),
        ("m2000ia", "fanuc"),
        ("abb_irb2400", "abb"),
        # issue 62: the vendors' own package and model names
        ("abb_crb15000_5_95", "abb"),
        ("gofa", "abb"),
        ("yumi", "abb"),
        ("crx10ial", "fanuc"),
        ("fanuc_crx10ial", "fanuc"),
        ("motoman_hc10", "yaskawa"),
        ("hc10dt", "yaskawa"),
        ("ur", "ur"),
        ("ur20", "ur"),
        ("gen3", "kinova"),
        ("kinova_gen3_lite", "kinova"),
        ("vs060", "denso"),
        ("denso_cobotta", "denso"),
        ("epson_vt6", "epson"),
        ("fr3", "franka"),
        ("my_robot", None),
    ],
)
def test_import_names_the_vendor_families(name, vendor):
    from rworld_cli.schema.urdf_vendors import vendor_conventions

    assert vendor_conventions(name)[0] == vendor


def test_a_vendor_is_read_from_the_package_when_the_name_says_nothing():
    """A robot named 'robot' in abb_crb15000_support (or fanuc_crx10ia_support) is ABB's (or
    FANUC's, with its J2-J3 factor); the CRX's coupling is the other FANUCs' (its streaming
    launch files' J23_factor 1)."""
    from rworld_cli.schema.urdf_vendors import vendor_conventions

    assert vendor_conventions("robot", "abb_crb15000_support") == ("abb", None)
    assert vendor_conventions("robot", "fanuc_crx10ia_support") == ("fanuc", -1.0)
    assert vendor_conventions("robot", "my_robot_description") == (None, None)


def test_an_import_without_a_vendor_says_so(tmp_path, cli):
    """A URDF whose name and package name no vendor: the import warns, naming both and the
    way on ('export program' needs --format, or controller.vendor in cell.yaml)."""
    (tmp_path / "arm").mkdir()
    (tmp_path / "arm" / "package.xml").write_text("<package><name>arm</name></package>\n")
    urdf = tmp_path / "arm" / "my_arm.urdf"
    urdf.write_text(
        '<robot name="my_arm"><link name="base"/><link name="l1"/>'
        '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>'
        '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>'
    )
    result = cli(["import", "urdf", str(urdf), "-o", str(tmp_path / "cell")])
    assert result.exit_code == 0, result.output
    assert (
        "warning: controller: no controller vendor recognised from the robot's name 'my_arm' "
        "or its package 'arm': 'export program' then needs --format"
    ) in result.output


def test_a_vendor_without_a_language_is_refused_with_the_reason(tmp_path, cli):
    """A Franka Panda (driven through libfranka: no program file) exported without --format:
    exit 2, saying so and that csv streams it; nothing written.  With --format krl: the
    7-axis arm is refused, pointing at csv and at Sunrise."""
    import shutil

    cell = tmp_path / "panda"
    shutil.copytree(REPO / "workcells" / "panda", cell)
    text = (cell / "cell.yaml").read_text()
    assert "controller:" not in text
    doc = yaml.safe_load(text)
    doc["devices"][0]["controller"] = {"vendor": "franka"}
    (cell / "cell.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    out = tmp_path / "out"
    result = cli(["export", "program", str(cell), "pick_place", "-o", str(out)])
    assert result.exit_code == 2
    assert "franka controller" in result.stderr and "--format csv" in result.stderr
    krl = cli(["export", "program", str(cell), "pick_place", "--format", "krl", "-o", str(out)])
    assert krl.exit_code == 2 and "--format sunrise (a 7-axis KUKA LBR)" in krl.stderr
    assert not out.exists()


def test_pulses_per_axis_are_one_per_joint(tmp_path, cli):
    import shutil

    cell = tmp_path / "gp7"
    shutil.copytree(DATA / "vendor_cells" / "gp7", cell)
    text = (cell / "cell.yaml").read_text()
    (cell / "cell.yaml").write_text(
        text.replace(
            "    vendor: yaskawa\n", "    vendor: yaskawa\n    pulses_per_degree: [1, 2]\n"
        )
    )
    result = cli(["validate", str(cell)])
    assert result.exit_code == 2
    assert "pulses_per_degree: 2 value(s) for 6 joint(s): one per axis" in result.output


@pytest.mark.parametrize(
    "cell, target, config, message",
    [
        (
            "workcells/puma560",
            "workpiece.grasp, tcp: probe",
            "{arm_angle: 30deg}",
            "arm_angle is a 7-axis arm's; 'puma' has 6 joint(s)",
        ),
        ("tests/data/vendor_cells/iiwa14", "table.top_center", "{arm_angle: 30}", "no unit"),
        (
            "tests/data/vendor_cells/iiwa14",
            "table.top_center",
            "{arm_angle: 30 parsecs}",
            "is not an angle",
        ),
        (
            "tests/data/vendor_cells/iiwa14",
            "table.top_center, motion: linear",
            "{arm_angle: 30deg}",
            "'arm_angle' is for joint moves",
        ),
    ],
)
def test_an_arm_angle_that_cannot_be_is_located(tmp_path, cli, cell, target, config, message):
    import shutil

    folder = tmp_path / "cell"
    shutil.copytree(REPO / cell, folder)
    device = yaml.safe_load((folder / "cell.yaml").read_text())["devices"][0]["name"]
    program = folder / "programs" / "angle.yaml"
    program.write_text(f"device: {device}\nsteps:\n  - move: {{to: {target}, config: {config}}}\n")
    result = cli(["check", str(folder), str(program)])
    assert result.exit_code == 2, result.output
    assert "angle.yaml:3" in result.output and message in result.output, result.output


def test_configuration_fields_are_those_of_the_joint_values_as_written(vendor_cell, tmp_path):
    """Issue 62: an axis at -5.6e-14 rad was written 0 in RAPID's jointtarget and quadrant -1
    in its confdata - the file disagreed with itself.  Every language's configuration fields
    now come from the joint values as written: a move to joints whose axes 1, 4, 5 and 6 sit
    a rounding below 0 (and a linear move back there) exports confdata [0,0,0,...] in RAPID,
    KUKA's Turn without those axes' bits, FANUC's turn numbers 0 and 'F'/'N' by the written J5,
    the LBR's Turn likewise."""
    import re

    from rworld_cli.kinematics.configuration import (
        abb_confdata,
        as_written,
        fanuc_config,
        kuka_status_turn,
    )

    tiny = -5.6e-14
    axes = np.array(
        [tiny, 0.3, 0.4, tiny, tiny, tiny, tiny][: 7 if "iiwa" in vendor_cell[0] else 6]
    )
    assert abb_confdata(axes, None)[:3] == [-1, -1, -1]  # what the raw values say
    written = as_written(axes, 9)
    assert list(written[[0, 3, 4, 5]]) == [0.0] * 4 and not np.signbit(written).any()
    assert abb_confdata(written, None) == [0, 0, 0, 0]
    assert kuka_status_turn(written, None)[1] == 0
    assert fanuc_config(as_written(axes, 6), None) == "N U T, 0, 0, 0"
    key, root, device, _ = vendor_cell
    fmt = VENDORS[key][1]
    if fmt != "rapid":
        return
    degrees = ", ".join(repr(float(np.degrees(a))) for a in axes)
    program = root / "programs" / "tiny.yaml"
    program.write_text(
        f"device: {device}\nunits: {{angle: deg}}\nsteps:\n  - move: {{joints: [{degrees}]}}\n"
    )
    out = tmp_path / "out"
    export_program(str(root), str(program), fmt, str(out))
    text = (out / "tiny.mod").read_text()
    joints = re.search(r"CONST jointtarget j\d+ := \[\[([^\]]*)\]", text).group(1).split(",")
    cf = re.search(r"CONST robtarget p\d+ := \[\[[^\]]*\],\[[^\]]*\],\[([^\]]*)\]", text)
    confdata = cf.group(1).split(",")
    assert joints[0] == "0" and joints[3:6] == ["0", "0", "0"]
    assert confdata == ["0", "0", "0", "0"], text
