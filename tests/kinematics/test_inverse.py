"""Inverse kinematics: FK(IK(T)) = T on reachable targets, clear failure on unreachable ones."""

from __future__ import annotations

import numpy as np
import pytest

from rworld_cli import spatial
from rworld_cli.kinematics.inverse import solve_ik
from rworld_cli.kinematics.jacobian import ToolMount, tool_pose
from rworld_cli.model.cell import JointLimits
from rworld_cli.schema.loader import load_cell
from tests.dynamics.test_properties import random_device


def with_limits(device, lo, hi):
    from dataclasses import replace

    joints = tuple(replace(j, limits=JointLimits(lower=lo, upper=hi)) for j in device.joints)
    return replace(device, joints=joints)


@pytest.mark.parametrize(
    "device",
    [
        load_cell("workcells/puma560").cell.devices["puma"],
        with_limits(random_device(11, "modified", "RRPRRR"), -2.5, 2.5),
        with_limits(random_device(12, "standard", "PRRRRR"), -2.5, 2.5),
    ],
    ids=["puma560", "modified-RRPRRR", "standard-PRRRRR"],
)
def test_fk_of_ik_round_trip(device):
    rng = np.random.default_rng(0)
    lo, hi = device.limit_array("lower"), device.limit_array("upper")
    mount = ToolMount(device.dof, spatial.make_transform(p=[0.0, 0.0, 0.1]))
    for _ in range(15):
        q_true = rng.uniform(lo, hi)
        target = tool_pose(device, q_true, mount)
        result = solve_ik(device, target, mount, seed=rng.uniform(lo, hi))
        assert result.success, (result.position_error, result.rotation_error)
        assert np.all(result.q >= lo - 1e-12) and np.all(result.q <= hi + 1e-12)
        np.testing.assert_allclose(tool_pose(device, result.q, mount), target, atol=1e-6)


def test_nearest_solution_to_the_seed_is_kept():
    """Started at a solution, IK returns it (not another branch)."""
    device = load_cell("workcells/puma560").cell.devices["puma"]
    q = np.array([0.3, 0.6, -2.5, 0.4, 0.5, -0.3])
    result = solve_ik(device, tool_pose(device, q), seed=q + 1e-3)
    np.testing.assert_allclose(result.q, q, atol=1e-6)


def test_unreachable_reports_distance_and_limits():
    device = load_cell("workcells/puma560").cell.devices["puma"]
    target = spatial.make_transform(p=[2.0, 0.0, 0.7])
    result = solve_ik(device, target, position_only=True)
    assert not result.success
    reach = (
        0.4318 + 0.4318 + 0.0203 + 0.15005
    )  # a generous bound of the arm's reach from the shoulder
    assert result.position_error > 2.0 - reach - 0.1


def test_wide_range_joints_take_the_turn_nearest_the_seed():
    """The UR5's joints range over +-360 deg: a solution a whole turn from the seed is the same
    pose, and IK returns the turn nearest the seed (within the limits)."""
    from tests.conftest import WORKCELLS

    device = load_cell(WORKCELLS / "ur5").cell.devices["ur5"]
    lower, upper = device.limit_array("lower"), device.limit_array("upper")
    rng = np.random.default_rng(5)
    for _ in range(20):
        q_true = rng.uniform(-np.pi, np.pi, 6)
        q_true[4] = rng.choice([-1, 1]) * rng.uniform(0.4, 2.7)  # clear of the wrist singularity
        seed = q_true + rng.uniform(-0.2, 0.2, 6)
        seed[3] += 2 * np.pi * rng.choice([-1, 1])  # the wrist a turn away
        seed = np.clip(seed, lower, upper)
        target = tool_pose(device, q_true)
        result = solve_ik(device, target, seed=seed)
        assert result.success
        np.testing.assert_allclose(tool_pose(device, result.q), target, atol=1e-6)
        # no whole turn within the limits brings any joint nearer the seed
        for k in (-1, 1):
            turned = result.q + 2 * np.pi * k
            inside = (turned >= lower) & (turned <= upper)
            assert np.all(~inside | (np.abs(turned - seed) >= np.abs(result.q - seed) - 1e-9))


def test_nearest_turns_keeps_prismatic_joints_and_limits():
    from rworld_cli.kinematics.inverse import nearest_turns

    q = np.array([3.0, 0.5, -3.0])
    seed = np.array([-3.0, 0.5 + 2 * np.pi, 3.0])
    revolute = np.array([True, False, True])
    lower, upper = np.array([-4.0, -10.0, -3.1]), np.array([4.0, 10.0, 3.1])
    got = nearest_turns(q, seed, revolute, lower, upper)
    # joint 1 turns down to 3 - 2 pi; joint 2 is prismatic; joint 3's turn would leave its range
    np.testing.assert_allclose(got, [3.0 - 2 * np.pi, 0.5, -3.0])


def test_a_line_tracked_with_a_joint_held_at_its_limit():
    """The LBR iiwa 14 (its vendor package's chain) starting with axis A6 at its lower limit:
    lines whose every pose the other six axes reach (joint paths with A6 fixed there) are
    tracked to the tolerance.  Clamping the step alone stalled where it pushed A6 further
    (a probe's line refused '2.45e-05 mm short' at 1 % of the path)."""
    from rworld_cli.kinematics.inverse import track

    device = load_cell("tests/data/probe_robots/iiwa14").cell.devices["kuka_lbr_iiwa_14_r820"]
    lo = device.limit_array("lower")
    q0 = np.array([1.06, 1.21, 0.64, 1.5, 0.7, lo[5], 0.14])
    rng = np.random.default_rng(3)
    s = np.linspace(0.0, 1.0, 41)[:, None]
    for _ in range(12):
        d = rng.normal(0.0, 0.3, 7)
        d[5] = 0.0  # A6 stays at its limit along the way
        targets = tool_pose(device, q0 + s * d)
        result = track(device, targets, q0)
        assert result.failed_at is None, (result.reason, result.error)
        reached = tool_pose(device, result.q)
        assert np.abs(reached[:, :3, 3] - targets[:, :3, 3]).max() < 1e-6
        assert (result.q[:, 5] >= lo[5]).all()
