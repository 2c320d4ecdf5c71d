"""rworld's batched device physics beside Pinocchio, on the Puma 560, in one run.

Run:  .venv/bin/pip install -e ".[bench]" && .venv/bin/python bench/dynamics.py [--sizes 1000 10000
100000]

Same model in both (workcells/puma560, rigid body: no armature, no
friction; Pinocchio's model is built from the same DH table and mass
properties), same random states.  Before timing, the two are checked to
agree.  Per-sample times are the best of --repeat runs; ratios are
rworld / Pinocchio (below 1: rworld faster).  Pinocchio is timed two ways:
a Python loop of per-state calls, and its one-thread batched
rneaInParallel / abaInParallel.  There is no batched Jacobian in
Pinocchio's Python API, so FK + Jacobian compares with its per-call loop.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from peers import pinocchio_model  # noqa: E402

from rworld_cli.dynamics import DeviceDynamics  # noqa: E402
from rworld_cli.kinematics.jacobian import tool_pose_and_jacobian  # noqa: E402
from rworld_cli.schema.loader import load_cell  # noqa: E402


def best_time(fn, repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000, 100000])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    try:
        import pinocchio as pin
    except ImportError:
        raise SystemExit(
            "Pinocchio is not installed: .venv/bin/pip install -e '.[bench]'"
        ) from None

    device = load_cell(REPO / "workcells" / "puma560").cell.devices["puma"]
    dyn = DeviceDynamics(device, armature=False, friction=False)
    g = np.array([0.0, 0.0, -9.81])
    model, tool = pinocchio_model(device)
    data = model.createData()
    pool = pin.ModelPool(model, 1)
    rng = np.random.default_rng(20261121)
    n = device.dof

    # same work: check agreement first
    q, qd, qdd = (rng.uniform(-2, 2, (50, n)) for _ in range(3))
    tau = dyn.inverse(q, qd, qdd, g)
    tau_pin = np.array([pin.rnea(model, data, a, b, c) for a, b, c in zip(q, qd, qdd)])
    T, J = tool_pose_and_jacobian(device, q)
    J_pin = []
    for a in q:
        pin.forwardKinematics(model, data, a)
        J_pin.append(
            pin.computeFrameJacobian(model, data, a, tool, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        )
    qdd_fd = dyn.forward(q, qd, tau, g)
    print(
        f"agreement: tau {np.abs(tau - tau_pin).max():.1e}, jacobian "
        f"{np.abs(J - np.array(J_pin)).max():.1e}, "
        f"forward dynamics {np.abs(qdd_fd - qdd).max():.1e}"
    )
    print(
        f"pinocchio {pin.__version__}, numpy {np.__version__}; best of {args.repeat}; per-sample "
        "times in microseconds\n"
    )

    header = (
        f"{'operation':22s} {'N':>7s} {'rworld':>9s} {'pin loop':>9s} {'pin batch':>10s} "
        f"{'ratio':>7s}"
    )
    print(header)
    print("-" * len(header))
    for N in args.sizes:
        q, qd, qdd = (rng.uniform(-2, 2, (N, n)) for _ in range(3))
        qT, qdT, qddT = (np.asfortranarray(x.T) for x in (q, qd, qdd))
        out = np.zeros((n, N), order="F")
        tau = dyn.inverse(q, qd, qdd, g)

        def pin_rnea_loop():
            for a, b, c in zip(q, qd, qdd):
                pin.rnea(model, data, a, b, c)

        def pin_fkj_loop():
            for a in q:
                pin.forwardKinematics(model, data, a)
                pin.computeFrameJacobian(
                    model, data, a, tool, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
                )

        def pin_aba_loop():
            for a, b, c in zip(q, qd, tau):
                pin.aba(model, data, a, b, c)

        tauT = np.asfortranarray(tau.T)
        rows = [
            (
                "inverse dynamics",
                lambda: dyn.inverse(q, qd, qdd, g),
                pin_rnea_loop,
                lambda: pin.rneaInParallel(1, pool, qT, qdT, qddT, out),
            ),
            ("FK + Jacobian", lambda: tool_pose_and_jacobian(device, q), pin_fkj_loop, None),
            (
                "forward dynamics",
                lambda: dyn.forward(q, qd, tau, g),
                pin_aba_loop,
                lambda: pin.abaInParallel(1, pool, qT, qdT, tauT, out),
            ),
        ]
        for label, ours, loop, batch in rows:
            t_ours = best_time(ours, args.repeat) / N * 1e6
            t_loop = best_time(loop, args.repeat) / N * 1e6
            t_batch = best_time(batch, args.repeat) / N * 1e6 if batch else float("nan")
            reference = t_batch if batch else t_loop
            print(
                f"{label:22s} {N:7d} {t_ours:9.3f} {t_loop:9.3f} {t_batch:10.3f} "
                f"{t_ours / reference:7.2f}"
            )

    q1, qd1, qdd1 = q[0], qd[0], qdd[0]
    reps = 2000
    t_single = (
        best_time(lambda: [dyn.inverse(q1, qd1, qdd1, g) for _ in range(reps)], args.repeat)
        / reps
        * 1e6
    )
    t_pin = (
        best_time(lambda: [pin.rnea(model, data, q1, qd1, qdd1) for _ in range(reps)], args.repeat)
        / reps
        * 1e6
    )
    t_fkj = (
        best_time(lambda: [tool_pose_and_jacobian(device, q1) for _ in range(reps)], args.repeat)
        / reps
        * 1e6
    )
    print(
        f"\nsingle state: rworld inverse dynamics {t_single:.1f} us (pinocchio rnea call "
        f"{t_pin:.1f} us), "
        f"rworld FK + Jacobian {t_fkj:.1f} us"
    )
    print(
        "ratio = rworld / pinocchio batched (inverse and forward dynamics) or / pinocchio loop "
        "(FK + Jacobian)"
    )


if __name__ == "__main__":
    main()
