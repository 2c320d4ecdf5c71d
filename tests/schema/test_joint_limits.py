"""Vendors' joint-limits files read as they ship (issue 62): UR's with xacro's `!degrees`
tags, Kinova's driver lists (`joint_names` with `$(arg prefix)`), Kinova's MoveIt file that
also names the gripper's joint (said where the file names it, and skipped), Franka's
per-joint `limit:` mappings.  Files in tests/data/joint_limits (SOURCE.md) and
tests/data/universal_robots."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rworld_cli.errors import UserError
from rworld_cli.schema.loader import load_cell
from rworld_cli.schema.urdf import read_joint_limits
from rworld_cli.schema.yamlio import parse_yaml_text
from tests.conftest import REPO

DATA = REPO / "tests" / "data"
LIMITS = DATA / "joint_limits"
UR = DATA / "universal_robots"
GEN3 = DATA / "probe_robots" / "gen3"


def test_ur20_limits_with_degrees_tags_import_in_si(cli, tmp_path):
    """UR's config/ur20/joint_limits.yaml (`max_velocity: !degrees 120.0`) was refused with 18
    errors; read as xacro reads it, the velocities are radians per second."""
    limits = UR / "ur_description" / "config" / "ur20" / "joint_limits.yaml"
    cell = tmp_path / "ur20"
    result = cli(
        ["import", "urdf", str(UR / "ur_description" / "urdf" / "ur.urdf.xacro")]
        + ["--package-path", str(UR), "--xacro-arg", "ur_type:=ur20", "--xacro-arg", "name:=ur20"]
        + ["--joint-limits", str(limits), "-o", str(cell)]
    )
    assert result.exit_code == 0, result.output
    [device] = load_cell(str(cell)).cell.devices.values()
    degrees = [120.0, 120.0, 150.0, 210.0, 210.0, 210.0]  # the file's, per joint
    np.testing.assert_allclose(device.limit_array("velocity"), np.radians(degrees), rtol=1e-15)
    assert list(device.limit_array("effort")) == [738.0, 738.0, 433.0, 107.0, 107.0, 107.0]


def test_unit_tags_are_numbers_and_arithmetic_only():
    doc = parse_yaml_text(
        "a: !degrees 90\nb: !radians pi/2\nc: !millimeters -2.5\nd: !degrees (1+2)*30\n",
        "x.yaml",
        ros_units=True,
    )
    assert doc.data["a"] == doc.data["b"] == math.pi / 2
    assert doc.data["c"] == -0.0025 and doc.data["d"] == math.pi / 2
    for text in ("!degrees __import__('os').getcwd()", "!degrees 1/0", "!radians [1]"):
        with pytest.raises(UserError) as caught:
            parse_yaml_text(f"a: {text}\n", "x.yaml", ros_units=True)
        assert caught.value.issues[0].format().startswith("x.yaml:1:4: a: !")
    with pytest.raises(UserError) as caught:
        parse_yaml_text("a: !degrees 90\n", "x.yaml")  # rworld's own files: no such tags
    assert "constructor for the tag '!degrees'" in caught.value.issues[0].message


def test_a_joint_the_robot_lacks_is_named_with_the_nearest_it_has(cli, tmp_path):
    motoman = DATA / "motoman"
    limits = tmp_path / "joint_limits.yaml"
    limits.write_text(
        "joint_limits:\n  joint_1_x: {has_acceleration_limits: true, max_acceleration: 5}\n"
    )
    result = cli(
        ["import", "urdf", str(motoman / "motoman_gp7_support" / "urdf" / "gp7.xacro")]
        + ["--package-path", str(motoman), "-o", str(tmp_path / "c"), "--joint-limits", str(limits)]
    )
    assert result.exit_code == 0, result.output
    assert (
        f"{limits}:2:3: warning: joint_1_x: the joint limits name 'joint_1_x', a joint the robot "
        "does not have (did you mean 'joint_1_s'?): skipped"
    ) in result.output


@pytest.fixture(scope="module")
def gen3_urdf(tmp_path_factory):
    """The Gen3 as imported from Kinova's package (tests/data/probe_robots/gen3), out to
    URDF: joints joint_1 ... joint_7, as the vendor's files name them."""
    from rworld_cli.api import export_urdf

    path = tmp_path_factory.mktemp("gen3") / "gen3.urdf"
    export_urdf(str(GEN3), str(path), None)
    return path


def test_kinova_driver_lists_give_velocities_and_accelerations(cli, tmp_path, gen3_urdf):
    """kortex_description's joint_limits.yaml: `joint_names` ($(arg prefix) empty unless
    given), `maximum_velocities`, `maximum_accelerations` (was: "no 'joint_limits:'
    section")."""
    read = read_joint_limits(LIMITS / "kinova" / "gen3_7dof_joint_limits.yaml")
    assert read.form == "lists" and list(read.limits) == [f"joint_{k}" for k in range(1, 8)]
    assert read.marks["joint_3"][1:] == (4, 5)  # the name's line and column
    cell = tmp_path / "gen3"
    result = cli(
        ["import", "urdf", str(gen3_urdf), "-o", str(cell)]
        + ["--joint-limits", str(LIMITS / "kinova" / "gen3_7dof_joint_limits.yaml")]
    )
    assert result.exit_code == 0, result.output
    assert "no acceleration limit" not in result.output
    [device] = load_cell(str(cell)).cell.devices.values()
    assert list(device.limit_array("velocity")) == [0.8727] * 7
    assert list(device.limit_array("acceleration")) == [1.0] * 4 + [10.0] * 3
    prefixed = read_joint_limits(
        LIMITS / "kinova" / "gen3_7dof_joint_limits.yaml", {"prefix": "left_"}
    )
    assert list(prefixed.limits)[0] == "left_joint_1"


def test_a_moveit_file_naming_the_grippers_joint_warns_there_and_imports(cli, tmp_path, gen3_urdf):
    """Kinova's MoveIt joint_limits.yaml names robotiq_85_left_knuckle_joint beside the arm's
    seven: refused before ("name joints the robot does not have", no file:line); now said at
    the file's line, skipped, and the arm's limits taken."""
    limits = LIMITS / "kinova" / "gen3_7dof_robotiq_2f_85_moveit_joint_limits.yaml"
    cell = tmp_path / "gen3"
    result = cli(["import", "urdf", str(gen3_urdf), "-o", str(cell), "--joint-limits", str(limits)])
    assert result.exit_code == 0, result.output
    line = next(text for text in result.output.splitlines() if "robotiq_85" in text)
    number = 1 + limits.read_text().splitlines().index("  robotiq_85_left_knuckle_joint:")
    assert line == (
        f"{limits}:{number}:3: warning: robotiq_85_left_knuckle_joint: the joint limits name "
        "'robotiq_85_left_knuckle_joint', a joint the robot does not have: skipped"
    )
    [device] = load_cell(str(cell)).cell.devices.values()
    assert list(device.limit_array("acceleration")) == [8.6] * 7


def test_franka_limit_mappings_give_velocities_and_efforts():
    read = read_joint_limits(LIMITS / "franka" / "fr3_joint_limits.yaml")
    assert read.form == "urdf" and list(read.limits) == [f"joint{k}" for k in range(1, 8)]
    assert read.limits["joint1"] == {"velocity": 2.62, "effort": 87.0}
    assert read.limits["joint7"]["effort"] == 12.0


@pytest.mark.parametrize(
    "text, message",
    [
        ("joint_names: [a, b]\nmaximum_velocities: [1.0]\n",
         "x.yaml:2:21: maximum_velocities: 2 joint_names, 1 maximum_velocities: one each"),
        ("joint_names: [a]\n", "no limits beside the names"),
        ("joint_names: [a]\nmaximum_accelerations: [-1]\n", "maximum_accelerations[0] -1 is not"),
        ("a: {limit: {velocity: fast}}\n", "x.yaml:1:23: a.limit.velocity: velocity is not a"),
        ("limits: {}\n", "not a joint-limits file: expected 'joint_limits:'"),
    ],
)  # fmt: skip
def test_other_forms_errors_are_located(tmp_path, text, message):
    path = tmp_path / "x.yaml"
    path.write_text(text)
    with pytest.raises(UserError) as caught:
        read_joint_limits(path)
    assert message in caught.value.issues[0].format().replace(str(tmp_path) + "/", "")
