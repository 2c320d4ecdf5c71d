"""The example cells load, validate and round-trip through the file model."""

from __future__ import annotations

import shutil

import numpy as np
import yaml

from rworld_cli.schema.loader import load_cell
from rworld_cli.schema.models import CellFile, PoseFile
from rworld_cli.schema.yamlio import read_yaml
from rworld_cli.world.tree import World


def test_example_validates_with_exit_0(cli, example_cell):
    result = cli(["validate", str(example_cell / "cell.yaml")])
    assert result.exit_code == 0, result.stderr
    assert result.stdout.startswith("ok: ")


def test_example_round_trips(example_cell, tmp_path):
    """Dump the parsed files back to YAML; the reloaded cell has identical data and world poses."""
    copy = tmp_path / example_cell.name
    shutil.copytree(example_cell, copy)
    for name, model in (("cell.yaml", CellFile), ("poses.yaml", PoseFile)):
        parsed = model.model_validate(read_yaml(example_cell / name).data)
        dumped = yaml.safe_dump(parsed.model_dump(mode="json", exclude_unset=True), sort_keys=False)
        (copy / name).write_text(dumped)
        assert model.model_validate(yaml.safe_load(dumped)) == parsed
    original, again = load_cell(example_cell).cell, load_cell(copy).cell
    assert original.frames == again.frames
    assert original.affixments == again.affixments
    assert original.conditions == again.conditions
    w1, w2 = World(original), World(again)
    p1, p2 = w1.world_poses(), w2.world_poses()
    assert p1.keys() == p2.keys()
    for name in p1:
        np.testing.assert_array_equal(p1[name], p2[name])


def test_units_convert_to_si_at_load():
    cell = load_cell("workcells/paper_fig9").cell
    robot = cell.devices["robot"]
    assert robot.joints[1].a == -0.425  # -425 mm
    assert np.isclose(robot.joints[0].alpha, np.pi / 2)  # 90 deg
    assert np.isclose(robot.joints[0].limits.velocity, np.pi)  # 180 deg/s
    conveyor = cell.devices["conveyor"].joints[0]
    assert (
        conveyor.kind == "prismatic"
        and conveyor.limits.upper == 2.0
        and conveyor.limits.velocity == 0.5
    )
    assert np.allclose(cell.sensors["load_cell"].force_curve[1], [1000e-9, 50.0])  # mm^3 -> m^3
    np.testing.assert_allclose(cell.poses["table"][:3, 3], [1.2, 0.6, 0.8])


def test_puma_motor_friction_referred_to_joint():
    j1 = load_cell("workcells/puma560").cell.devices["puma"].joints[0]
    G = -62.6111
    assert j1.armature == 0.0002 * G**2
    assert np.isclose(j1.viscous, 0.00148 * G**2)
    assert np.isclose(j1.coulomb_positive, 0.395 * abs(G)) and np.isclose(
        j1.coulomb_negative, 0.435 * abs(G)
    )


def test_puma_inertia_warnings_name_the_links():
    warnings = load_cell("workcells/puma560").warnings
    assert [w.location for w in warnings] == [
        "devices[0].links[0].inertia",
        "devices[0].links[2].inertia",
    ]
    assert all("triangle inequality" in w.message for w in warnings)


def test_yaml_12_floats_are_numbers():
    from rworld_cli.schema.yamlio import parse_yaml_text

    assert parse_yaml_text("a: 4e-05\nb: 1E3\nc: -2.5e+2\n", "x").data == {
        "a": 4e-05,
        "b": 1000.0,
        "c": -250.0,
    }


def test_later_pose_file_overrides_earlier(tmp_path):
    copy = tmp_path / "cal"
    shutil.copytree("workcells/calibration_example", copy)
    text = (
        (copy / "cell.yaml")
        .read_text()
        .replace("pose_files: [poses.yaml]", "pose_files: [poses.yaml, calibrated.yaml]")
    )
    (copy / "cell.yaml").write_text(text)
    (copy / "calibrated.yaml").write_text(
        "units: {length: mm, angle: deg}\nposes:\n  block: {xyz: [-99, -75, 0], rpy: [0, 0, "
        "15.5]}\n"
    )
    cell = load_cell(copy).cell
    np.testing.assert_allclose(cell.poses["block"][:3, 3], [-0.099, -0.075, 0])
    assert cell.pose_sources["block"].name == "calibrated.yaml"
    assert cell.pose_sources["block.frame2"].name == "poses.yaml"
