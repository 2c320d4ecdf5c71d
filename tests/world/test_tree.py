"""The runtime frame tree: poses, affixments, and the report's semantics."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rworld_cli import spatial
from rworld_cli.model.cell import WORLD, CellModel, FrameDecl, Inertial, ObjectModel
from rworld_cli.schema.loader import load_cell
from rworld_cli.world.tree import AffixmentError, World


@pytest.fixture(scope="module")
def fig9() -> CellModel:
    return load_cell("workcells/paper_fig9").cell


def random_pose(rng) -> np.ndarray:
    return spatial.make_transform(
        spatial.rpy_to_matrix(rng.uniform(-np.pi, np.pi, 3)), rng.uniform(-1, 1, 3)
    )


def synthetic_cell(n: int, parents: list[int], seed: int) -> CellModel:
    """n objects o0..o{n-1}, each with an auxiliary frame; object i rests on object parents[i]
    (-1: world).
    """
    rng = np.random.default_rng(seed)
    frames = {WORLD: FrameDecl(WORLD, "world", WORLD, None)}
    objects, poses, affix = {}, {}, []
    from rworld_cli.model.cell import AffixmentDecl

    for i in range(n):
        name = f"o{i}"
        frames[name] = FrameDecl(name, "natural", name, None)
        frames[f"{name}.f"] = FrameDecl(f"{name}.f", "auxiliary", name, name)
        objects[name] = ObjectModel(name, Inertial.zero(), None)
        poses[name] = random_pose(rng)
        poses[f"{name}.f"] = random_pose(rng)
        if parents[i] >= 0:
            affix.append(AffixmentDecl(f"o{parents[i]}.f", name, "rigid", "assembly"))
    return CellModel("synthetic", None, np.zeros(3), frames, objects, {}, {}, {}, [], affix, poses)


@st.composite
def trees_and_ops(draw):
    n = draw(st.integers(2, 8))
    parents = [-1] + [draw(st.integers(-1, i - 1)) for i in range(1, n)]
    ops = draw(
        st.lists(
            st.tuples(
                st.sampled_from(["attach", "detach", "move"]),
                st.integers(0, n - 1),
                st.integers(-1, n - 1),
            ),
            max_size=12,
        )
    )
    return n, parents, ops, draw(st.integers(0, 2**16))


@settings(max_examples=60, deadline=None)
@given(trees_and_ops())
def test_random_attach_detach_sequences_keep_world_poses_consistent(case):
    n, parents, ops, seed = case
    rng = np.random.default_rng(seed)
    world = World(synthetic_cell(n, parents, seed))
    for op, a, b in ops:
        child = f"o{a}"
        before = world.world_poses()
        if op == "attach":
            parent = WORLD if b < 0 else f"o{b}.f"
            if parent != WORLD and parent in world.subtree(child):
                with pytest.raises(AffixmentError, match="cycle|its own frame"):
                    world.attach(child, parent, "non_rigid", "rests_on")
                continue
            world.attach(child, parent, "non_rigid", "rests_on")
            after = world.world_poses()  # attaching moves nothing
            for k in before:
                np.testing.assert_allclose(after[k], before[k], atol=1e-12)
            assert world.parent(child) == parent
        elif op == "detach":
            if world.affixment(child) is None:
                with pytest.raises(AffixmentError):
                    world.detach(child)
                continue
            world.detach(child)  # the tree splits; nothing moves
            after = world.world_poses()
            for k in before:
                np.testing.assert_allclose(after[k], before[k], atol=1e-12)
            assert world.parent(child) == WORLD
        else:
            aff = world.affixment(child)
            if aff is not None and aff.type == "rigid":
                with pytest.raises(AffixmentError, match="rigidly affixed"):
                    world.move(child, np.eye(4))
                continue
            target = random_pose(rng)
            moved = world.subtree(child)
            world.move(child, target)
            after = world.world_poses()
            np.testing.assert_allclose(after[child], target, atol=1e-12)
            delta = target @ spatial.invert_transform(before[child])
            for k in before:  # the subtree moves rigidly with it; nothing else moves
                expected = delta @ before[k] if k in moved else before[k]
                np.testing.assert_allclose(after[k], expected, atol=1e-9)
        # invariants after every step: each relative pose composes to the world pose
        poses = world.world_poses()
        for k in poses:
            if world.parent(k) is not None:
                np.testing.assert_allclose(
                    poses[world.parent(k)] @ world.T_parent(k), poses[k], atol=1e-9
                )


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**16))
def test_relative_poses_are_inverse_pairs(seed):
    rng = np.random.default_rng(seed)
    cell = load_cell("workcells/paper_fig9").cell
    world = World(cell)
    for dev in cell.devices.values():
        lo = np.maximum(dev.limit_array("lower"), -3.0)
        hi = np.minimum(dev.limit_array("upper"), 3.0)
        world.set_joints(dev.name, rng.uniform(lo, hi))
    names = world.frames
    for _ in range(10):
        a, b = rng.choice(names, 2)
        np.testing.assert_allclose(world.T(a, b) @ world.T(b, a), np.eye(4), atol=1e-12)
        np.testing.assert_allclose(world.T(WORLD, b), world.T_world(b), atol=1e-12)


def test_conveyor_carries_robot_hands_and_grasped_objects(fig9):
    world = World(fig9)
    carried = world.subtree("conveyor")
    assert {
        "robot",
        "hand_a",
        "hand_b",
        "part",
        "housing",
        "shaft",
        "cap",
        "housing.approach",
    } <= set(carried)
    before = world.world_poses()
    world.set_joints("conveyor", [0.75])  # 750 mm along the base z = world +x
    after = world.world_poses()
    for name in carried[2:]:  # everything on the carriage shifts by 0.75 m in world x
        np.testing.assert_allclose(
            after[name][:3, 3] - before[name][:3, 3], [0.75, 0, 0], atol=1e-12
        )
        np.testing.assert_allclose(after[name][:3, :3], before[name][:3, :3], atol=1e-12)
    for name in ("table", "table.slot_part", "drop_zone"):
        np.testing.assert_array_equal(after[name], before[name])


def test_release_place_and_regrasp(fig9):
    """Grasp -> release (tree splits) -> place on the table (non-rigid) -> the robot moves
    without it.
    """
    world = World(fig9)
    world.detach("part")
    assert world.parent("part") == WORLD and "part" not in world.subtree("robot")
    world.attach("part", "table.slot_part", "non_rigid", "rests_on")
    T_part = world.T_world("part")
    world.set_joints("robot", world.joints("robot") + 0.3)
    np.testing.assert_array_equal(world.T_world("part"), T_part)  # it stays on the table
    world.attach("part", "hand_a.tcp", "rigid", "grasp", T_parent_child=np.eye(4))
    np.testing.assert_allclose(world.T_world("part"), world.T_world("hand_a.tcp"), atol=1e-12)
    assert world.affixment("part").kind == "grasp"


def test_assembly_follows_its_base_but_not_the_converse(fig9):
    world = World(fig9)
    world.detach("housing")
    world.move("housing", np.eye(4))
    np.testing.assert_allclose(world.T_world("cap"), world.T("housing", "cap"), atol=1e-12)
    with pytest.raises(AffixmentError, match="rigidly affixed to 'shaft'"):
        world.move("cap", np.eye(4))


def test_resting_object_moves_alone():
    cell = load_cell("workcells/calibration_example").cell
    world = World(cell)
    T_table = world.T_world("table")
    target = world.T_world("block")
    target[:3, 3] += [0.01, 0.02, 0.0]
    world.move("block", target)  # B slides on A; A stays
    np.testing.assert_array_equal(world.T_world("table"), T_table)
    np.testing.assert_allclose(world.T_world("block"), target, atol=1e-12)


def test_tool_change_switches_the_active_tcp(fig9):
    world = World(fig9)
    assert world.active_tcp("robot") == "robot.tool_plate"
    world.detach("hand_a")
    world.attach("hand_a", "robot.tool_plate", "rigid", "tool")
    assert world.active_tcp("robot") == "hand_a.tcp"
    world.detach("hand_a")
    assert world.active_tcp("robot") == "robot.tool_plate"
    world.set_active_tcp("robot", "hand_b.tcp")  # a TCP of an aggregated hand
    assert world.active_tcp("robot") == "hand_b.tcp"
    with pytest.raises(Exception, match="not a TCP carried by"):
        world.set_active_tcp("robot", "hand_a.tcp")


@pytest.mark.parametrize(
    "child, parent, kind, message",
    [
        ("robot", "table.slot_part", None, "cannot hold device"),
        ("part", "drop_zone", None, "free frame"),
        ("conveyor", "robot.tool_plate", None, "cycle"),
        ("part", "part.grasp", None, "its own frame"),
        ("part", "table", "grasp", "a grasp holds"),
        ("table.slot_part", "world", None, "only primitives are affixed"),
    ],
)
def test_hierarchy_rules_enforced_at_run_time(fig9, child, parent, kind, message):
    world = World(fig9)
    with pytest.raises(AffixmentError, match=message):
        world.attach(child, parent, "rigid", kind)


def test_owned_frames_cannot_be_moved_or_detached(fig9):
    world = World(fig9)
    with pytest.raises(AffixmentError, match="owned by 'table'"):
        world.move("table.slot_part", np.eye(4))
    with pytest.raises(AffixmentError, match="not affixed"):
        world.detach("table")


def test_joint_values_checked_and_limits_reported(fig9):
    world = World(fig9)
    with pytest.raises(Exception, match="has 6 joint"):
        world.set_joints("robot", [0, 0])
    with pytest.raises(Exception, match="did you mean 'robot'"):
        world.set_joints("robt", np.zeros(6))
    world.set_joints("conveyor", [2.5])  # accepted for analysis ...
    assert world.joint_limit_violations("conveyor") == [(0, 2.5, 0.0, 2.0)]  # ... and reported
