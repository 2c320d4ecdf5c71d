"""rworld's batched device physics beside Pinocchio, on the Puma 560 and the Panda, in one run.

Run:  .venv/bin/pip install -e ".[bench]" && .venv/bin/python bench/dynamics.py [--sizes 1000 10000
100000]

Same model in both, rigid body (no armature, no friction), same random states: the Puma of
workcells/puma560 (Pinocchio's model built from the same DH table and mass properties), and the
Panda's arm from example-robot-data's URDF (rworld imports it with 'import urdf', Pinocchio
loads the same file).  Before timing, the two are checked to
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
from rworld_cli.kinematics.jacobian import ToolMount, tool_pose_and_jacobian  # noqa: E402
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
    parser.add_argument("--robots", nargs="+", choices=list(ROBOTS), default=list(ROBOTS))
    args = parser.parse_args()
    try:
        import pinocchio as pin
    except ImportError:
        raise SystemExit(
            "Pinocchio is not installed: .venv/bin/pip install -e '.[bench]'"
        ) from None

    print(
        f"pinocchio {pin.__version__}, numpy {np.__version__}; best of {args.repeat}; per-sample "
        "times in microseconds"
    )
    for robot in args.robots:
        device, model, tool, mount = ROBOTS[robot](pin)
        print(f"\n== {robot}: {device.dof} joints, {device.convention} ==")
        run_robot(device, model, tool, mount, args, pin)
    print(
        "\nratio = rworld / pinocchio batched (inverse and forward dynamics) or / pinocchio loop "
        "(FK + Jacobian)"
    )


def puma(pin):
    """The Puma 560 of workcells/puma560 (standard DH); Pinocchio's model built from the same
    table and mass properties."""
    device = load_cell(REPO / "workcells" / "puma560").cell.devices["puma"]
    model, tool = pinocchio_model(device)
    return device, model, tool, None


def panda(pin):
    """The Panda's arm from example-robot-data's URDF, imported by rworld; Pinocchio loads the
    same file (fingers locked at 0, as rworld's import locks them)."""
    import tempfile
    from importlib.metadata import distribution

    from rworld_cli.api import import_urdf

    share = Path(str(distribution("example-robot-data").locate_file("cmeel.prefix/share")))
    urdf = share / "example-robot-data/robots/panda_description/urdf/panda.urdf"
    folder = Path(tempfile.mkdtemp()) / "panda"
    import_urdf(str(urdf), str(folder), [str(share)], tip="panda_hand")
    device = load_cell(folder).cell.devices["panda"]
    model = pin.buildModelFromUrdf(str(urdf))
    locked = [model.getJointId(f"panda_finger_joint{k}") for k in (1, 2)]
    model = pin.buildReducedModel(model, locked, pin.neutral(model))
    # rworld's tool: the hand frame, merged into link 7 by the import
    mount = ToolMount(device.dof, load_cell(folder).cell.poses["panda.panda_hand"])
    return device, model, model.getFrameId("panda_hand"), mount


def puma_frames(pin):
    """The same Puma as joint frames: written out by 'export urdf' and read back by 'import urdf'
    (the generated kernels' cost on a joint-frame chain against the DH one); Pinocchio loads the
    written URDF."""
    import tempfile

    from rworld_cli.api import export_urdf, import_urdf

    folder = Path(tempfile.mkdtemp())
    export_urdf(str(REPO / "workcells" / "puma560"), str(folder / "puma.urdf"))
    import_urdf(str(folder / "puma.urdf"), str(folder / "puma"))
    device = load_cell(folder / "puma").cell.devices["puma"]
    model = pin.buildModelFromUrdf(str(folder / "puma.urdf"))
    mount = ToolMount(device.dof, load_cell(folder / "puma").cell.poses["puma.tool"])
    return device, model, model.getFrameId("tool"), mount


ROBOTS = {"puma": puma, "puma-frames": puma_frames, "panda": panda}


def run_robot(device, model, tool, mount, args, pin) -> None:
    dyn = DeviceDynamics(device, armature=False, friction=False)
    g = np.array([0.0, 0.0, -9.81])
    data = model.createData()
    pool = pin.ModelPool(model, 1)
    rng = np.random.default_rng(20261121)
    n = device.dof

    # same work: check agreement first
    q, qd, qdd = (rng.uniform(-2, 2, (50, n)) for _ in range(3))
    tau = dyn.inverse(q, qd, qdd, g)
    tau_pin = np.array([pin.rnea(model, data, a, b, c) for a, b, c in zip(q, qd, qdd)])
    T, J = tool_pose_and_jacobian(device, q, mount)
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
        f"forward dynamics {np.abs(qdd_fd - qdd).max():.1e}\n"
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
            ("FK + Jacobian", lambda: tool_pose_and_jacobian(device, q, mount), pin_fkj_loop, None),
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
        best_time(
            lambda: [tool_pose_and_jacobian(device, q1, mount) for _ in range(reps)], args.repeat
        )
        / reps
        * 1e6
    )
    print(
        f"\nsingle state: rworld inverse dynamics {t_single:.1f} us (pinocchio rnea call "
        f"{t_pin:.1f} us), "
        f"rworld FK + Jacobian {t_fkj:.1f} us"
    )


if __name__ == "__main__":
    main()
