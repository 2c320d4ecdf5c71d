"""UR factory calibrations (issue 46): ``rworld import ur-calibration`` turns the kinematics
file ur_calibration reads from a robot into an overlay of the cell's joint frames; the
calibrated cell's tool0 equals Pinocchio's forward kinematics of the calibrated URDF (built
from the same file as ur_description's ur_macro.xacro builds it) to 1e-9 m; copying the
numbers in by hand without the base's turn is named by a warning."""

from __future__ import annotations

import json
import math

import numpy as np
import pinocchio as pin
import pytest
import yaml

from rworld_cli.api import import_urdf
from rworld_cli.schema.loader import load_cell
from rworld_cli.world.tree import World

# ur_description's default kinematics of a UR5e (config/ur5e/default_kinematics.yaml)
DEFAULT = {
    "shoulder": [0, 0, 0.1625, 0, 0, 0],
    "upper_arm": [0, 0, 0, math.pi / 2, 0, 0],
    "forearm": [-0.425, 0, 0, 0, 0, 0],
    "wrist_1": [-0.3922, 0, 0.1333, 0, 0, 0],
    "wrist_2": [0, -0.0997, 0, math.pi / 2, 0, 0],
    "wrist_3": [0, 0.0996, 0, math.pi / 2, math.pi, math.pi],
}
JOINTS = ["shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3"]
LINKS = ["shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3"]


def _urdf(kinematics: dict) -> str:
    """A UR5e as ur_macro.xacro builds it (inertias, no meshes)."""

    def link(name):
        return (
            f'<link name="{name}"><inertial><mass value="2"/><origin xyz="0 0 0.05"/>'
            '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        )

    out = ['<robot name="ur5e">', '<link name="base_link"/>', link("base_link_inertia")]
    out.append(
        '<joint name="base_link-base_link_inertia" type="fixed"><parent link="base_link"/>'
        f'<child link="base_link_inertia"/><origin xyz="0 0 0" rpy="0 0 {math.pi!r}"/></joint>'
    )
    parent = "base_link_inertia"
    for joint, child, group in zip(JOINTS, LINKS, DEFAULT):
        x, y, z, roll, pitch, yaw = kinematics[group]
        out.append(link(f"{child}_link"))
        out.append(
            f'<joint name="{joint}_joint" type="revolute"><parent link="{parent}"/>'
            f'<child link="{child}_link"/><origin xyz="{x!r} {y!r} {z!r}" '
            f'rpy="{roll!r} {pitch!r} {yaw!r}"/><axis xyz="0 0 1"/>'
            '<limit lower="-6.2832" upper="6.2832" effort="150" velocity="3.14"/></joint>'
        )
        parent = f"{child}_link"
    half = math.pi / 2
    out += [
        '<link name="flange"/><joint name="wrist_3-flange" type="fixed">'
        '<parent link="wrist_3_link"/><child link="flange"/>'
        f'<origin xyz="0 0 0" rpy="0 {-half!r} {-half!r}"/></joint>',
        '<link name="tool0"/><joint name="flange-tool0" type="fixed"><parent link="flange"/>'
        f'<child link="tool0"/><origin xyz="0 0 0" rpy="{half!r} 0 {half!r}"/></joint>',
        "</robot>",
    ]
    return "\n".join(out) + "\n"


def _calibrated(seed: int = 3) -> dict:
    """A factory calibration: every group off by tenths of a millimetre and a milliradian."""
    rng = np.random.default_rng(seed)
    return {
        g: [float(x) for x in np.array(v) + np.r_[rng.normal(0, 3e-4, 3), rng.normal(0, 1e-3, 3)]]
        for g, v in DEFAULT.items()
    }


def _calibration_file(path, kinematics: dict) -> None:
    doc = {
        "kinematics": {
            **{
                g: dict(zip(["x", "y", "z", "roll", "pitch", "yaw"], map(float, v)))
                for g, v in kinematics.items()
            },
            "hash": "calib_1234567890",
        }
    }
    path.write_text(yaml.safe_dump(doc, sort_keys=False))


@pytest.fixture(scope="module")
def ur5e(tmp_path_factory):
    root = tmp_path_factory.mktemp("ur5e")
    urdf = root / "ur5e.urdf"
    urdf.write_text(_urdf(DEFAULT))
    cell = root / "cell"
    device = import_urdf(str(urdf), str(cell), overlap_states=0).device
    for joint in (data := yaml.safe_load((cell / "cell.yaml").read_text()))["devices"][0]["joints"]:
        joint["limits"]["acceleration"] = 10.0
    (cell / "cell.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    return root, cell, device


def _list(cell, overlay) -> None:
    text = (cell / "cell.yaml").read_text()
    (cell / "cell.yaml").write_text(
        text.replace("pose_files:\n- poses.yaml\n", f"pose_files:\n- poses.yaml\n- {overlay}\n")
    )


def test_the_calibrated_cell_is_urs_calibrated_kinematics(cli, ur5e, tmp_path):
    root, cell, device = ur5e
    kinematics = _calibrated()
    calibration = tmp_path / "robot_calibration.yaml"
    _calibration_file(calibration, kinematics)
    overlay = cell / "ur_cal.yaml"
    result = cli(
        ["import", "ur-calibration", str(calibration), "--cell", str(cell), "-o", str(overlay)]
        + ["--json"]
    )
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert report["hash"] == "calib_1234567890" and len(report["joints"]) == 6
    assert all(0 < j["moved_mm"] < 5 for j in report["joints"])
    _list(cell, "ur_cal.yaml")
    try:
        calibrated_urdf = tmp_path / "calibrated.urdf"
        calibrated_urdf.write_text(_urdf(kinematics))
        model = pin.buildModelFromUrdf(str(calibrated_urdf))
        data = model.createData()
        world = World(load_cell(str(cell)).cell)
        rng = np.random.default_rng(8)
        worst = 0.0
        for q in rng.uniform(-math.pi, math.pi, (30, 6)):
            pin.framesForwardKinematics(model, data, q)
            expected = data.oMf[model.getFrameId("tool0")].homogeneous
            world.set_joints(device, q)
            got = np.linalg.solve(world.T_world(device), world.T_world(f"{device}.tool0"))
            worst = max(worst, float(np.abs(got[:3, 3] - expected[:3, 3]).max()))
            assert np.abs(got[:3, :3] - expected[:3, :3]).max() < 1e-9
        print(f"calibrated tool0 against Pinocchio: worst {worst:.2e} m")
        assert worst < 1e-9
        assert "warning" not in cli(["validate", str(cell / "cell.yaml")]).output
    finally:
        text = (cell / "cell.yaml").read_text()
        (cell / "cell.yaml").write_text(text.replace("- ur_cal.yaml\n", ""))


def test_a_hand_copied_calibration_is_named_and_a_wrong_file_refused(cli, ur5e, tmp_path):
    root, cell, device = ur5e
    kinematics = _calibrated()
    lines = ["units: {length: mm, angle: deg}", "joints:"]
    for joint, group in zip(JOINTS, DEFAULT):  # each group as its joint's frame, by hand
        x, y, z, roll, pitch, yaw = kinematics[group]
        lines.append(
            f"  {device}.{joint}_joint: {{xyz: [{x * 1000!r}, {y * 1000!r}, {z * 1000!r}], "
            f"rpy: [{math.degrees(roll)!r}, {math.degrees(pitch)!r}, {math.degrees(yaw)!r}]}}"
        )
    (cell / "by_hand.yaml").write_text("\n".join(lines) + "\n")
    _list(cell, "by_hand.yaml")
    try:
        result = cli(["validate", str(cell / "cell.yaml")])
        assert "by_hand.yaml" in result.output and "shoulder_pan_joint's frame by" in result.output
        assert "180.00 deg" in result.output or "179.9" in result.output, result.output
    finally:
        text = (cell / "cell.yaml").read_text()
        (cell / "cell.yaml").write_text(text.replace("- by_hand.yaml\n", ""))
    bad = tmp_path / "bad.yaml"
    bad.write_text("kinematics:\n  shoulder: {x: 0, y: 0, z: oops, roll: 0, pitch: 0, yaw: 0}\n")
    result = cli(["import", "ur-calibration", str(bad), "--cell", str(cell)])
    assert result.exit_code == 2
    assert "bad.yaml:2:29: kinematics.shoulder.z: 'z' is not a number" in result.output
    assert "no 'upper_arm' group" in result.output
    other = tmp_path / "other.yaml"
    far = dict(_calibrated())
    far["forearm"] = [-0.6127, 0, 0, 0, 0, 0]  # a UR10e's forearm
    _calibration_file(other, far)
    result = cli(["import", "ur-calibration", str(other), "--cell", str(cell)])
    assert result.exit_code == 2 and "'elbow_joint' frame of the calibration is 18" in result.output


def test_a_hash_that_is_not_a_plain_token_is_refused(cli, ur5e, tmp_path):
    """The outside report's file: a hash with newlines that, written raw into the overlay's
    comment, added a 'poses:' section moving a fixture 250 mm (issue 58)."""
    root, cell, device = ur5e
    hostile = tmp_path / "hostile.yaml"
    _calibration_file(hostile, _calibrated())
    text = hostile.read_text().replace(
        "hash: calib_1234567890", 'hash: "calib_1\\nposes:\\n  fixture: {xyz: [0.25, 0, 0]}"'
    )
    hostile.write_text(text)
    out = tmp_path / "overlay.yaml"
    result = cli(["import", "ur-calibration", str(hostile), "--cell", str(cell), "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert "hostile.yaml:" in result.output and "kinematics.hash" in result.output
    assert "is not a plain token" in result.output and not out.exists()
