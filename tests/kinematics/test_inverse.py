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
