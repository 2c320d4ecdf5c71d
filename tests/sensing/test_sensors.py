"""Each sensor type on the Fig. 9 cell, and the sense / render commands."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rworld_cli.schema.loader import load_cell
from rworld_cli.sensing.sensors import read_sensors
from rworld_cli.world.tree import World


@pytest.fixture
def world():
    return World(load_cell("workcells/paper_fig9").cell)


def reading(world, name):
    return read_sensors(world, [name])[0]


def test_tactile_map_shows_the_wall_under_the_pad(world):
    r = reading(world, "pad_a")
    assert r.objects == ["part"]
    expected = np.zeros((8, 4), dtype=bool)
    expected[:5] = True  # the 5 rows (of 5 mm) below the top of the bracket's wall
    np.testing.assert_array_equal(r.cells, expected)


def test_tactile_pad_free_once_the_part_is_released_and_moved(world):
    world.detach("part")
    T = world.T_world("part")
    T[2, 3] -= 0.5
    world.move("part", T)
    assert not reading(world, "pad_a").active


def test_presence_beam_sees_the_housing_and_then_nothing(world):
    r = reading(world, "beam_b")
    assert r.active and r.objects == ["housing"]
    world.detach("housing")
    world.move("housing", np.eye(4))
    assert not reading(world, "beam_b").active


def test_proximity_slices_step_with_distance(world):
    """Move a ball along the range box's axis: the nearest hit slice counts the distance in
    slices.
    """
    from rworld_cli.model.cell import Box, Inertial, ObjectModel, Shape

    sensor = world.cell.sensors["range_wrist"]
    world.detach("range_wrist")
    world.move("range_wrist", np.eye(4))  # looking up along world z from the origin
    r = 0.01
    ball = ObjectModel(
        "ball",
        Inertial.zero(),
        Shape("sphere", np.eye(4), np.full(3, 2 * r), Box(np.eye(4), np.full(3, r))),
    )
    cell = world.cell
    cell.objects["ball"] = ball
    from rworld_cli.model.cell import FrameDecl

    cell.frames["ball"] = FrameDecl("ball", "natural", "ball", None)
    world2 = World(cell)
    world2.detach("range_wrist")
    world2.move("range_wrist", np.eye(4))
    slice_len = sensor.size[2] / sensor.slices  # 30 mm
    seen = []
    for k in range(sensor.slices):
        T = np.eye(4)
        T[2, 3] = (k + 0.5) * slice_len + r  # the ball's lowest point in the middle of slice k
        world2.move("ball", T)
        rd = read_sensors(world2, ["range_wrist"])[0]
        seen.append(rd.value)
        assert "ball" in rd.objects
    assert seen == [1, 2, 3, 4, 5]
    T = np.eye(4)
    T[2, 3] = 1.0  # far beyond the range box
    world2.move("ball", T)
    assert read_sensors(world2, ["range_wrist"])[0].value == 0


def test_force_from_overlap_volume_through_the_calibration_curve(world):
    r = reading(world, "load_cell")
    # the weight (a 48-sided cylinder of radius 30 mm) sinks 0.2 mm into the pad
    sides, radius, depth = 48, 0.030, 0.0002
    area = 0.5 * sides * radius**2 * np.sin(2 * np.pi / sides)
    assert r.overlap_volume == pytest.approx(area * depth, rel=1e-5)
    curve = world.cell.sensors["load_cell"].force_curve
    assert r.value == pytest.approx(np.interp(area * depth, curve[:, 0], curve[:, 1]), rel=1e-5)
    assert r.objects == ["weight"] and not r.saturated
    T = world.T_world("weight")
    T[2, 3] += 0.001  # lifted off: no overlap, no force
    world.move("weight", T)
    r = reading(world, "load_cell")
    assert r.value == 0.0 and not r.active


def test_touch_sensor_and_mount_exclusion(world):
    r = reading(world, "bumper")
    assert not r.active  # it sits on the table but does not feel it (its mount)
    T = world.T_world("bumper")
    world.detach("weight")
    world.move("weight", T @ np.diag([1.0, 1, 1, 1]))  # the weight moved onto the bumper
    assert reading(world, "bumper").objects == ["weight"]


def test_sense_command(cli, tmp_path):
    result = cli(["sense", "workcells/paper_fig9", "--png", str(tmp_path / "maps.png")])
    assert result.exit_code == 0, result.output
    assert "pad_a (tactile 8x4): 20 cell(s) in contact with part" in result.stdout
    assert "    ####" in result.stdout and "    ...." in result.stdout
    assert "load_cell (force): 28.19 N" in result.stdout
    assert (tmp_path / "maps.png").read_bytes()[:4] == b"\x89PNG"
    data = json.loads(cli(["sense", "workcells/paper_fig9", "--sensor", "pad_a", "--json"]).stdout)
    assert len(data["readings"]) == 1 and sum(map(sum, data["readings"][0]["cells"])) == 20


def test_sense_with_device_and_q(cli):
    far = json.loads(
        cli(
            [
                "sense",
                "workcells/puma560",
                "--device",
                "puma",
                "--q",
                "0,0.78,-3.14,0,0.78,0",
                "--json",
            ]
        ).stdout
    )
    assert far["readings"][0]["active"] is False
    result = cli(["sense", "workcells/puma560", "--device", "puma"])
    assert result.exit_code == 2 and "--device and --q go together" in result.output


def test_render_png_and_glb(cli, tmp_path):
    import trimesh

    assert cli(["render", "workcells/paper_fig9", "-o", str(tmp_path / "cell.png")]).exit_code == 0
    assert (tmp_path / "cell.png").read_bytes()[:4] == b"\x89PNG"
    assert cli(["render", "workcells/paper_fig9", "-o", str(tmp_path / "cell.glb")]).exit_code == 0
    scene = trimesh.load(tmp_path / "cell.glb")
    assert "pad_a[0]" in scene.geometry and "part" in scene.geometry


@pytest.mark.parametrize(
    "args, message",
    [
        (
            ["sense", "workcells/paper_fig9", "--sensor", "pad_b"],
            "unknown sensor 'pad_b' (did you mean 'pad_a'?)",
        ),
        (
            ["sense", "workcells/paper_fig9", "--tolerance", "-1"],
            "tolerance must be a finite length >= 0",
        ),
        (["sense", "workcells/puma560", "--png", "x.png"], "no tactile or proximity sensor"),
        (["render", "workcells/paper_fig9", "-o", "cell.jpg"], "give a .png, .glb or .html file"),
    ],
)
def test_bad_sensing_input_exits_2(cli, tmp_path, args, message):
    result = cli(args, cwd=None)
    assert result.exit_code == 2, result.output
    assert message in result.output


def test_a_ball_that_may_not_touch_reads_nothing():
    """``ball_may_touch`` (all states at once) is True wherever the exact reading is active:
    the probe cell's 39 latched contacts on the plate and bracket, each turned by up to 4 mrad
    per joint (seeded), read one state at a time and all at once."""
    from rworld_cli.api import simulate_run
    from rworld_cli.sensing.sensors import ball_may_touch

    _, result = simulate_run("workcells/probing", "probe")
    latched = np.array(
        [e.reading["q"] for e in result.events if e.kind == "guard" and e.reading is not None]
    )
    assert len(latched) == 39
    rng = np.random.default_rng(7)
    q = np.repeat(latched, 8, axis=0) + rng.uniform(-4e-3, 4e-3, (8 * len(latched), 6))
    world = World(load_cell("workcells/probing").cell)
    may = ball_may_touch(world, "probe_ball", {"puma": q})
    active = []
    for state in q:
        world.set_joints("puma", state)
        active.append(read_sensors(world, ["probe_ball"])[0].active)
    active = np.array(active)
    assert not (active & ~may).any()
    # both sides well represented: touching states, and states it spares reading
    assert active.sum() > 50 and (~may).sum() > 50
