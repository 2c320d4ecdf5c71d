"""A vendor's robot as a new user gets it (issue 50): the Yaskawa GP7's xacro from
ROS-Industrial (tests/data/motoman), with $(find PKG) and an included macro, imported without
ROS; its kinematics equal Pinocchio's of the same expansion; the vendor's joint_limits.yaml
gives every joint its acceleration limit, and what is still missing is said in one warning."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from rworld_cli.schema.loader import load_cell
from rworld_cli.schema.urdf import expand_xacro
from rworld_cli.world.tree import World
from tests.conftest import REPO

MOTOMAN = REPO / "tests" / "data" / "motoman"
GP7 = MOTOMAN / "motoman_gp7_support" / "urdf" / "gp7.xacro"
LIMITS = """joint_limits:
  joint_1_s: {has_velocity_limits: true, max_velocity: 6.5, has_acceleration_limits: true, max_acceleration: 12.0}
  joint_2_l: {has_velocity_limits: true, max_velocity: 5.5, has_acceleration_limits: true, max_acceleration: 11.0}
  joint_3_u: {has_velocity_limits: true, max_velocity: 7.1, has_acceleration_limits: true, max_acceleration: 13.0}
  joint_4_r: {has_velocity_limits: true, max_velocity: 9.6, has_acceleration_limits: true, max_acceleration: 20.0}
  joint_5_b: {has_velocity_limits: false, max_velocity: 0, has_acceleration_limits: true, max_acceleration: 20.0}
  joint_6_t: {has_velocity_limits: true, max_velocity: 17.4, has_acceleration_limits: false, max_acceleration: 0}
"""  # noqa: E501


def test_the_gp7_xacro_imports_without_ros_and_moves_as_pinocchio_says(cli, tmp_path):
    limits = tmp_path / "joint_limits.yaml"
    limits.write_text(LIMITS)
    cell = tmp_path / "gp7"
    result = cli(
        ["import", "urdf", str(GP7), "--package-path", str(MOTOMAN), "-o", str(cell)]
        + ["--joint-limits", str(limits)]
    )
    assert result.exit_code == 0, result.output
    assert "gp7.xacro (as xacro expands it)" in result.output
    warned = [line for line in result.output.splitlines() if "no acceleration limit" in line]
    assert len(warned) == 1 and "for joint_6_t (URDF" in warned[0], warned
    model_cell = load_cell(str(cell)).cell
    [device] = model_cell.devices.values()
    assert [j.name for j in device.joints] == [
        "joint_1_s", "joint_2_l", "joint_3_u", "joint_4_r", "joint_5_b", "joint_6_t"
    ]  # fmt: skip
    accelerations = device.limit_array("acceleration")
    assert list(accelerations[:5]) == [12.0, 11.0, 13.0, 20.0, 20.0]
    assert not np.isfinite(accelerations[5])
    assert device.limit_array("velocity")[0] == 6.5
    # the same expansion through Pinocchio: tool0 where rworld puts it
    urdf = tmp_path / "gp7.urdf"
    urdf.write_bytes(expand_xacro(GP7, str(GP7), [MOTOMAN]))
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    world = World(model_cell)
    lo, hi = device.limit_array("lower"), device.limit_array("upper")
    for q in np.random.default_rng(4).uniform(lo, hi, (20, 6)):
        pin.framesForwardKinematics(model, data, q)
        expected = data.oMf[model.getFrameId("tool0")].homogeneous
        world.set_joints(device.name, q)
        got = np.linalg.solve(world.T_world(device.name), world.T_world(f"{device.name}.tool0"))
        assert np.abs(got - expected).max() < 1e-9


def test_xacro_errors_are_clear(cli, tmp_path):
    result = cli(["import", "urdf", str(GP7), "-o", str(tmp_path / "x")])
    assert result.exit_code == 2
    assert "$(find motoman_gp7_support): no ROS package 'motoman_gp7_support'" in result.output
    assert "--package-path DIR" in result.output
    bad = tmp_path / "bad.xacro"
    bad.write_text(
        '<robot name="r" xmlns:xacro="http://ros.org/wiki/xacro">'
        '<link name="$(arg missing)"/></robot>'
    )
    result = cli(["import", "urdf", str(bad), "-o", str(tmp_path / "y")])
    expected = "bad.xacro:1:57: <link>: xacro: $(arg missing): undefined; give it with "
    assert result.exit_code == 2 and expected + "--xacro-arg missing:=VALUE" in result.output
    result = cli(["import", "urdf", str(bad), "-o", str(tmp_path / "y"), "--xacro-arg", "missing"])
    assert result.exit_code == 2 and "write NAME:=VALUE" in result.output


@pytest.mark.parametrize(
    "text, message",
    [
        ("joint_limits:\n  joint_1_s: {has_acceleration_limits: true}\n",
         "joint_limits.yaml:2:14: joint_limits.joint_1_s.max_acceleration: "
         "has_acceleration_limits is true: give max_acceleration"),
        ("joint_limits:\n  joint_1_s: {has_acceleration_limits: true, max_acceleration: -1}\n",
         "max_acceleration -1 is not a number above 0"),
        ("limits: {}\n", "not a joint-limits file: expected 'joint_limits:'"),
    ],
)  # fmt: skip
def test_bad_joint_limits_are_located(cli, tmp_path, text, message):
    limits = tmp_path / "joint_limits.yaml"
    limits.write_text(text)
    result = cli(
        ["import", "urdf", str(GP7), "--package-path", str(MOTOMAN), "-o", str(tmp_path / "c")]
        + ["--joint-limits", str(limits)]
    )
    assert result.exit_code == 2 and message in result.output, result.output
    assert not (tmp_path / "c").exists()


def test_relative_package_paths_resolve_from_where_the_user_stands(cli, tmp_path, monkeypatch):
    """`--package-path ./src` as typed in a shell: xacro includes `$(find PKG)/...` against its
    own folder, so a relative package folder once made it look under the xacro's folder."""
    monkeypatch.chdir(REPO / "tests")
    cell = tmp_path / "gp7"
    result = cli(
        ["import", "urdf", "./data/motoman/motoman_gp7_support/urdf/gp7.xacro"]
        + ["--package-path", "./data/motoman", "-o", str(cell)]
    )
    assert result.exit_code == 0, result.output
    [device] = load_cell(str(cell)).cell.devices.values()
    assert len(device.joints) == 6
