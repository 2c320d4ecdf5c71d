"""The animated .glb of a run: valid glTF (read back by pygltflib and checked structurally), its
node poses equal to the simulator's world to 1e-6 m, its decimated keyframes within 0.1 mm at
every sample, sensor colours as the sensors read, and the page within 5 MB."""

from __future__ import annotations

import numpy as np
import pytest

from rworld_cli.schema.gltf import TOLERANCE, accessor_array, read_glb, scene_glb
from rworld_cli.spatial import quat_to_matrix
from rworld_cli.world.tree import World


def parsed(scene, tolerance=TOLERANCE):
    data = scene_glb(scene, tolerance)
    gltf, blob = read_glb(data, "test.glb")
    return data, gltf, blob


def channels_of(gltf, blob) -> dict:
    """node index -> path -> (times, values, interpolation)."""
    out: dict = {}
    animation = gltf["animations"][0]
    for channel in animation["channels"]:
        sampler = animation["samplers"][channel["sampler"]]
        out.setdefault(channel["target"]["node"], {})[channel["target"]["path"]] = (
            accessor_array(gltf, blob, sampler["input"]).astype(float),
            accessor_array(gltf, blob, sampler["output"]).astype(float),
            sampler["interpolation"],
        )
    return out


def sample(track, t: float, static) -> np.ndarray:
    """A glTF channel's value at t, as a viewer computes it (LINEAR: lerp / slerp; STEP)."""
    if track is None:
        return np.asarray(static, dtype=float)
    times, values, interpolation = track
    k = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 1))
    if interpolation == "STEP" or k == len(times) - 1 or t <= times[0]:
        return values[k] if t >= times[0] else values[0]
    u = (t - times[k]) / (times[k + 1] - times[k])
    a, b = values[k], values[k + 1]
    if len(a) == 4:  # slerp, as three.js does it (float32 keys are not exactly unit)
        a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
        if a @ b < 0:
            b = -b
        angle = np.arccos(np.clip(a @ b, -1, 1))
        if angle < 1e-6:  # lerp and normalise
            mix = a + u * (b - a)
            return mix / np.linalg.norm(mix)
        return (np.sin((1 - u) * angle) * a + np.sin(u * angle) * b) / np.sin(angle)
    return a + u * (b - a)


def node_pose(gltf, tracks, index: int, t: float) -> np.ndarray:
    node = gltf["nodes"][index]
    mine = tracks.get(index, {})
    p = sample(mine.get("translation"), t, node.get("translation", [0, 0, 0]))
    x, y, z, w = sample(mine.get("rotation"), t, node.get("rotation", [0, 0, 0, 1]))
    T = np.eye(4)
    T[:3, :3] = quat_to_matrix([w, x, y, z])
    T[:3, 3] = p
    return T


def test_the_glb_is_valid_gltf(fig9_scene):
    pygltflib = pytest.importorskip("pygltflib")
    data, gltf, blob = parsed(fig9_scene)
    other = pygltflib.GLTF2.load_from_bytes(data)  # a second reader
    assert len(other.nodes) == len(gltf["nodes"]) and len(other.animations) == 1
    assert other.binary_blob() is not None and len(other.binary_blob()) >= len(blob)
    assert len(data) % 4 == 0
    for k, view in enumerate(gltf["bufferViews"]):
        assert view["byteOffset"] % 4 == 0 and view["byteOffset"] + view["byteLength"] <= len(blob)
    sizes = {5126: 4, 5123: 2, 5125: 4}
    widths = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}
    for a in gltf["accessors"]:
        view = gltf["bufferViews"][a["bufferView"]]
        assert a["count"] * widths[a["type"]] * sizes[a["componentType"]] <= view["byteLength"]
    for mesh in gltf["meshes"]:
        for primitive in mesh["primitives"]:
            position = gltf["accessors"][primitive["attributes"]["POSITION"]]
            values = accessor_array(gltf, blob, primitive["attributes"]["POSITION"])
            assert np.allclose(values.min(axis=0), position["min"])
            assert np.allclose(values.max(axis=0), position["max"])
            if "indices" in primitive:
                assert accessor_array(gltf, blob, primitive["indices"]).max() < position["count"]
    children = [c for node in gltf["nodes"] for c in node.get("children", [])]
    assert len(children) == len(set(children))  # a tree: no node has two parents
    roots = gltf["scenes"][0]["nodes"]
    assert sorted(roots + children) == list(range(len(gltf["nodes"])))
    animation = gltf["animations"][0]
    for sampler in animation["samplers"]:
        times = accessor_array(gltf, blob, sampler["input"])
        assert np.all(np.diff(times) > 0)  # strictly increasing key times
        assert gltf["accessors"][sampler["output"]]["count"] == len(times)
    for name in ("robot.link3", "part", "pad_a", "hand_a.tcp"):
        assert name in {n["name"] for n in gltf["nodes"]}


def test_node_poses_equal_the_simulated_world_at_20_instants(fig9_run, fig9_scene):
    loaded, result = fig9_run
    _, gltf, blob = parsed(fig9_scene, tolerance=0.0)  # every sample a keyframe
    tracks = channels_of(gltf, blob)
    index = {n["name"]: i for i, n in enumerate(gltf["nodes"])}
    frames = [n.name for n in fig9_scene.nodes]
    world = World(loaded.cell)
    times = result.times
    worst = 0.0
    for k in np.linspace(0, len(times) - 1, 20).astype(int):
        t = float(times[k])
        # the simulator's world at that sample, one frame at a time (not the scene's batch)
        world.restore([s for ts, s in result.snapshots if ts <= t][-1])
        for d, tl in result.devices.items():
            world.set_joints(d, tl.q[k])
        for frame in frames:
            T_glb = node_pose(gltf, tracks, index[frame], t)
            T_sim = world.T_world(frame)
            worst = max(worst, np.abs(T_glb[:3, 3] - T_sim[:3, 3]).max())
            # glTF stores times as float32: an instant near 10 s within 0.5 us, in which a link
            # turning at 3 rad/s turns 1.5e-6 rad
            assert np.abs(T_glb[:3, :3] - T_sim[:3, :3]).max() < 2e-6, (frame, t)
    assert worst < 1e-6
    # the grasped part rides with hand_a's TCP (grasped at t = 0) until it is placed
    placed = next(e.t for e in result.events if e.kind == "place" and e.tree["child"] == "part")
    first = next(k for k in range(len(times)) if times[k] > placed) - 2
    assert first > 10
    for k in (5, first // 2, first):
        t = float(times[k])
        T_tcp = node_pose(gltf, tracks, index["hand_a.tcp"], t)
        T_part = node_pose(gltf, tracks, index["part"], t)
        if k == 5:
            held = np.linalg.inv(T_tcp) @ T_part
        assert np.allclose(np.linalg.inv(T_tcp) @ T_part, held, atol=1e-6)


def test_decimated_keyframes_stay_within_a_tenth_of_a_millimetre(fig9_scene):
    _, gltf, blob = parsed(fig9_scene)
    _, full, full_blob = parsed(fig9_scene, tolerance=0.0)
    tracks = channels_of(gltf, blob)
    index = {n["name"]: i for i, n in enumerate(gltf["nodes"])}
    times = fig9_scene.times
    kept = sum(len(t[0]) for node in tracks.values() for p, t in node.items() if p == "translation")
    total = sum(
        len(t[0])
        for node in channels_of(full, full_blob).values()
        for p, t in node.items()
        if p == "translation"
    )
    assert kept < total / 4  # held objects and idle devices cost two keyframes
    for node in fig9_scene.nodes:
        radius = (
            np.linalg.norm(node.mesh.vertices, axis=1).max() if node.mesh is not None else node.axes
        )
        for k in range(0, len(times), 3):
            T = node_pose(gltf, tracks, index[node.name], float(times[k]))
            P = node.poses[k]
            angle = np.arccos(np.clip((np.trace(T[:3, :3].T @ P[:3, :3]) - 1) / 2, -1, 1))
            error = np.linalg.norm(T[:3, 3] - P[:3, 3]) + max(radius, 0.01) * angle
            assert error < TOLERANCE + 2e-6, (node.name, times[k], error)  # + float32 rounding


def test_sensor_cells_show_the_readings(fig9_run, fig9_scene):
    from rworld_cli.sensing.sensors import read_sensors
    from rworld_cli.units import SENSING_TOLERANCE

    loaded, result = fig9_run
    _, gltf, blob = parsed(fig9_scene)
    tracks = channels_of(gltf, blob)
    index = {n["name"]: i for i, n in enumerate(gltf["nodes"])}
    pad = next(s for s in fig9_scene.sensors if s.name == "pad_a")
    assert pad.sensed.any() and not pad.sensed.all()  # it senses for part of the run
    world = World(loaded.cell)
    for m in np.linspace(0, len(pad.times) - 1, 6).astype(int):
        t = float(pad.times[m])
        k = int(np.argmin(np.abs(result.times - t)))
        world.restore([s for ts, s in result.snapshots if ts <= t][-1])
        for d, tl in result.devices.items():
            world.set_joints(d, tl.q[k])
        reading = next(r for r in read_sensors(world, ["pad_a"], SENSING_TOLERANCE))
        from rworld_cli.sensing.render import cell_boxes

        truth = [sensed for *_, sensed in cell_boxes(loaded.cell.sensors["pad_a"], reading)]
        for c, sensed in enumerate(truth):
            on = index[f"pad_a[{c}].sensing"]
            off = index[f"pad_a[{c}].free"]
            scale_on = sample(tracks.get(on, {}).get("scale"), t, gltf["nodes"][on]["scale"])
            scale_off = sample(tracks.get(off, {}).get("scale"), t, gltf["nodes"][off]["scale"])
            assert (scale_on.max() > 0) == sensed and (scale_off.max() > 0) != sensed, (t, c)


def test_the_fig9_page_stays_under_5_mb(fig9_page):
    size = fig9_page.stat().st_size
    assert size <= 5_000_000, size
    text = fig9_page.read_text(encoding="utf-8")
    assert "http://" not in text.split('<script type="importmap">')[0]  # no CDN
    assert "unpkg" not in text and "cdn." not in text


def test_every_object_has_its_own_colour(example_run):
    """Issue 50: the plate was drawn in the table's grey; each object now has its own colour."""
    from rworld_cli.schema.gltf import scene_glb
    from rworld_cli.simulate.scene import run_scene

    loaded, result = example_run("probing", "probe_features")
    scene = run_scene(loaded.cell, result)
    colours = {n.name: n.mesh.colour for n in scene.nodes if n.kind == "object" and n.mesh}
    assert set(colours) == {"table", "bracket", "plate", "peg"}
    assert len(set(colours.values())) == len(colours)
    glb = scene_glb(scene)
    assert all(c.encode() in glb for c in colours.values())  # the materials are named so
