"""Dynamics no real robot has, warned at import (issue 62): DENSO's VS060 package ships 1 kg
links with 1 kg m^2 inertias and 1 N m efforts (tests/data/probe_robots/vs060, imported as it
ships)."""

from __future__ import annotations

import numpy as np

from rworld_cli.dynamics.core import DEFAULT_GRAVITY
from rworld_cli.dynamics.plausible import efforts_below_gravity, inertia_beyond_size
from rworld_cli.schema.loader import load_cell
from tests.conftest import REPO, WORKCELLS

VS060 = REPO / "tests" / "data" / "probe_robots" / "vs060"


def test_inertia_is_bounded_by_mass_and_size():
    """About any axis through the centre of mass, I <= m R^2 (R: the farthest point): a solid
    ball (2/5 m r^2) and a thin ring (m R^2 about its axis, the bound itself) pass; 1 kg m^2
    on a 1 kg link that fits within 0.2 m does not."""
    ball = 0.4 * 2.0 * 0.1**2 * np.eye(3)
    assert inertia_beyond_size(2.0, ball, 0.1) is None
    ring = np.diag([0.5, 0.5, 1.0]) * 3.0 * 0.2**2
    assert inertia_beyond_size(3.0, ring, 0.2) is None
    largest, most = inertia_beyond_size(1.0, np.eye(3), 0.2)
    assert largest == 1.0 and most == 1.0 * 0.2**2


def test_placeholder_efforts_cannot_hold_the_arm():
    """The VS060's 1 N m: its shoulder and elbow need more to hold its 1 kg links (the torque
    reported is the gravity torque at the state reported, recomputed here by statics: the
    sum over the links beyond the joint of m g times the lever about its axis)."""
    device = load_cell(str(VS060)).cell.devices["vs060"]
    weak = efforts_below_gravity(device)
    assert [device.joints[j].name for j, _, _ in weak] == ["joint_2", "joint_3"]
    from rworld_cli.world.tree import World

    world = World(load_cell(str(VS060)).cell)
    for j, need, q in weak:
        world.set_joints("vs060", q)
        T_joint = world.T_world(device.link_frames[j])  # joint j moves link j+1's frame
        axis = T_joint[:3, :3] @ np.asarray(device.joints[j].axis, dtype=float)
        torque = 0.0
        for link, frame in zip(device.links[j:], device.link_frames[j:]):
            T = world.T_world(frame)
            com = T[:3, :3] @ link.inertial.com + T[:3, 3]
            force = link.inertial.mass * DEFAULT_GRAVITY  # the base upright
            torque += axis @ np.cross(com - T_joint[:3, 3], force)
        assert abs(abs(torque) - need) < 1e-9 * max(need, 1.0), (need, torque)
    # a real robot's efforts hold it: the example Puma's
    puma = load_cell(str(WORKCELLS / "puma560")).cell.devices["puma"]
    assert efforts_below_gravity(puma) == []


def test_the_import_warns_of_the_vs060s_placeholders(cli, tmp_path):
    urdf = tmp_path / "vs060.urdf"
    assert cli(["export", "urdf", str(VS060), "-o", str(urdf)]).exit_code == 0
    result = cli(["import", "urdf", str(urdf), "-o", str(tmp_path / "cell")])
    assert result.exit_code == 0, result.output
    assert "warning: inertial: the inertia of 6 link(s) is more than their mass and size allow" in (
        result.output
    )
    assert (
        "warning: limit: the effort limits of 2 joint(s) cannot hold the arm against gravity "
        "(joint_2 needs up to 19.6 (limit 1); joint_3 needs up to 8.12 (limit 1)"
    ) in result.output
