"""Time-optimal timing and payload capacity: rworld beside toppra, on two problems, in one run.

Run:  .venv/bin/pip install -e ".[bench]" && .venv/bin/python bench/planning.py [--grids 100 500
1000 2000]

Grid sizes count grid points, as toppra and the reference do (N points, N - 1 intervals).

Problems:

* ``puma``: tests/data/reference/planning/puma560_path.json - the Puma 560
  (rigid body + armature, no friction), a clamped cubic spline through 5
  equally spaced waypoints, velocity / acceleration / torque limits in four
  sets (a: v + a rated; b: v + a + torque, rated and aggressive; c: v + torque).
* ``ur5``: ``workcells/ur5`` (the reference UR5: DH and point-mass links) on
  ``workcells/ur5/paths/natural.yaml``, a *natural* spline through 5
  waypoints at uneven knots [0, 0.12, 0.47, 0.71, 1], under UR's velocity
  limits (pi rad/s) and torque limits (150 / 28 N m).

toppra 0.6 runs in its best ordinary setup: the seidel solver,
ParametrizeConstAccel output, the torque constraint discretised by
Interpolation (as the reference), and its torques from Pinocchio's ``rnea``
(the same model: rigid bodies, armature Jm G^2, no friction); the bench
first checks that the two inverse dynamics agree to 1e-9 N m on random
states, and stops if not.  Both results are sampled at 20 001 instants (and
both sides of every grid instant for rworld); "worst" is the largest
|value| / limit there.  Runtimes: best of --repeat (default 5), the two
taking turns within each repetition, each timed from the waypoints (its
spline built, then solved); rworld's includes its checks and local repairs
between grid points.  "grid only" is rworld's solution before those repairs -
the same problem toppra solves.  Payload capacity (exact, affine in mass) on
toppra's rated timing, on rworld's, and on a 5 s quintic, against the
reference figures.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from peers import pinocchio_with_armature  # noqa: E402

from rworld_cli.dynamics import DeviceDynamics  # noqa: E402
from rworld_cli.planning.path import JointPath  # noqa: E402
from rworld_cli.planning.payload import payload_capacity, quintic_timing  # noqa: E402
from rworld_cli.planning.topp import Limits, limit_ratios, sample_trajectory, time_optimal  # noqa: E402
from rworld_cli.schema.loader import load_cell  # noqa: E402

REF = json.loads(
    (REPO / "tests" / "data" / "reference" / "planning" / "puma560_path.json").read_text()
)


def best_interleaved(fns, repeat):
    """Each function's output and best time over ``repeat`` rounds, the functions taking turns
    within a round, so that a busy spell of the shared machine hits them alike."""
    out, t = [None] * len(fns), [np.inf] * len(fns)
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            t0 = time.perf_counter()
            out[i] = fn()
            t[i] = min(t[i], time.perf_counter() - t0)
    return out, t


def check_dynamics_agree(device, dyn, model, gravity, samples=200, tolerance=1e-9):
    """The largest |tau_rworld - tau_pinocchio| over random states [N m]; exits if above
    ``tolerance``: the runtimes below compare the same dynamics or nothing."""
    import pinocchio as pin

    rng = np.random.default_rng(7)
    n = len(device.joints)
    q, qd, qdd = (rng.uniform(-2.0, 2.0, (samples, n)) for _ in range(3))
    ours = dyn.inverse(q, qd, qdd, gravity)
    data = model.createData()
    theirs = np.array([pin.rnea(model, data, *state) for state in zip(q, qd, qdd)])
    worst = float(np.abs(ours - theirs).max())
    if not worst <= tolerance:
        raise SystemExit(f"{device.name}: rworld and Pinocchio differ by {worst:.1e} N m")
    return worst


def problems():
    """name -> (device, knots, waypoints, boundary, gravity, {config: (Limits, torque?)})"""
    puma = load_cell(REPO / "workcells" / "puma560").cell.devices["puma"]
    v, a_rated, a_aggr, tmax = (
        np.array(REF[k])
        for k in (
            "vel_lim_rad_s",
            "acc_lim_rated_rad_s2",
            "acc_lim_aggressive_rad_s2",
            "tau_lim_Nm",
        )
    )
    waypoints = np.radians(REF["waypoints_deg"])
    out = {
        "puma": (
            puma,
            np.linspace(0, 1, len(waypoints)),
            waypoints,
            "clamped",
            np.array(REF["gravity"]),
            {
                "a_rated": (Limits(v, a_rated, None), False),
                "b_rated": (Limits(v, a_rated, tmax), True),
                "b_aggr": (Limits(v, a_aggr, tmax), True),
                "c_vtau": (Limits(v, None, tmax), True),
            },
        )
    }
    from rworld_cli.api import load_joint_path, planning_limits

    ur5 = load_cell(REPO / "workcells" / "ur5").cell.devices["ur5"]
    ur5_path = load_joint_path(str(REPO / "workcells" / "ur5" / "paths" / "natural.yaml"), ur5)
    out["ur5"] = (
        ur5,
        ur5_path.knots,
        ur5_path.waypoints,
        ur5_path.boundary,
        np.array([0, 0, -9.81]),
        {"ur5_vtau": (planning_limits(ur5), True)},
    )
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grids", type=int, nargs="+", default=[100, 500, 1000, 2000])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    try:
        import pinocchio as pin
        import toppra as ta
        import toppra.algorithm as algo
        import toppra.constraint as constraint
    except ImportError:
        raise SystemExit(
            "toppra and pin are not installed: .venv/bin/pip install -e '.[bench]'"
        ) from None
    ta.setup_logging("WARNING")
    from importlib.metadata import version

    print(
        f"toppra {version('toppra')}, pinocchio {pin.__version__}, numpy {np.__version__}; best "
        f"of {args.repeat}\n"
    )

    def toppra_solve(knots, waypoints, boundary, limits, torque, grid, model):
        path = ta.SplineInterpolator(knots, waypoints, bc_type=boundary)
        cons = [
            constraint.JointVelocityConstraint(np.column_stack([-limits.velocity, limits.velocity]))
        ]
        if limits.acceleration is not None:
            cons.append(
                constraint.JointAccelerationConstraint(
                    np.column_stack([-limits.acceleration, limits.acceleration])
                )
            )
        if torque:
            data = model.createData()

            def inv_dyn(q, qd, qdd):  # toppra calls this with one state at a time
                return pin.rnea(model, data, q, qd, qdd)

            cons.append(
                constraint.JointTorqueConstraint(
                    inv_dyn,
                    np.column_stack([-limits.effort, limits.effort]),
                    np.zeros(len(limits.velocity)),
                    discretization_scheme=constraint.DiscretizationType.Interpolation,
                )
            )
        instance = algo.TOPPRA(
            cons,
            path,
            gridpoints=np.linspace(0, 1, grid),
            solver_wrapper="seidel",
            parametrizer="ParametrizeConstAccel",
        )
        return instance.compute_trajectory()

    def sampled_toppra(traj):
        t = np.linspace(0, traj.duration, 20001)
        return t, traj(t), traj(t, 1), traj(t, 2)

    ref_T = {(r["config"], r["gridpoints"]): r["duration_s"] for r in REF["toppra_results"]}
    cases = problems()
    for name, (device, _, _, _, g, _) in cases.items():
        agree = check_dynamics_agree(
            device,
            DeviceDynamics(device, armature=True, friction=False),
            pinocchio_with_armature(device, g)[0],
            g,
        )
        print(
            f"{name}: rworld's and Pinocchio's inverse dynamics (armature, no friction) agree to "
            f"{agree:.1e} N m on 200 random states"
        )
    print()
    print(
        f"{'config':8s} {'grid':>5s} | {'toppra T [s]':>13s} {'vs ref':>8s} {'worst':>8s} "
        f"{'ms':>7s} | {'grid only':>9s} | "
        f"{'rworld T [s]':>13s} {'worst':>9s} {'ms':>7s} | {'T ratio':>8s} {'time ratio':>10s}"
    )
    toppra_rated, ratios_T = None, []
    for name, (device, knots, waypoints, boundary, g, configs) in cases.items():
        dyn = DeviceDynamics(device, armature=True, friction=False)
        model, _ = pinocchio_with_armature(device, g)
        ours_path = JointPath(waypoints, knots, boundary)
        for config, (limits, torque) in configs.items():
            for grid in args.grids:
                # each timed from the waypoints: its spline built, then the solve
                (traj, (timing, _)), (t_toppra, t_ours) = best_interleaved(
                    [
                        lambda: toppra_solve(
                            knots, waypoints, boundary, limits, torque, grid, model
                        ),
                        lambda: time_optimal(
                            JointPath(waypoints, knots, boundary),
                            limits,
                            dyn if torque else None,
                            g,
                            grid,
                        ),
                    ],
                    args.repeat,
                )
                _, q, qd, qdd = sampled_toppra(traj)
                worst_toppra = max(
                    np.max(r)
                    for r in limit_ratios(q, qd, qdd, limits, dyn if torque else None, g).values()
                )
                if config == "a_rated" and grid == 1000:
                    toppra_rated = traj
                plain, _ = time_optimal(
                    ours_path, limits, dyn if torque else None, g, grid, repair=False
                )
                _, q, qd, qdd = sample_trajectory(ours_path, timing, 20001, switches=True)
                worst_ours = max(
                    np.max(r)
                    for r in limit_ratios(q, qd, qdd, limits, dyn if torque else None, g).values()
                )
                vs_ref = (
                    f"{traj.duration / ref_T[(config, grid)] - 1:+8.0e}"
                    if (config, grid) in ref_T
                    else f"{'-':>8s}"
                )
                ratios_T.append(timing.duration / traj.duration)
                print(
                    f"{config:8s} {grid:5d} | {traj.duration:13.6f} {vs_ref} {worst_toppra:8.5f} "
                    f"{t_toppra * 1000:7.1f} | "
                    f"{plain.duration / traj.duration - 1:+9.0e} | {timing.duration:13.6f} "
                    f"{worst_ours:9.7f} {t_ours * 1000:7.1f} | "
                    f"{timing.duration / traj.duration:8.5f} {t_ours / t_toppra:10.2f}"
                )
    print(
        f"\ncycle time over toppra's, every problem and grid above: {min(ratios_T):.5f} .. "
        f"{max(ratios_T):.5f}"
    )

    print(
        "\npayload capacity (point mass at [0, 0, 0.1] m in frame 6), exact (torque is affine in "
        "mass):"
    )
    device, knots, waypoints, _, g, configs = cases["puma"]
    ours_path = JointPath(waypoints, knots)
    ref = {c["label"]: c for c in REF["payload_capacity"]}

    def capacity(path, timing_or_traj, switches=False):
        if hasattr(timing_or_traj, "u"):
            _, q, qd, qdd = sample_trajectory(path, timing_or_traj, 20001, switches=switches)
        else:
            _, q, qd, qdd = sampled_toppra(timing_or_traj)
        return payload_capacity(device, q, qd, qdd, g, [0, 0, 0.1])

    if toppra_rated is not None:
        cap = capacity(None, toppra_rated)
        r = ref["toppra v+a(rated) optimal"]
        print(
            f"  on toppra's rated timing, 1000 points ({toppra_rated.duration:.9f} s): "
            f"{cap.mass:.6f} kg, joint {cap.joint + 1} "
            f"(reference {r['m_star_linear_kg']:.6f} kg on {r['duration_s']:.9f} s, joint "
            f"{r['binding_joint']}; "
            f"difference {cap.mass - r['m_star_linear_kg']:+.1e} kg)"
        )
    for label, repair in (("grid only", False), ("checked between grid points", True)):
        timing, _ = time_optimal(ours_path, configs["a_rated"][0], None, g, 1000, repair=repair)
        sampled, exact = capacity(ours_path, timing), capacity(ours_path, timing, switches=True)
        print(
            f"  on rworld's rated timing, 1000 points, {label} ({timing.duration:.9f} s): "
            f"{sampled.mass:.6f} kg sampled "
            f"at 20 001 instants, {exact.mass:.6f} kg with switches, joint {exact.joint + 1}"
        )
    t, s, sd, sdd = quintic_timing(5.0, 20001)
    q, dq, ddq = ours_path.evaluate(s)
    cap = payload_capacity(
        device, q, dq * sd[:, None], ddq * (sd**2)[:, None] + dq * sdd[:, None], g, [0, 0, 0.1]
    )
    r = ref["quintic time law, T=5.0 s"]
    print(
        f"  on the 5 s quintic: {cap.mass:.6f} kg, joint {cap.joint + 1} (reference "
        f"{r['m_star_linear_kg']:.6f} kg; "
        f"difference {cap.mass - r['m_star_linear_kg']:+.1e} kg)"
    )
    print(
        "\ngrid = grid points; vs ref = toppra's duration here against the reference file's; "
        "worst = max |value| / limit "
        "over 20 001 samples (above 1: a violation); grid only = rworld's grid solution against "
        "toppra's duration; "
        "T ratio = rworld / toppra duration; time ratio = rworld / toppra runtime"
    )


if __name__ == "__main__":
    main()
