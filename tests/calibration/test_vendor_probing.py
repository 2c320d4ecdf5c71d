"""Probing and feature steps on vendor robots rworld was not built on (issue 60): each imported
from its vendor's ROS package as it ships (``tests/data/probe_robots``, SOURCE.md each), in a
cell with a table, the holed plate, a wall and a ball probe on a stem
(:mod:`tests.calibration.probe_cells`).  A program of feature steps (probes of the plate's
top, front face and two holes, then home by a free path) passes ``rworld check``, from the
vendor's zero pose and from a folded home, before and after a calibration that moves the
plate; ``plan-measurements --program`` writes a program that passes its own check.  Each robot
once here (one home, nominal or calibrated); every robot from both homes, before and after the
calibration, the planned programs too, in ``bench/probing_vendors.py`` (the figures:
docs/performance.md) - the suite keeps to its six minutes.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.calibration.probe_cells import calibrated_copy, probe_cell


@pytest.fixture(scope="module")
def cells(tmp_path_factory):
    root = tmp_path_factory.mktemp("probe_cells")
    return {
        (robot, home): probe_cell(robot, root / f"{robot}_{home}", home)
        for robot, home in (("ur10e", "zero"), ("kr6r900sixx", "zero"), ("gen3", "folded"))
    }


def test_feature_steps_pass_their_own_check(cli, cells):
    """The UR10e from its zero pose (the arm stretched level: its IK from there reached the
    plate elbow down, the forearm 60 mm in the table, before the transits were planned).  The
    KR 6 R900 sixx, the CR-7iA/L, the VS060 and the Gen3 from both homes: bench (10-25 s each,
    more than the suite's budget)."""
    cell = cells["ur10e", "zero"]
    result = cli(["check", str(cell), str(cell / "programs" / "features.yaml")])
    assert result.exit_code == 0, result.output
    assert "no collisions" in result.output


@pytest.mark.parametrize(
    "robot, home, calibrated",
    [
        ("kr6r900sixx", "folded", False),
        ("cr7ial", "zero", True),
        ("vs060", "folded", False),
        ("gen3", "zero", True),
    ],
)
def test_each_robots_feature_steps_pass_check(cli, tmp_path, robot, home, calibrated):
    """A test per robot (the UR10e's is above): the program of feature steps passes its
    check in the nominal cell, or in the cell whose plate a calibration moved - the same
    program, its targets moved with the plate (the re-planned transits too).  Half the robots
    each way here; every robot both ways in ``bench/probing_vendors.py``."""
    cell = probe_cell(robot, tmp_path / robot, home)
    features = str(cell / "programs" / "features.yaml")
    where = calibrated_copy(cell) if calibrated else cell
    result = cli(["check", str(where), features])
    assert result.exit_code == 0, (where.name, result.output)
    assert "no collisions" in result.output


def test_plan_measurements_writes_a_program_that_passes_check(cli, cells, tmp_path):
    cell = cells["ur10e", "zero"]
    program = tmp_path / "planned.yaml"
    planned = cli(["plan-measurements", str(cell), "--program", str(program)])
    assert planned.exit_code == 0, planned.output
    checked = cli(["check", str(cell), str(program)])
    assert checked.exit_code == 0, checked.output


def test_a_free_path_leaves_a_pair_that_starts_inside_the_search_margin(cells):
    """The KR 6's stem runs 0.7 mm beside its link 5 in every state: a free path searched with
    the 5 mm margin for that pair found nothing in 60 s; the pair keeps the clearance asked."""
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.planning.motion import plan_in_world
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.world.tree import World

    cell = load_cell(cells["kr6r900sixx", "zero"] / "cell.yaml").cell
    world = World(cell)
    plan, checks = plan_in_world(
        world,
        collision_model(cell),
        "kuka_kr6r900sixx",
        np.zeros(6),
        np.array([0.0, -1.2, 1.5, 0.0, 1.2, 0.0]),
        tolerance=0.001,
        timeout=10.0,
    )
    assert plan.found, plan.reason
    labels = {frozenset(checks.exact.model.bodies[k].label for k in pair) for pair in checks.tight}
    assert frozenset({"stylus", "kuka_kr6r900sixx.link_5"}) in labels
    # and said, with the distance (plan path prints it as a note, --json as inside_margin)
    assert plan.inside_margin[0].startswith(
        "stylus and kuka_kr6r900sixx.link_5 0.707 mm apart at the start, inside the search's "
        "5 mm margin"
    )


def test_a_continuous_joint_past_half_a_turn_is_planned_from_as_an_angle(cells):
    """A Gen3 joint 3 at 244.3 deg (where a probe step left it) and a goal at -100 deg: the
    same angle a turn apart is one state, so the path turns 15.7 deg, not 344 (the goal was
    refused 'outside the joint limits')."""
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.planning.motion import plan_in_world
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.world.tree import World

    cell = load_cell(cells["gen3", "folded"] / "cell.yaml").cell
    home = np.array(cell.devices["gen3"].home, dtype=float)
    start, goal = home.copy(), home.copy()
    start[2], goal[2] = np.radians(244.3), np.radians(-100.0)
    plan, _ = plan_in_world(
        World(cell), collision_model(cell), "gen3", start, goal, tolerance=0.001, timeout=10.0
    )
    assert plan.found, plan.reason
    travel = np.degrees(plan.waypoints[-1][2] - start[2])
    assert travel == pytest.approx(15.7, abs=1e-6)


def test_ik_takes_a_continuous_joints_turn_nearest_where_the_arm_is(cells):
    """The Gen3's joints 1, 3, 5 and 7 are continuous: IK from an arm whose joint 3 stands at
    350 deg answers a pose reached at -10 deg there with 350 deg (the same angle, no turn),
    and from -10 deg with -10 deg; a joint with limits is never moved out of them so."""
    from rworld_cli.kinematics.inverse import solve_ik
    from rworld_cli.kinematics.jacobian import tool_pose
    from rworld_cli.schema.loader import load_cell

    device = load_cell(cells["gen3", "folded"] / "cell.yaml").cell.devices["gen3"]
    continuous = ~np.isfinite(device.limit_array("lower"))
    assert continuous.tolist() == [True, False, True, False, True, False, True]
    q = np.array(device.home, dtype=float)
    q[2] = np.radians(-10.0)
    target = tool_pose(device, q)
    for seed_angle, want in ((350.0, 350.0), (-10.0, -10.0)):
        seed = q.copy()
        seed[2] = np.radians(seed_angle)
        result = solve_ik(device, target, seed=seed)
        assert result.success
        assert np.degrees(result.q[2]) == pytest.approx(want, abs=1e-6)
        assert np.allclose(tool_pose(device, result.q), target, atol=1e-9)
