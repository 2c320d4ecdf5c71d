"""Time-optimal timing and payload capacity: rworld beside toppra, on the reference problem, in one run.

Run:  .venv/bin/pip install -e ".[bench]" && .venv/bin/python bench/planning.py [--grids 100 500 1000 2000]

Grid sizes count grid points, as toppra and the reference do (N points, N - 1 intervals).

The problem is ../shared/reference/planning/puma560_path.json: the Puma 560
(rigid body + armature, no friction), a clamped cubic spline through 5
waypoints, velocity / acceleration / torque limits.  toppra 0.6 runs with
the seidel solver, ParametrizeConstAccel output and the torque constraint
discretised by Interpolation (as the reference); its torques come from
rworld's inverse dynamics (the same model).  Both results are sampled at
20 001 instants; "worst" is the largest |value| / limit there.  Runtimes:
best of --repeat, in the same run; rworld's includes its checks and local
repairs between grid points.  "grid only" is rworld's solution before those
repairs - the same problem toppra solves.  Payload capacity (exact, affine in
mass) on toppra's rated timing, on rworld's, and on a 5 s quintic, against
the reference figures; "with switches" also evaluates both one-sided limits
at every grid instant, where the acceleration jumps.
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

from rworld_cli.dynamics import DeviceDynamics  # noqa: E402
from rworld_cli.planning.path import JointPath  # noqa: E402
from rworld_cli.planning.payload import payload_capacity, quintic_timing  # noqa: E402
from rworld_cli.planning.topp import Limits, limit_ratios, sample_trajectory, time_optimal  # noqa: E402
from rworld_cli.schema.loader import load_cell  # noqa: E402

REF = json.loads((REPO.parent / "shared" / "reference" / "planning" / "puma560_path.json").read_text())


def best(fn, repeat):
    out, t = None, np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        t = min(t, time.perf_counter() - t0)
    return out, t


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grids", type=int, nargs="+", default=[100, 500, 1000, 2000])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    try:
        import toppra as ta
        import toppra.algorithm as algo
        import toppra.constraint as constraint
    except ImportError:
        raise SystemExit("toppra is not installed: .venv/bin/pip install -e '.[bench]'") from None
    ta.setup_logging("WARNING")

    device = load_cell(REPO / "workcells" / "puma560").cell.devices["puma"]
    dyn = DeviceDynamics(device, armature=True, friction=False)
    g = np.array(REF["gravity"])
    waypoints = np.radians(REF["waypoints_deg"])
    knots = np.linspace(0, 1, len(waypoints))
    ours_path = JointPath(waypoints, knots)
    v, a_rated, a_aggr, tmax = (np.array(REF[k]) for k in ("vel_lim_rad_s", "acc_lim_rated_rad_s2", "acc_lim_aggressive_rad_s2", "tau_lim_Nm"))
    configs = {
        "a_rated": (Limits(v, a_rated, None), False),
        "b_rated": (Limits(v, a_rated, tmax), True),
        "b_aggr": (Limits(v, a_aggr, tmax), True),
        "c_vtau": (Limits(v, None, tmax), True),
    }

    def toppra_solve(limits: Limits, torque: bool, grid: int):
        path = ta.SplineInterpolator(knots, waypoints, bc_type="clamped")
        cons = [constraint.JointVelocityConstraint(np.column_stack([-limits.velocity, limits.velocity]))]
        if limits.acceleration is not None:
            cons.append(constraint.JointAccelerationConstraint(np.column_stack([-limits.acceleration, limits.acceleration])))
        if torque:
            def inv_dyn(q, qd, qdd):
                return dyn.inverse(np.atleast_2d(q), np.atleast_2d(qd), np.atleast_2d(qdd), g).reshape(np.shape(q))
            cons.append(constraint.JointTorqueConstraint(inv_dyn, np.column_stack([-limits.effort, limits.effort]), np.zeros(6),
                                                         discretization_scheme=constraint.DiscretizationType.Interpolation))
        instance = algo.TOPPRA(cons, path, gridpoints=np.linspace(0, 1, grid), solver_wrapper="seidel", parametrizer="ParametrizeConstAccel")
        return instance.compute_trajectory()

    def sampled_toppra(traj):
        t = np.linspace(0, traj.duration, 20001)
        return t, traj(t), traj(t, 1), traj(t, 2)

    ref_T = {(r["config"], r["gridpoints"]): r["duration_s"] for r in REF["toppra_results"]}
    print(f"{'config':8s} {'grid':>5s} | {'toppra T [s]':>13s} {'vs ref':>8s} {'worst':>8s} {'ms':>7s} | {'grid only':>9s} | "
          f"{'rworld T [s]':>13s} {'worst':>9s} {'ms':>7s} | {'T ratio':>8s} {'time ratio':>10s}")
    toppra_rated = None
    for name, (limits, torque) in configs.items():
        for grid in args.grids:
            traj, t_toppra = best(lambda: toppra_solve(limits, torque, grid), args.repeat)
            _, q, qd, qdd = sampled_toppra(traj)
            worst_toppra = max(np.max(r) for r in limit_ratios(q, qd, qdd, limits, dyn if torque else None, g).values())
            if name == "a_rated" and grid == 1000:
                toppra_rated = traj
            plain, _ = time_optimal(ours_path, limits, dyn if torque else None, g, grid, repair=False)
            (timing, _), t_ours = best(lambda: time_optimal(ours_path, limits, dyn if torque else None, g, grid), args.repeat)
            _, q, qd, qdd = sample_trajectory(ours_path, timing, 20001)
            worst_ours = max(np.max(r) for r in limit_ratios(q, qd, qdd, limits, dyn if torque else None, g).values())
            vs_ref = f"{traj.duration / ref_T[(name, grid)] - 1:+8.0e}" if (name, grid) in ref_T else f"{'-':>8s}"
            print(f"{name:8s} {grid:5d} | {traj.duration:13.6f} {vs_ref} {worst_toppra:8.5f} {t_toppra * 1000:7.1f} | "
                  f"{plain.duration / traj.duration - 1:+9.0e} | {timing.duration:13.6f} {worst_ours:9.7f} {t_ours * 1000:7.1f} | "
                  f"{timing.duration / traj.duration:8.5f} {t_ours / t_toppra:10.2f}")

    print("\npayload capacity (point mass at [0, 0, 0.1] m in frame 6), exact (torque is affine in mass):")
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
        print(f"  on toppra's rated timing, 1000 points ({toppra_rated.duration:.9f} s): {cap.mass:.6f} kg, joint {cap.joint + 1} "
              f"(reference {r['m_star_linear_kg']:.6f} kg on {r['duration_s']:.9f} s, joint {r['binding_joint']}; "
              f"difference {cap.mass - r['m_star_linear_kg']:+.1e} kg)")
    for label, repair in (("grid only", False), ("checked between grid points", True)):
        timing, _ = time_optimal(ours_path, configs["a_rated"][0], None, g, 1000, repair=repair)
        sampled, exact = capacity(ours_path, timing), capacity(ours_path, timing, switches=True)
        print(f"  on rworld's rated timing, 1000 points, {label} ({timing.duration:.9f} s): {sampled.mass:.6f} kg sampled "
              f"at 20 001 instants, {exact.mass:.6f} kg with switches, joint {exact.joint + 1}")
    t, s, sd, sdd = quintic_timing(5.0, 20001)
    q, dq, ddq = ours_path.evaluate(s)
    cap = payload_capacity(device, q, dq * sd[:, None], ddq * (sd**2)[:, None] + dq * sdd[:, None], g, [0, 0, 0.1])
    r = ref["quintic time law, T=5.0 s"]
    print(f"  on the 5 s quintic: {cap.mass:.6f} kg, joint {cap.joint + 1} (reference {r['m_star_linear_kg']:.6f} kg; "
          f"difference {cap.mass - r['m_star_linear_kg']:+.1e} kg)")
    print("\ngrid = grid points; vs ref = toppra's duration here against the reference file's; worst = max |value| / limit "
          "over 20 001 samples (above 1: a violation); grid only = rworld's grid solution against toppra's duration; "
          "T ratio = rworld / toppra duration; time ratio = rworld / toppra runtime")


if __name__ == "__main__":
    main()
