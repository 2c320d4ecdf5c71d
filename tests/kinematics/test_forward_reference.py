"""Link poses of the world tree and the batched FK against the reference (Pinocchio / RTB)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rworld_cli.kinematics.forward import link_poses
from rworld_cli.model.cell import DeviceModel, Inertial, Joint, JointLimits, Link
from rworld_cli.schema.loader import load_cell
from rworld_cli.world.tree import World
from tests.conftest import REFERENCE


def device_from_reference(model: dict) -> DeviceModel:
    joints, links = [], []
    for i, row in enumerate(model["links"]):
        kind = "revolute" if row["joint"] == "R" else "prismatic"
        joints.append(
            Joint(
                f"j{i + 1}",
                kind,
                row["a"],
                row["alpha"],
                row["d"] or 0.0,
                row["theta"] or 0.0,
                JointLimits(),
            )
        )
        links.append(Link(f"link{i + 1}", Inertial.zero(), None))
    return DeviceModel(
        model["name"],
        model["dh_convention"],
        tuple(joints),
        tuple(links),
        (),
        np.zeros(len(joints)),
    )


@pytest.mark.parametrize("name", ["puma560.json", "ur5.json"])
def test_batched_link_poses_match_reference(name):
    ref = json.loads((REFERENCE / "dynamics" / name).read_text())
    device = device_from_reference(ref["model"])
    states = ref["model"]["states"]
    q = np.array([s["q"] for s in states])
    T = link_poses(device, q)  # (N, n, 4, 4), one call
    expected = np.array([s["T_links"] for s in states])
    np.testing.assert_allclose(T, expected, atol=1e-12, rtol=0)


def test_puma_cell_world_poses_match_reference():
    ref = json.loads((REFERENCE / "dynamics" / "puma560.json").read_text())
    world = World(load_cell("workcells/puma560").cell)
    for s in ref["model"]["states"]:
        world.set_joints("puma", s["q"])
        np.testing.assert_allclose(world.T_world("puma.tool"), s["T_tool"], atol=1e-12, rtol=0)
        for i, T in enumerate(s["T_links"]):
            np.testing.assert_allclose(world.T_world(f"puma.link{i + 1}"), T, atol=1e-12, rtol=0)
        np.testing.assert_allclose(
            world.T("puma.tool", "puma.probe")[:3, 3], [0, 0, 0.1], atol=1e-15
        )


def test_modified_dh_equals_standard_for_the_same_arm():
    """A standard table rewritten in modified form gives the same flange pose.

    Standard row i (a_i, alpha_i, d_i, theta_i) equals modified rows that carry
    (a_{i-1}, alpha_{i-1}) forward; the last link's (a_n, alpha_n) becomes a
    fixed tool transform.
    """
    from rworld_cli import spatial

    rng = np.random.default_rng(7)
    n = 5
    a, alpha, d = rng.normal(size=n), rng.uniform(-np.pi, np.pi, n), rng.normal(size=n)
    kinds = ["revolute", "prismatic", "revolute", "revolute", "prismatic"]

    def dev(conv, aa, al):
        joints = tuple(
            Joint(f"j{i}", kinds[i], aa[i], al[i], d[i], 0.0, JointLimits()) for i in range(n)
        )
        links = tuple(Link(f"l{i}", Inertial.zero(), None) for i in range(n))
        return DeviceModel("x", conv, joints, links, (), np.zeros(n))

    std = dev("standard", a, alpha)
    mod = dev("modified", np.r_[0.0, a[:-1]], np.r_[0.0, alpha[:-1]])
    q = rng.uniform(-1, 1, (20, n))
    tool = spatial.dh_standard(a[-1], alpha[-1], 0.0, 0.0)
    np.testing.assert_allclose(
        link_poses(std, q)[:, -1], link_poses(mod, q)[:, -1] @ tool, atol=1e-12
    )
