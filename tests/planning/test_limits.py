"""Limits that a plan must never drop or leave unchecked (issue 19).

- A joint with no limit of a kind is unlimited in that kind alone: every other joint keeps its
limit.
- Position limits hold along the whole spline, found exactly; a path that leaves its range exits 1.
- Torque is bounded between the check points: a 10x denser sampling finds no excess.
- Controller output: fixed-rate rows, s / sdot / sddot columns, grid instants, external
trajectories.
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import yaml

from rworld_cli.api import planning_limits, unlimited_joints
from rworld_cli.dynamics import DeviceDynamics
from rworld_cli.planning.path import JointPath, range_excursions
from rworld_cli.planning.topp import (
    InfeasiblePath,
    Limits,
    limit_ratios,
    sample_trajectory,
    time_optimal,
)
from rworld_cli.schema.loader import load_cell
from tests.conftest import WORKCELLS
from tests.reference import device_from_reference, load_reference

PUMA_PATH = "workcells/puma560/paths/reference.yaml"
# j4 between its waypoints: the clamped spline reaches 170.84 deg against a limit of 170 (the
# issue's case)
J4_OUT = """device: puma
units: {angle: deg}
waypoints:
  - [-60, 30, -150, -100, 30, -45]
  - [-20, 50, -170, 169, 50, 0]
  - [20, 20, -130, -109, 10, 60]
  - [60, 40, -160, 169, 40, 30]
  - [90, 25, -140, -20, 20, -30]
boundary: clamped
"""
J4_OUT_MESSAGE = (
    "joint j4 leaves its position range between waypoints 4 and 5: 170.84 at s = "
    "0.7632, above its upper limit 170"
)


def puma_without(tmp_path, joint: str, *keys: str):
    """A copy of workcells/puma560 whose joint ``joint`` has no limit named by ``keys`` (e.g.
    'acceleration').
    """
    cell = tmp_path / "puma"
    shutil.copytree(WORKCELLS / "puma560", cell)
    doc = yaml.safe_load((cell / "cell.yaml").read_text())
    row = next(j for d in doc["devices"] for j in d["joints"] if j.get("name") == joint)
    for key in keys:
        del row["limits"][key]
    (cell / "cell.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    return cell


def plan(cell, off=(), torque=True):
    """Duration, dense limit ratios, limits and device of the reference path on ``cell``;
    ``off``: kinds left out.
    """
    from rworld_cli.api import device_context, device_dynamics, load_joint_path

    device = load_cell(cell).cell.devices["puma"]
    ctx = device_context(str(cell), "puma")
    path = load_joint_path(str(cell / "paths" / "reference.yaml"), device)
    limits = planning_limits(device, torque=torque, acceleration="acceleration" not in off)
    if "velocity" in off:
        limits.velocity = np.full(device.dof, np.inf)
    if "effort" in off:
        limits.effort = None
    dyn = device_dynamics(ctx, armature=True, friction=False) if limits.effort is not None else None
    timing, _ = time_optimal(path, limits, dyn, ctx.gravity_base, 300)
    _, q, qd, qdd = sample_trajectory(path, timing, 20001, switches=True)
    return timing.duration, limit_ratios(q, qd, qdd, limits, dyn, ctx.gravity_base), limits, device


@pytest.mark.parametrize(
    "kind, key, joint, base_off",
    [
        ("acceleration", "acceleration", "j1", ()),
        ("velocity", "velocity", "j1", ()),
        ("torque", "effort", "j2", ("acceleration",)),  # velocity + torque: the torque limits bind
    ],
)
def test_one_missing_limit_leaves_the_other_joints_limited(tmp_path, kind, key, joint, base_off):
    """One joint without a limit runs unlimited in it; the other joints' limits of that kind
    still bind.
    """
    torque = kind == "torque"
    full, _, _, _ = plan(WORKCELLS / "puma560", base_off, torque)
    cell = puma_without(tmp_path, joint, key)
    one, ratios, limits, device = plan(cell, base_off, torque)
    none, _, _, _ = plan(cell, base_off + (key,), torque)
    j = int(joint[1:]) - 1
    others = np.delete(ratios[kind], j, axis=1)
    assert others.max() <= 1.0  # the others hold their limits everywhere
    assert none < one * (1 - 1e-3)  # ... and they still cost time: without them the plan is faster
    assert one <= full * (1 + 1e-6)  # one joint freed can only help
    assert unlimited_joints(device, limits)[kind] == [joint]


def test_missing_acceleration_on_j4_does_not_switch_off_the_others(cli, tmp_path):
    """The issue's case: 1.4296 s came out when one acceleration limit was missing; the others
    must stay.
    """
    cell = puma_without(tmp_path, "j4", "acceleration")
    out = json.loads(
        cli(
            [
                "plan",
                "time-optimal",
                str(cell),
                "--path",
                str(cell / "paths" / "reference.yaml"),
                "--no-torque",
                "--json",
            ]
        ).stdout
    )
    assert out["duration"] == pytest.approx(1.8273, abs=2e-4)
    assert out["unlimited"] == {"acceleration": ["j4"]}
    assert out["peak_ratio"]["acceleration"] == pytest.approx(
        1.0, abs=1e-5
    )  # the other joints bind
    text = cli(
        [
            "plan",
            "time-optimal",
            str(cell),
            "--path",
            str(cell / "paths" / "reference.yaml"),
            "--no-torque",
        ]
    ).stdout
    assert "unlimited (no limit in the cell): acceleration of j4" in text


def test_missing_position_limit_is_unlimited_for_that_joint_alone(cli, tmp_path):
    cell = puma_without(tmp_path, "j4", "position")
    (cell / "paths" / "j4_out.yaml").write_text(J4_OUT)
    ok = cli(
        [
            "plan",
            "time-optimal",
            str(cell),
            "--path",
            str(cell / "paths" / "j4_out.yaml"),
            "--no-torque",
            "--json",
        ]
    )
    assert ok.exit_code == 0 and json.loads(ok.stdout)["unlimited"]["position"] == ["j4"]
    (cell / "paths" / "j5_out.yaml").write_text(
        J4_OUT.replace("[20, 20, -130, -109, 10, 60]", "[20, 20, -130, -109, 99, 60]").replace(
            "[-20, 50, -170, 169, 50, 0]", "[-20, 50, -170, 169, 99, 0]"
        )
    )
    bad = cli(
        [
            "plan",
            "time-optimal",
            str(cell),
            "--path",
            str(cell / "paths" / "j5_out.yaml"),
            "--no-torque",
        ]
    )
    assert bad.exit_code == 1 and "joint j5 leaves its position range" in bad.output


def test_the_simulator_applies_the_same_rule(cli, tmp_path):
    """Moves are timed by the joints that have limits; the output says which joints run
    unchecked.
    """
    cell = puma_without(tmp_path, "j4", "acceleration")
    out = json.loads(cli(["simulate", str(cell), "pick_place", "--json"]).stdout)
    assert out["unlimited"] == {"puma": {"acceleration": ["j4"]}}
    peaks = out["devices"]["puma"]["peak_ratio"]["acceleration"]
    # j4 has no ratio (null, never 0); the others still time the moves
    assert peaks[3] is None and max(p for p in peaks if p is not None) == pytest.approx(
        1.0, abs=1e-6
    )
    check = cli(["check", str(cell), "pick_place"])
    assert (
        check.exit_code == 0
        and "note: puma: no limit in the cell, so unchecked: acceleration of j4" in check.output
    )


def test_a_move_nothing_can_time_is_refused_with_its_step(cli, tmp_path):
    cell = tmp_path / "puma"
    shutil.copytree(WORKCELLS / "puma560", cell)
    doc = yaml.safe_load((cell / "cell.yaml").read_text())
    for j in doc["devices"][0]["joints"]:
        j["limits"].pop("acceleration", None)
    (cell / "cell.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    result = cli(["check", str(cell), "pick_place"])
    assert (
        result.exit_code == 2
        and "no joint of 'puma' has an acceleration limit, so nothing times its moves"
        in result.output
    )


def test_nothing_limiting_the_speed_is_an_error_not_an_infinite_plan():
    path = JointPath(np.array([[0.0, 0.0], [1.0, 0.5]]))
    with pytest.raises(InfeasiblePath, match="nothing limits the path speed"):
        time_optimal(path, Limits(np.array([np.inf, np.inf]), None, None), gridpoints=50)
    # one limited joint is enough
    timing, _ = time_optimal(
        path, Limits(np.array([np.inf, 1.0]), np.array([np.inf, 2.0]), None), gridpoints=50
    )
    assert np.isfinite(timing.duration) and timing.duration > 0


# --------------------------------------------------------------------------- position along the
# whole path


def test_exact_extrema_bound_a_fine_sampling_and_are_attained():
    rng = np.random.default_rng(7)
    for boundary in ("clamped", "natural", "not-a-knot"):
        for _ in range(20):
            k = int(rng.integers(2, 7))
            knots = np.concatenate([[0.0], np.sort(rng.uniform(0.05, 0.95, k - 2)), [1.0]])
            path = JointPath(rng.uniform(-2, 2, (k, 3)), knots, boundary)
            q_min, s_min, q_max, s_max = path.extrema()
            q = path.evaluate(np.linspace(0, 1, 200001))[0]
            assert np.all(q.min(axis=0) >= q_min - 1e-12) and np.all(q.max(axis=0) <= q_max + 1e-12)
            np.testing.assert_allclose(q.min(axis=0), q_min, atol=1e-8)
            np.testing.assert_allclose(q.max(axis=0), q_max, atol=1e-8)
            np.testing.assert_allclose(
                path.evaluate(s_max)[0][np.arange(3), np.arange(3)], q_max, atol=1e-12
            )


def test_range_excursions_name_joint_s_value_and_limit():
    path = JointPath(np.radians([[-100.0], [169.0], [-109.0], [169.0], [-20.0]]))
    (e,) = range_excursions(path, np.radians([-110.0]), np.radians([170.0]))
    assert (
        e.joint == 0
        and e.side == "upper"
        and np.degrees(e.value) == pytest.approx(170.84, abs=0.005)
    )
    assert e.s == pytest.approx(0.7632, abs=1e-4) and np.degrees(e.limit) == pytest.approx(170.0)


@pytest.mark.parametrize(
    "command",
    [
        ["plan", "time-optimal", "--no-torque"],
        ["plan", "payload"],
        ["plan", "payload", "--timing", "quintic", "--duration", "5"],
        ["plan", "load-optimal", "--duration", "5", "--gridpoints", "50"],
    ],
)
def test_a_path_leaving_its_range_exits_1_naming_joint_s_value_and_limit(cli, tmp_path, command):
    (tmp_path / "out.yaml").write_text(J4_OUT)
    out = tmp_path / "traj.csv"
    extra = ["-o", str(out)] if command[1] != "payload" else []
    result = cli(
        command[:2]
        + ["workcells/puma560", "--path", str(tmp_path / "out.yaml")]
        + command[2:]
        + extra
    )
    assert result.exit_code == 1
    assert f"out.yaml:8:20: waypoints[4][3]: {J4_OUT_MESSAGE}" in result.output
    assert not out.exists()


def test_validate_checks_path_files_against_their_cell(cli, tmp_path):
    ok = cli(["validate", PUMA_PATH])
    assert ok.exit_code == 0 and "within its position range all along" in ok.output
    (tmp_path / "out.yaml").write_text(J4_OUT)
    alone = cli(["validate", str(tmp_path / "out.yaml")])
    assert alone.exit_code == 0 and "--cell" in alone.output  # no cell known: the format alone
    bad = cli(["validate", "--cell", "workcells/puma560", str(tmp_path / "out.yaml")])
    assert bad.exit_code == 2 and J4_OUT_MESSAGE in bad.output


@pytest.mark.parametrize(
    "text, located",
    [
        (
            "waypoints:\n  - [0, 0, 0, 0, 0, 0]\n  - [0, 0, 400, 0, 0, 0]\nunits: {angle: deg}\n",
            "p.yaml:3:12: waypoints[1][2]: 400.0 is outside the position limits of j3 [-225, 45]",
        ),
        (
            "waypoints:\n  - [0, 0, 0, 0, 0, 0]\n  - [1, 1, 1, 1, 1, 1]\n  - [0, 0, 0, 0, 0, "
            "0]\nknots: [0, 0.7, 0.3]\nunits: {angle: rad}\n",
            "p.yaml:5:8: knots: knots must rise strictly from 0 to 1",
        ),
        (
            "waypoints:\n  - [0, 0, 0, 0, 0, 0]\n  - [1, 1, 1, 1, 1, 1]\n  - [0, 1, 0, 0, 0, "
            "0]\nboundary: blended\nblends: [0, 0.7, 0]\nunits: {angle: rad}\n",
            "p.yaml:6:13: blends[1]: 0.7 is outside [0, 0.5] (a fraction)",
        ),
        (
            "waypoints:\n  - [0, 0, 0, 0, 0, 0]\n  - [1, 1, 1, 1, 1, 1]\n  - [0, 1, 0, 0, 0, "
            "0]\nboundary: blended\nblends: [0.1, 0.2, 0]\nunits: {angle: rad}\n",
            "p.yaml:6:10: blends[0]: the path's ends are at rest: blend 0",
        ),
        (
            "waypoints:\n  - [0, 0, 0, 0, 0, 0]\n  - [1, 1, 1, 1, 1, 1]\n  - [0, 1, 0, 0, 0, "
            "0]\nboundary: blended\nblends: [0, 0.2]\nunits: {angle: rad}\n",
            "p.yaml:6:9: blends: 2 blend(s) for 3 waypoints: one each",
        ),
        (
            "waypoints:\n  - [0, 0, 0, 0, 0, 0]\n  - [1, 1, 1, 1, 1, 1]\n  - [0, 1, 0, 0, 0, "
            "0]\nboundary: blended\nknots: [0, 0.5, 1]\nunits: {angle: rad}\n",
            "p.yaml:6:8: knots: a blended path's knots follow its joint-space lengths: remove "
            "'knots'",
        ),
        (
            "waypoints:\n  - [0, 0, 0, 0, 0, 0]\n  - [0, 0, 0, 0, 0, 0]\n  - [1, 1, 1, 1, 1, 1]\n"
            "boundary: blended\nunits: {angle: rad}\n",
            "p.yaml:3:5: waypoints[1]: waypoint 2 repeats waypoint 1",
        ),
        (
            "waypoints:\n  - [0, 0, 0, 0, 0, 0]\n  - [1, 1, 1, 1, 1, 1]\nblends: [0, 0]\n"
            "units: {angle: rad}\n",
            "p.yaml:4:9: blends: blends are for 'boundary: blended'",
        ),
        (  # issue 58: knots 1e-300 apart made NaN pass and a 2e300 s "time-optimal" duration
            "waypoints:\n  - [0, 0, 0, 0, 0, 0]\n  - [1, 1, 1, 1, 1, 1]\n  - [0, 1, 0, 0, 0, "
            "0]\nknots: [0, 1.0e-300, 1]\nunits: {angle: rad}\n",
            "p.yaml:5:8: knots: knots must rise strictly from 0 to 1 (each step at least 1e-09)",
        ),
        (
            "waypoints:\n  - [0, 0, 0, 0, 0, 0]\n  - [1, .nan, 1, 1, 1, 1]\nunits: {angle: rad}\n",
            "p.yaml:3:9: waypoints[1][1]: expected a finite number, got nan",
        ),
        (
            "device: ur5\nwaypoints:\n  - [0, 0, 0, 0, 0, 0]\n  - [1, 1, 1, 1, 1, 1]\n"
            "units: {angle: rad}\n",
            "p.yaml:1:9: device: the path is for 'ur5', not for 'puma'",
        ),
    ],
)
def test_bad_waypoints_and_knots_exit_2_located_and_write_nothing(cli, tmp_path, text, located):
    (tmp_path / "p.yaml").write_text(text)
    out = tmp_path / "traj.csv"
    result = cli(
        [
            "plan",
            "time-optimal",
            "workcells/puma560",
            "--path",
            str(tmp_path / "p.yaml"),
            "-o",
            str(out),
        ]
    )
    assert result.exit_code == 2 and located in result.output and not out.exists()


def test_impulse_paths_stay_in_range():
    from rworld_cli.api import device_context, device_dynamics
    from rworld_cli.kinematics.inverse import solve_ik
    from rworld_cli.planning.impulse import max_impulse

    ctx = device_context("workcells/puma560", "puma", "probe")
    q_end = solve_ik(
        ctx.device,
        np.linalg.inv(ctx.T_world_base) @ ctx.world.T_world("table.drop"),
        ctx.mount,
        ctx.device.home,
    ).q
    r = max_impulse(
        ctx.device,
        ctx.device.home,
        q_end,
        [0, 0, -1],
        0.0,
        [0, 0, 0],
        planning_limits(ctx.device),
        device_dynamics(ctx, friction=False),
        ctx.gravity_base,
        ctx.mount,
        100,
        10,
    )
    assert not range_excursions(
        r.path, ctx.device.limit_array("lower"), ctx.device.limit_array("upper")
    )


# --------------------------------------------------------------------------- torque between check
# points


def ur5_case():
    """A UR5 (reference model, UR's velocity and torque limits) on a natural spline with uneven
    knots.
    """
    device = device_from_reference(load_reference("ur5.json")["model"])
    waypoints = np.array(
        [
            [0, -1.6, 1.4, -1.4, -1.57, 0],
            [0.9, -1.0, 1.9, -2.2, -1.2, 0.7],
            [1.8, -1.9, 0.6, -0.8, -1.9, 1.6],
            [2.4, -1.2, 1.5, -1.6, -1.0, 0.2],
            [3.0, -1.57, 1.57, -1.57, -1.57, 0],
        ]
    )
    path = JointPath(waypoints, [0, 0.12, 0.47, 0.71, 1.0], "natural")
    limits = Limits(np.full(6, np.pi), None, np.array([150, 150, 150, 28, 28, 28.0]))
    return path, limits, DeviceDynamics(device, armature=False, friction=False)


@pytest.mark.parametrize("grid", [100, 300])
def test_torque_bound_holds_ten_times_denser_than_the_check(grid):
    """Torque is bounded on 20 001 points of s; 200 001 instants (and both sides of every
    switch) find no excess.
    """
    path, limits, dyn = ur5_case()
    g = np.array([0, 0, -9.81])
    timing, info = time_optimal(path, limits, dyn, g, grid, check_samples=20001)
    assert info["dense_ratio"] <= 1.0 and timing.scale <= 1.0 + 1e-5  # at most a trace settled
    _, q, qd, qdd = sample_trajectory(path, timing, 200001, switches=True)
    ratios = limit_ratios(q, qd, qdd, limits, dyn, g)
    assert ratios["torque"].max() <= 1.0 and ratios["velocity"].max() <= 1.0
    plain, _ = time_optimal(
        path, limits, dyn, g, grid, repair=False
    )  # the grid solution alone exceeds torque in between
    _, q, qd, qdd = sample_trajectory(path, plain, 200001, switches=True)
    assert limit_ratios(q, qd, qdd, limits, dyn, g)["torque"].max() > 1.0 + 1e-4


def test_torque_bound_holds_with_a_coarse_check():
    """The bound carries the interpolation error, so even 2 001 check points keep 200 001
    samples within the limit.
    """
    path, limits, dyn = ur5_case()
    g = np.array([0, 0, -9.81])
    timing, _ = time_optimal(path, limits, dyn, g, 100, check_samples=2001)
    _, q, qd, qdd = sample_trajectory(path, timing, 200001, switches=True)
    assert limit_ratios(q, qd, qdd, limits, dyn, g)["torque"].max() <= 1.0


# --------------------------------------------------------------------------- output for controllers


def test_fixed_rate_rows_with_path_columns_and_grid_instants(cli, tmp_path):
    out = tmp_path / "t.csv"
    data = json.loads(
        cli(
            [
                "plan",
                "time-optimal",
                "workcells/puma560",
                "--path",
                PUMA_PATH,
                "--gridpoints",
                "200",
                "--period",
                "8ms",
                "-o",
                str(out),
                "--json",
            ]
        ).stdout
    )
    header, *rows = out.read_text().splitlines()
    cols = header.split(",")
    assert cols[:4] == ["t", "s", "sd", "sdd"] and "tau6" in cols
    table = np.array([[float(v) for v in r.split(",")] for r in rows])
    np.testing.assert_allclose(np.diff(table[:, 0]), 0.008, atol=1e-12)
    assert table[-1, 0] >= data["duration"] > table[-2, 0]
    assert (
        table[-1, 1] == 1.0 and table[-1, 2] == 0.0 and table[-1, 3] == 0.0
    )  # the last row is at rest at the end
    assert np.all(np.diff(table[:, 1]) >= 0) and np.all(table[:, 2] >= 0)
    with_grid = tmp_path / "g.csv"
    cli(
        [
            "plan",
            "time-optimal",
            "workcells/puma560",
            "--path",
            PUMA_PATH,
            "--gridpoints",
            "200",
            "--samples",
            "101",
            "--grid-instants",
            "-o",
            str(with_grid),
        ]
    )
    assert len(with_grid.read_text().splitlines()) == 1 + 101 + 2 * 198
    both = cli(
        [
            "plan",
            "time-optimal",
            "workcells/puma560",
            "--path",
            PUMA_PATH,
            "--samples",
            "10",
            "--period",
            "8ms",
        ]
    )
    assert both.exit_code == 2 and "not both" in both.output
    bad = cli(
        ["plan", "time-optimal", "workcells/puma560", "--path", PUMA_PATH, "--period", "fast"]
    )
    assert bad.exit_code == 2 and "is not a positive duration" in bad.output


def test_payload_of_an_externally_timed_trajectory(cli, tmp_path):
    """A plan written out and read back has the capacity the plan itself reports."""
    csv = tmp_path / "traj.csv"
    cli(
        [
            "plan",
            "time-optimal",
            "workcells/puma560",
            "--path",
            PUMA_PATH,
            "--no-torque",
            "--grid-instants",
            "-o",
            str(csv),
        ]
    )
    external = json.loads(
        cli(
            [
                "plan",
                "payload",
                "workcells/puma560",
                "--trajectory",
                str(csv),
                "--tcp",
                "probe",
                "--json",
            ]
        ).stdout
    )
    internal = json.loads(
        cli(
            [
                "plan",
                "payload",
                "workcells/puma560",
                "--path",
                PUMA_PATH,
                "--tcp",
                "probe",
                "--json",
            ]
        ).stdout
    )
    assert external["payload_mass"] == pytest.approx(internal["payload_mass"], abs=1e-9)
    assert (
        external["timing"] == "external" and external["binding_joint"] == internal["binding_joint"]
    )


def test_a_trajectory_whose_time_goes_back_exits_2_located(cli, tmp_path):
    csv = tmp_path / "traj.csv"
    cli(
        [
            "plan",
            "time-optimal",
            "workcells/puma560",
            "--path",
            PUMA_PATH,
            "--no-torque",
            "--samples",
            "50",
            "-o",
            str(csv),
        ]
    )
    lines = csv.read_text().splitlines()
    fields = lines[11].split(",")
    fields[0] = "0.001"
    lines[11] = ",".join(fields)
    csv.write_text("\n".join(lines) + "\n")
    result = cli(["plan", "payload", "workcells/puma560", "--trajectory", str(csv)])
    assert result.exit_code == 2
    assert "traj.csv:12:1: column 't': time 0.001 comes before the row above" in result.output
    neither = cli(["plan", "payload", "workcells/puma560"])
    assert neither.exit_code == 2 and "--path FILE" in neither.output
