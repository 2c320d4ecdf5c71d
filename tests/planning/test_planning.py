"""Time-optimal timing and payload capacity against the reference problem (toppra 0.6.10
results).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from rworld_cli.dynamics import DeviceDynamics
from rworld_cli.planning.path import JointPath
from rworld_cli.planning.payload import payload_capacity, quintic_timing
from rworld_cli.planning.topp import (
    InfeasiblePath,
    Limits,
    limit_ratios,
    sample_trajectory,
    time_optimal,
)
from rworld_cli.schema.loader import load_cell
from tests.conftest import REFERENCE, WORKCELLS

REF = json.loads((REFERENCE / "planning" / "puma560_path.json").read_text())
DEVICE = load_cell(WORKCELLS / "puma560").cell.devices["puma"]
PATH = JointPath(np.radians(REF["waypoints_deg"]))
G = np.array(REF["gravity"])
DYN = DeviceDynamics(DEVICE, armature=True, friction=False)
V = np.array(REF["vel_lim_rad_s"])
CONFIGS = {
    "a_rated": (Limits(V, np.array(REF["acc_lim_rated_rad_s2"]), None), False),
    "b_rated": (
        Limits(V, np.array(REF["acc_lim_rated_rad_s2"]), np.array(REF["tau_lim_Nm"])),
        True,
    ),
    "b_aggr": (
        Limits(V, np.array(REF["acc_lim_aggressive_rad_s2"]), np.array(REF["tau_lim_Nm"])),
        True,
    ),
    "c_vtau": (Limits(V, None, np.array(REF["tau_lim_Nm"])), True),
}


def toppra_duration(config, grid):
    return next(
        r["duration_s"]
        for r in REF["toppra_results"]
        if r["config"] == config and r["gridpoints"] == grid
    )


@pytest.mark.parametrize("config", CONFIGS)
@pytest.mark.parametrize("grid", [100, 500, 1000])
def test_grid_solution_is_toppras(config, grid):
    """Before the checks between grid points, the grid problem is the one toppra solves (same
    grid points).
    """
    limits, torque = CONFIGS[config]
    timing, info = time_optimal(PATH, limits, DYN if torque else None, G, grid, repair=False)
    assert timing.duration == pytest.approx(toppra_duration(config, grid), rel=1e-6)
    assert info["rounds"] == 1 and info["repaired"] == 0


@pytest.mark.parametrize("config", CONFIGS)
@pytest.mark.parametrize("grid", [100, 500, 1000])
def test_cycle_time_within_a_tenth_of_a_percent_of_toppra_and_no_violation(config, grid):
    limits, torque = CONFIGS[config]
    timing, info = time_optimal(PATH, limits, DYN if torque else None, G, grid)
    assert 1.0 <= timing.duration / toppra_duration(config, grid) < 1.001  # issue target: 0.5 %
    assert (
        info["dense_ratio"] <= 1.0 and timing.scale == 1.0
    )  # settled by local repairs, no uniform slow-down
    # zero violations on 20 001 samples (the reference's check)
    _, q, qd, qdd = sample_trajectory(PATH, timing, 20001)
    for name, r in limit_ratios(q, qd, qdd, limits, DYN if torque else None, G).items():
        assert r.max() <= 1.0, (name, r.max())


@pytest.mark.parametrize("grid", [17, 60])
def test_exact_maxima_between_grid_points(grid):
    """The closed-form interval maxima of velocity and acceleration bound a fine sampling and
    are attained.
    """
    from rworld_cli.planning.constraints import Segments
    from rworld_cli.planning.topp import constraints_from_limits, interval_excess

    limits, _ = CONFIGS["a_rated"]
    timing, _ = time_optimal(
        PATH, limits, None, G, grid, repair=False
    )  # coarse: the grid solution overshoots inside
    loose = Limits(
        np.ones(6), np.ones(6), None
    )  # unit limits: the ratios are the values themselves
    _, _, worst = interval_excess(timing, constraints_from_limits(loose), Segments(PATH, timing.s))
    _, q, qd, qdd = sample_trajectory(PATH, timing, 400001, switches=True)
    sampled = max(np.abs(qd).max(), np.abs(qdd).max())
    assert sampled <= worst * (1 + 1e-12)
    assert sampled == pytest.approx(worst, rel=1e-6)
    ratios = limit_ratios(q, qd, qdd, limits)
    assert (
        max(r.max() for r in ratios.values()) > 1.001
    )  # the unrepaired grid solution exceeds a limit between grid points


def test_payload_capacity_on_the_rated_time_optimal_timing_matches_the_reference():
    """The reference's 6.577 kg: toppra's timing at 1000 grid points, sampled at 20 001 instants."""
    cap_ref = next(c for c in REF["payload_capacity"] if c["label"] == "toppra v+a(rated) optimal")
    limits, _ = CONFIGS["a_rated"]
    for repair in (False, True):
        timing, _ = time_optimal(PATH, limits, None, G, 1000, repair=repair)
        t, q, qd, qdd = sample_trajectory(PATH, timing, 20001)
        cap = payload_capacity(DEVICE, q, qd, qdd, G, [0, 0, 0.1])
        assert cap.mass == pytest.approx(cap_ref["m_star_linear_kg"], abs=1e-4)
        assert cap.joint + 1 == cap_ref["binding_joint"] and cap.side == cap_ref["binding_side"]
        assert t[cap.sample] == pytest.approx(cap_ref["binding_time_s"], abs=1e-3)
        # the acceleration jumps at grid instants; with both sides of each counted, the capacity is
        # a little lower
        exact = payload_capacity(
            DEVICE, *sample_trajectory(PATH, timing, 20001, switches=True)[1:], G, [0, 0, 0.1]
        )
        fine = payload_capacity(
            DEVICE, *sample_trajectory(PATH, timing, 400001)[1:], G, [0, 0, 0.1]
        )
        assert (
            exact.mass <= fine.mass <= cap.mass
        )  # finer sampling creeps down towards it (the sawtooth is steep)
        assert fine.mass - exact.mass < 2e-4 < cap.mass - exact.mass


def test_switch_samples_take_both_sides_of_each_grid_instant():
    limits, _ = CONFIGS["a_rated"]
    timing, _ = time_optimal(PATH, limits, None, G, 50)
    t, q, qd, qdd = sample_trajectory(PATH, timing, 11, switches=True)
    assert len(t) == 11 + 2 * 48 and np.all(np.diff(t) >= 0)
    k = 10  # grid instant 10: the last sample of interval 9, then the first of interval 10
    i = int(np.flatnonzero(t == timing.t[k])[0])
    np.testing.assert_allclose(q[i], q[i + 1], atol=1e-12)
    np.testing.assert_allclose(qd[i], qd[i + 1], atol=1e-12)
    s, dq, ddq = PATH.evaluate(np.array([timing.s[k]]))
    np.testing.assert_allclose(qdd[i], ddq[0] * timing.x[k] + dq[0] * timing.u[k - 1], atol=1e-9)
    np.testing.assert_allclose(qdd[i + 1], ddq[0] * timing.x[k] + dq[0] * timing.u[k], atol=1e-9)


def test_finer_grids_converge():
    limits, _ = CONFIGS["a_rated"]
    durations = [time_optimal(PATH, limits, None, G, n)[0].duration for n in (250, 1000, 4000)]
    assert durations[0] > durations[1] > durations[2]
    assert durations[2] == pytest.approx(toppra_duration("a_rated", 5000), rel=3e-4)


def test_starts_and_ends_at_rest_and_follows_the_path():
    timing, _ = time_optimal(PATH, CONFIGS["b_rated"][0], DYN, G, 1000)
    t, q, qd, _ = sample_trajectory(PATH, timing, 2001)
    np.testing.assert_allclose(qd[0], 0, atol=1e-12)
    np.testing.assert_allclose(qd[-1], 0, atol=1e-6)
    np.testing.assert_allclose(q[0], np.radians(REF["waypoints_deg"][0]), atol=1e-12)
    np.testing.assert_allclose(q[-1], np.radians(REF["waypoints_deg"][-1]), atol=1e-9)


def test_payload_capacity_on_the_quintic_matches_the_reference():
    cap_ref = next(c for c in REF["payload_capacity"] if c["label"].startswith("quintic"))
    t, s, sd, sdd = quintic_timing(5.0, 20001)
    q, dq, ddq = PATH.evaluate(s)
    cap = payload_capacity(
        DEVICE, q, dq * sd[:, None], ddq * (sd**2)[:, None] + dq * sdd[:, None], G, [0, 0, 0.1]
    )
    assert cap.mass == pytest.approx(cap_ref["m_star_linear_kg"], abs=1e-3)
    assert cap.joint + 1 == cap_ref["binding_joint"] and cap.side == cap_ref["binding_side"]
    assert t[cap.sample] == pytest.approx(cap_ref["binding_time_s"], abs=1e-3)


def test_payload_capacity_is_exact():
    """At m* the binding joint sits exactly on its limit; a heavier payload overloads it."""
    from rworld_cli.dynamics import Payload

    t, s, sd, sdd = quintic_timing(5.0, 2001)
    q, dq, ddq = PATH.evaluate(s)
    qd, qdd = dq * sd[:, None], ddq * (sd**2)[:, None] + dq * sdd[:, None]
    cap = payload_capacity(DEVICE, q, qd, qdd, G, [0, 0, 0.1])
    at = DeviceDynamics(
        DEVICE, Payload.point_mass(cap.mass, [0, 0, 0.1]), armature=True, friction=False
    ).inverse(q, qd, qdd, G)
    ratio = np.abs(at) / DEVICE.limit_array("effort")
    assert ratio.max() == pytest.approx(1.0, abs=1e-12)
    over = DeviceDynamics(
        DEVICE, Payload.point_mass(cap.mass + 1e-6, [0, 0, 0.1]), armature=True, friction=False
    ).inverse(q, qd, qdd, G)
    assert (np.abs(over) / DEVICE.limit_array("effort")).max() > 1.0


def test_payload_slows_the_torque_limited_timing():
    from rworld_cli.dynamics import Payload

    limits, _ = CONFIGS["c_vtau"]
    light = time_optimal(PATH, limits, DYN, G, 500)[0].duration
    heavy_dyn = DeviceDynamics(
        DEVICE, Payload.point_mass(3.0, [0, 0, 0.1]), armature=True, friction=False
    )
    heavy = time_optimal(PATH, limits, heavy_dyn, G, 500)[0].duration
    assert heavy > light


def test_infeasible_when_gravity_exceeds_a_limit():
    weak = Limits(V, None, np.array(REF["tau_lim_Nm"]) * [1, 0.05, 1, 1, 1, 1])
    with pytest.raises(InfeasiblePath):
        time_optimal(PATH, weak, DYN, G, 200)


def test_plan_commands(cli, tmp_path):
    path = "workcells/puma560/paths/reference.yaml"
    data = json.loads(
        cli(
            [
                "plan",
                "time-optimal",
                "workcells/puma560",
                "--path",
                path,
                "--json",
                "-o",
                str(tmp_path / "t.csv"),
                "--plot",
                str(tmp_path / "t.png"),
            ]
        ).stdout
    )
    assert data["duration"] == pytest.approx(toppra_duration("b_rated", 1000), rel=0.005)
    assert max(data["peak_ratio"].values()) <= 1.0
    assert (tmp_path / "t.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "t.csv").read_text().startswith("t,s,sd,sdd,q1,")
    q = json.loads(
        cli(
            [
                "plan",
                "payload",
                "workcells/puma560",
                "--path",
                path,
                "--tcp",
                "probe",
                "--timing",
                "quintic",
                "--duration",
                "5",
                "--json",
            ]
        ).stdout
    )
    assert (
        q["payload_mass"] == pytest.approx(11.566531603971516, abs=1e-3)
        and q["binding_joint"] == "j2"
    )


def test_bad_path_file_is_located(cli, tmp_path):
    (tmp_path / "p.yaml").write_text(
        "units: {angle: deg}\nwaypoints:\n  - [0, 0, 0]\n  - [1, 2, 3, 4, 5, 6]\n"
    )
    result = cli(["plan", "time-optimal", "workcells/puma560", "--path", str(tmp_path / "p.yaml")])
    assert (
        result.exit_code == 2
        and "p.yaml:3:5: waypoints[0]: 3 value(s) but 'puma' has 6 joint(s)" in result.output
    )


def test_load_optimal_beats_the_quintic_and_respects_the_limits():
    from rworld_cli.dynamics import Payload
    from rworld_cli.planning.payload import load_optimal

    limits = Limits(V, np.array(REF["acc_lim_rated_rad_s2"]), np.array(REF["tau_lim_Nm"]))
    r = load_optimal(DEVICE, PATH, limits, G, [0, 0, 0.1], 5.0, gridpoints=200, tolerance=1e-3)
    assert r.quintic_capacity == pytest.approx(11.566531603971516, abs=1e-3)
    assert r.quintic_capacity < r.mass <= r.static_capacity
    assert r.timing.duration == pytest.approx(5.0)
    dyn = DeviceDynamics(
        DEVICE, Payload.point_mass(r.mass, [0, 0, 0.1]), armature=True, friction=False
    )
    _, q, qd, qdd = sample_trajectory(PATH, r.timing, 20001)
    assert max(np.max(v) for v in limit_ratios(q, qd, qdd, limits, dyn, G).values()) <= 1.0
    heavier = DeviceDynamics(
        DEVICE, Payload.point_mass(r.mass + 0.05, [0, 0, 0.1]), armature=True, friction=False
    )
    assert (
        time_optimal(PATH, limits, heavier, G, 200)[0].duration > 5.0
    )  # 50 g more no longer fits in 5 s


def test_load_optimal_command(cli):
    data = json.loads(
        cli(
            [
                "plan",
                "load-optimal",
                "workcells/puma560",
                "--path",
                "workcells/puma560/paths/reference.yaml",
                "--tcp",
                "probe",
                "--duration",
                "5",
                "--gridpoints",
                "100",
                "--tolerance",
                "0.01",
                "--json",
            ]
        ).stdout
    )
    assert data["payload_mass"] > data["quintic_capacity"] > data["time_optimal_capacity"]
    result = cli(
        [
            "plan",
            "load-optimal",
            "workcells/puma560",
            "--path",
            "workcells/puma560/paths/reference.yaml",
            "--duration",
            "0.5",
        ]
    )
    assert result.exit_code == 2 and "cannot be done in 0.5 s" in result.output


def test_max_impulse_arrives_along_the_direction_within_limits():
    from rworld_cli.api import device_context, device_dynamics, planning_limits
    from rworld_cli.dynamics import Payload
    from rworld_cli.kinematics.inverse import solve_ik
    from rworld_cli.kinematics.jacobian import jacobian
    from rworld_cli.planning.impulse import HermitePath, max_impulse

    ctx = device_context("workcells/puma560", "puma", "probe")
    q_end = solve_ik(
        ctx.device,
        np.linalg.inv(ctx.T_world_base) @ ctx.world.T_world("table.drop"),
        ctx.mount,
        ctx.device.home,
    ).q
    limits = planning_limits(ctx.device)
    dyn = device_dynamics(ctx, Payload.point_mass(2.0, [0, 0, 0]), armature=True, friction=False)
    r = max_impulse(
        ctx.device,
        ctx.device.home,
        q_end,
        [0, 0, -1],
        2.0,
        [0, 0, 0],
        limits,
        dyn,
        ctx.gravity_base,
        ctx.mount,
        200,
        16,
    )
    assert r.momentum == pytest.approx(2.0 * r.speed_along) and r.speed_along > 0.3
    np.testing.assert_allclose(
        r.end_velocity / np.linalg.norm(r.end_velocity), [0, 0, -1], atol=1e-9
    )
    np.testing.assert_allclose(
        jacobian(ctx.device, q_end, ctx.mount)[:3] @ r.end_joint_velocity, r.end_velocity, atol=1e-9
    )
    _, q, qd, qdd = sample_trajectory(r.path, r.timing, 20001)
    assert (
        max(np.max(v) for v in limit_ratios(q, qd, qdd, limits, dyn, ctx.gravity_base).values())
        <= 1.0
    )
    # the search beats the plain tangent length
    w = np.linalg.pinv(jacobian(ctx.device, q_end, ctx.mount)[:3]) @ np.array([0, 0, -1.0])
    plain = HermitePath(
        ctx.device.home, q_end, w * np.linalg.norm(q_end - ctx.device.home) / np.linalg.norm(w)
    )
    timing, _ = time_optimal(plain, limits, dyn, ctx.gravity_base, 200, end_at_rest=False)
    plain_speed = float(
        -(jacobian(ctx.device, q_end, ctx.mount)[:3] @ plain.m1)[2] * np.sqrt(timing.x[-1])
    )
    assert r.speed_along >= plain_speed - 1e-9


def test_impulse_command(cli):
    data = json.loads(
        cli(
            [
                "plan",
                "impulse",
                "workcells/puma560",
                "--tcp",
                "probe",
                "--target",
                "table.drop",
                "--direction",
                "0,0,-1",
                "--payload-mass",
                "2",
                "--gridpoints",
                "100",
                "--json",
            ]
        ).stdout
    )
    assert data["momentum"] > 0 and data["end_velocity"][2] < 0
    bad = cli(
        ["plan", "impulse", "workcells/puma560", "--target", "tabel.drop", "--direction", "0,0,-1"]
    )
    assert bad.exit_code == 2 and "did you mean 'table.drop'" in bad.output


def test_load_optimal_shape_moves_the_knots_and_keeps_the_waypoints():
    from rworld_cli.dynamics import Payload
    from rworld_cli.planning.payload import load_optimal

    limits = Limits(V, np.array(REF["acc_lim_rated_rad_s2"]), np.array(REF["tau_lim_Nm"]))
    r = load_optimal(
        DEVICE,
        PATH,
        limits,
        G,
        [0, 0, 0.1],
        2.2,
        gridpoints=150,
        tolerance=1e-3,
        shape=True,
        evaluations=40,
    )
    assert (
        r.given_shape_mass is not None and r.mass > r.given_shape_mass + 0.01
    )  # 13.30 against 13.25 kg at full resolution
    knots = r.path.knots
    assert (
        knots[0] == 0
        and knots[-1] == 1
        and np.all(np.diff(knots) > 0)
        and not np.allclose(knots, PATH.knots)
    )
    np.testing.assert_allclose(
        r.path.evaluate(knots)[0], PATH.waypoints, atol=1e-12
    )  # still through every waypoint
    dyn = DeviceDynamics(
        DEVICE, Payload.point_mass(r.mass, [0, 0, 0.1]), armature=True, friction=False
    )
    _, q, qd, qdd = sample_trajectory(r.path, r.timing, 20001)
    assert max(np.max(v) for v in limit_ratios(q, qd, qdd, limits, dyn, G).values()) <= 1.0
    assert r.timing.duration == pytest.approx(2.2)


def test_load_optimal_shape_command_writes_a_path_file(cli, tmp_path):
    path = "workcells/puma560/paths/reference.yaml"
    out = tmp_path / "reshaped.yaml"
    bad = cli(
        [
            "plan",
            "load-optimal",
            "workcells/puma560",
            "--path",
            path,
            "--duration",
            "3",
            "--shape-output",
            str(out),
        ]
    )
    assert bad.exit_code == 2 and "--shape-output needs --shape" in bad.output and not out.exists()
    data = json.loads(
        cli(
            [
                "plan",
                "load-optimal",
                "workcells/puma560",
                "--path",
                path,
                "--tcp",
                "probe",
                "--duration",
                "2.2",
                "--gridpoints",
                "100",
                "--tolerance",
                "0.01",
                "--shape",
                "--evaluations",
                "20",
                "--shape-output",
                str(out),
                "--json",
            ]
        ).stdout
    )
    assert data["payload_mass"] >= data["given_shape_mass"] and data["written"] == [str(out)]
    again = json.loads(
        cli(
            [
                "plan",
                "load-optimal",
                "workcells/puma560",
                "--path",
                str(out),
                "--tcp",
                "probe",
                "--duration",
                "2.2",
                "--gridpoints",
                "100",
                "--tolerance",
                "0.01",
                "--json",
            ]
        ).stdout
    )
    assert again["knots"] == pytest.approx(data["knots"], abs=1e-8)
    assert again["payload_mass"] == pytest.approx(data["payload_mass"], abs=2e-2)


def test_uniform_slowdown_when_the_local_repairs_do_not_settle():
    limits, _ = CONFIGS["b_aggr"]
    timing, info = time_optimal(PATH, limits, DYN, G, 100, max_rounds=1)  # no local repair allowed
    local, _ = time_optimal(PATH, limits, DYN, G, 100)
    assert timing.scale > 1.0 and info["dense_ratio"] <= 1.0
    assert (
        timing.duration > local.duration
    )  # slowing everywhere costs more than slowing where needed
    _, q, qd, qdd = sample_trajectory(PATH, timing, 20001)
    assert max(np.max(v) for v in limit_ratios(q, qd, qdd, limits, DYN, G).values()) <= 1.0


def test_what_the_cell_puts_on_the_links_is_carried_by_dynamics_and_planning(cli, tmp_path):
    """paper_fig9's robot holds two hands, a part and an assembly (2.02 kg on link 6): every
    torque includes them.
    """
    from rworld_cli.api import carried_summary, device_context, device_dynamics
    from rworld_cli.dynamics import Payload
    from rworld_cli.kinematics.jacobian import ToolMount

    ctx = device_context(WORKCELLS / "paper_fig9", "robot", None)
    carried = carried_summary(ctx)
    assert {c["name"] for c in carried} == {"hand_a", "part", "hand_b", "housing", "shaft", "cap"}
    assert sum(c["mass"] for c in carried) == pytest.approx(2.02) and {
        c["link"] for c in carried
    } == {6}
    # the same bodies given as rigid payloads at the flange give the same torques
    link6 = ctx.device.link_frames[-1]
    bodies = [
        (ctx.world.cell.objects[n].inertial, ctx.world.T(link6, n))
        for n in ("part", "housing", "shaft", "cap")
    ]
    for hand in ("hand_a", "hand_b"):
        dev = ctx.world.cell.devices[hand]
        bodies += [
            (link.inertial, ctx.world.T(link6, f)) for link, f in zip(dev.links, dev.link_frames)
        ]
    mount6 = ToolMount(6, np.eye(4))  # payloads given in the flange frame
    rng = np.random.default_rng(3)
    q, qd, qdd = (rng.uniform(-1, 1, (20, 6)) for _ in range(3))
    with_loads = device_dynamics(ctx, armature=False, friction=False).inverse(
        q, qd, qdd, ctx.gravity_base
    )
    by_payloads = DeviceDynamics(ctx.device, None, ctx.mount, False, False).inverse(
        q, qd, qdd, ctx.gravity_base
    )
    for inertial, T in bodies:
        one = DeviceDynamics(ctx.device, Payload.rigid_body(inertial, T), mount6, False, False)
        by_payloads += one.inverse(q, qd, qdd, ctx.gravity_base) - DeviceDynamics(
            ctx.device, None, mount6, False, False
        ).inverse(q, qd, qdd, ctx.gravity_base)
    np.testing.assert_allclose(with_loads, by_payloads, atol=1e-10)
    # the puma560's reference path, for paper_fig9's PUMA (a path file names its device)
    path_for_robot = tmp_path / "reference.yaml"
    path_for_robot.write_text(
        (WORKCELLS / "puma560" / "paths" / "reference.yaml")
        .read_text()
        .replace("device: puma", "device: robot")
    )
    out = json.loads(
        cli(
            [
                "plan",
                "payload",
                "workcells/paper_fig9",
                "-d",
                "robot",
                "--path",
                str(path_for_robot),
                "--timing",
                "quintic",
                "--duration",
                "5",
                "--json",
            ]
        ).stdout
    )
    assert {c["name"] for c in out["carried"]} == {c["name"] for c in carried}
