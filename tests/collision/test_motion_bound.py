"""The sweep's motion bound (``collision/sweep.py``): a joint that turns a sphere or cylinder
about its own axis - a base cylinder on the first joint, a wrist sphere - adds nothing to how
fast a pair's distance can change.  Checked against the distances themselves: turning such a
joint leaves every distance of that body as it was, and along real joint motions the distance
never changes faster than the bound says."""

from __future__ import annotations

import numpy as np
import pytest

from rworld_cli.collision import levers as lever_arms
from rworld_cli.collision import sweep
from rworld_cli.collision.bodies import collision_model, distances
from rworld_cli.schema.loader import load_cell
from rworld_cli.world.tree import World
from tests.conftest import WORKCELLS

CELLS = ["puma560", "ur5", "panda", "paper_fig9"]


def _setup(name: str):
    cell = load_cell(WORKCELLS / name).cell
    world = World(cell)
    model = collision_model(cell)
    joints = {
        d: (np.tile(dev.home, (2, 1)), np.zeros((2, dev.dof)), np.zeros((2, dev.dof)))
        for d, dev in cell.devices.items()
    }
    levers = lever_arms._Levers.of(world, model.bodies, joints)
    return cell, world, model, levers


def _all_distances(world, model, states: dict, of=None, deep_enough=0.0) -> np.ndarray:
    """(N, B, B) distances of every pair of bodies (``of``: those of that body) at N joint
    states (device -> (N, n)), minus their depths where they overlap: exact up to
    ``deep_enough`` (0: an overlap is only known to be one)."""
    bodies = model.bodies
    B = len(bodies)
    poses = sweep._poses(world, bodies, states)  # (B, N, 4, 4)
    N = poses.shape[1]
    I, J = np.triu_indices(B, 1)
    if of is not None:
        I, J = I[(I == of) | (J == of)], J[(I == of) | (J == of)]
    k = np.repeat(np.arange(N), len(I))
    I, J = np.tile(I, N), np.tile(J, N)
    res = distances(bodies, I, J, poses[I, k], poses[J, k], deep_enough=deep_enough)
    d = np.where(res.overlap, -res.depth, res.distance)
    out = np.zeros((N, B, B))
    out[k, I, J] = d
    out[k, J, I] = d
    return out


def test_the_pumas_round_bodies_are_found():
    cell, world, model, levers = _setup("puma560")
    found = {
        (model.bodies[b].label, levers.joints[c][1] + 1) for b, c in zip(*np.nonzero(levers.round))
    }
    # base and link1 cylinders on j1's axis; link4's cylinder on j5's; the wrist sphere on j5
    # and j6; the flange disc on j6.  The link boxes are round about nothing.
    assert found == {
        ("puma", 1),
        ("puma.link1", 1),
        ("puma.link4", 5),
        ("puma.link5", 5),
        ("puma.link5", 6),
        ("puma.link6", 6),
    }


@pytest.mark.parametrize("name", CELLS)
def test_turning_a_joint_about_a_round_body_changes_none_of_its_distances(name):
    cell, world, model, levers = _setup(name)
    rng = np.random.default_rng(7)
    flagged = list(zip(*np.nonzero(levers.round)))
    if name == "puma560":
        assert len(flagged) == 6
    for b, c in flagged:
        d, i = levers.joints[c]
        dev = cell.devices[d]
        lo, hi = dev.limit_array("lower"), dev.limit_array("upper")
        q = rng.uniform(np.maximum(lo, -np.pi), np.minimum(hi, np.pi), (8, dev.dof))
        turned = q.copy()
        turned[:, i] = rng.uniform(max(lo[i], -np.pi), min(hi[i], np.pi), 8)
        before = _all_distances(world, model, {d: q}, of=b, deep_enough=np.inf)
        after = _all_distances(world, model, {d: turned}, of=b, deep_enough=np.inf)
        # distances and depths (exact: convex.penetration) alike
        apart = before[:, b] > 0
        np.testing.assert_allclose(after[:, b][apart], before[:, b][apart], atol=1e-9)
        assert np.array_equal(after[:, b] > 0, apart)
        np.testing.assert_allclose(after[:, b][~apart], before[:, b][~apart], atol=1e-8)


@pytest.mark.parametrize("name, d", [("puma560", "puma"), ("paper_fig9", "robot")])
def test_distances_change_no_faster_than_the_bound_along_joint_motions(name, d):
    """Seeded straight joint motions over 20 ms, sampled 50 times: every pair's distance stays
    within its motion bound of the start (the bound with the round joints left out)."""
    cell, world, model, levers = _setup(name)
    dev = cell.devices[d]
    rng = np.random.default_rng(11)
    lo, hi = dev.limit_array("lower"), dev.limit_array("upper")
    B = len(model.bodies)
    I, J = np.triu_indices(B, 1)
    weights = levers.pair_weights(I, J)
    columns = [levers.joints.index((d, i)) for i in range(dev.dof) if (d, i) in levers.joints]
    checked = 0
    for _ in range(12):
        qa = rng.uniform(np.maximum(lo, -np.pi), np.minimum(hi, np.pi))
        velocity = rng.uniform(-2, 2, dev.dof)
        h = 0.02
        s = np.linspace(0, 1, 51)[:, None]
        q = qa + s * h * velocity
        dist = _all_distances(world, model, {d: q})[:, I, J]  # (51, P)
        travel = np.zeros((1, len(levers.joints)))
        travel[0, columns] = np.abs(h * velocity)[[levers.joints[c][1] for c in columns]]
        M = weights.bound(travel)[:, 0]  # (P,)
        change = np.abs(dist - dist[0]).max(axis=0)
        separate = dist.min(axis=0) > 0  # the bound is on distances, not on depths
        assert np.all(change[separate] <= M[separate] + 1e-12)
        checked += int(separate.sum())
    assert checked > 100


@pytest.mark.parametrize("convention, kinds", [("standard", "RPRRRR"), ("modified", "RRPRRR")])
def test_joint_axis_lines_are_what_each_turn_turns_about(convention, kinds):
    """The axis lines the round-body test uses, for DH tables of both kinds and joint-frame
    chains (the Panda's): at random states and turns, the points of the line before a joint
    stay put under its turn seen from before, those of the line after it under the turn seen
    from after, and a point off the line moves."""
    from tests.dynamics.test_properties import random_device

    devices = [random_device(3, convention, kinds), load_cell(WORKCELLS / "panda").cell.devices]
    devices[1] = next(iter(devices[1].values()))
    rng = np.random.default_rng(5)
    for dev in devices:
        lines = lever_arms._joint_axis_lines(dev)
        for i, joint in enumerate(dev.joints):
            if joint.kind != "revolute":
                assert lines[i] is None
                continue
            (pb, ub), (pa, ua) = lines[i]
            assert np.isclose(np.linalg.norm(ub), 1) and np.isclose(np.linalg.norm(ua), 1)
            for _ in range(5):
                q = rng.uniform(-2, 2, dev.dof)
                turned = q.copy()
                turned[i] += rng.uniform(-2, 2)
                A, B = dev.joint_transforms(q)[i], dev.joint_transforms(turned)[i]
                from_before, from_after = B @ np.linalg.inv(A), np.linalg.inv(A) @ B
                for M, p, u in ((from_before, pb, ub), (from_after, pa, ua)):
                    for s in (-1.0, 0.3, 2.0):
                        x = np.append(p + s * u, 1.0)
                        np.testing.assert_allclose(M @ x, x, atol=1e-12)
                    across = np.cross(u, np.eye(3)[np.argmin(np.abs(u))])
                    off = np.append(p + 0.1 * across / np.linalg.norm(across), 1.0)
                    assert np.linalg.norm(M @ off - off) > 1e-6
