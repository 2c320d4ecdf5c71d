"""rworld's device physics beside Pinocchio, every example device, in one run.

Run:  .venv/bin/pip install -e ".[bench]" && .venv/bin/python bench/dynamics.py [--sizes 1000 10000
100000] [--robots puma ur5 stanford puma-frames panda]

Same model in both, rigid body (no armature, no friction), same random states:

- the Puma of workcells/puma560 and the UR5 of workcells/ur5 (Pinocchio's models built from the
  same DH tables and mass properties);
- the Stanford arm of bench/cells/stanford (R R P R R R: the prismatic joint);
- the Puma as joint frames (written by 'export urdf', read back by 'import urdf');
- the Panda's arm from example-robot-data's URDF (rworld imports it with 'import urdf',
  Pinocchio loads the same file).

Before timing, the two are checked to agree, and rworld's compiled kernels against its numpy
code.  Per-sample times are the best of --repeat runs.  In the table rworld runs its compiled
kernels on one thread, as Pinocchio's batch does; the 'numpy' column is the same generated code
run by numpy (RWORLD_KERNELS=numpy, the fallback).  Pinocchio is timed two ways: a Python loop
of per-state calls, and its one-thread batched rneaInParallel / abaInParallel.  ratio = rworld /
Pinocchio batched where Pinocchio has a batched call (inverse and forward dynamics), else / its
loop (mass matrix: crba; FK + Jacobian).  Then: the largest batch on both cores (as a user gets
it) against rneaInParallel on 2 threads, single states (in a loop that drops each result, and in
one that keeps them all), and the compile cost of a new model (fresh processes, empty and warm
cache).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from peers import pinocchio_model  # noqa: E402

from rworld_cli import kernels  # noqa: E402
from rworld_cli.dynamics import DeviceDynamics  # noqa: E402
from rworld_cli.kinematics.jacobian import ToolMount, generated, tool_pose_and_jacobian  # noqa: E402
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
        f"pinocchio {pin.__version__}, numpy {np.__version__}, rworld kernels: "
        f"{kernels.backend()} ({kernels.thread_count()} threads from {kernels.PARALLEL_MIN} "
        f"samples); best of {args.repeat}; per-sample times in microseconds"
    )
    for robot in args.robots:
        device, model, tool, mount = ROBOTS[robot](pin)
        print(f"\n== {robot}: {device.dof} joints, {device.convention} ==")
        run_robot(device, model, tool, mount, args, pin)
    print(
        "\nratio = rworld / pinocchio batched (inverse and forward dynamics) or / pinocchio loop "
        "(mass matrix, FK + Jacobian)"
    )
    compile_cost()


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


def ur5(pin):
    """The UR5 of workcells/ur5 (standard DH, point-mass links)."""
    device = load_cell(REPO / "workcells" / "ur5").cell.devices["ur5"]
    model, tool = pinocchio_model(device)
    return device, model, tool, None


def stanford(pin):
    """The Stanford arm of bench/cells/stanford: standard DH, the third joint prismatic."""
    device = load_cell(REPO / "bench" / "cells" / "stanford").cell.devices["stanford"]
    model, tool = pinocchio_model(device)
    return device, model, tool, None


ROBOTS = {
    "puma": puma,
    "ur5": ur5,
    "stanford": stanford,
    "puma-frames": puma_frames,
    "panda": panda,
}


def run_robot(device, model, tool, mount, args, pin) -> None:
    dyn = DeviceDynamics(device, armature=False, friction=False)
    g = np.array([0.0, 0.0, -9.81])
    data = model.createData()
    pool = pin.ModelPool(model, 2)
    rng = np.random.default_rng(20261121)
    n = device.dof
    frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED

    def pin_mass(a):
        M = pin.crba(model, data, a)
        return np.triu(M) + np.triu(M, 1).T  # crba fills the upper triangle

    # same work: check agreement first
    q, qd, qdd = (rng.uniform(-2, 2, (50, n)) for _ in range(3))
    tau = dyn.inverse(q, qd, qdd, g)
    tau_pin = np.array([pin.rnea(model, data, a, b, c) for a, b, c in zip(q, qd, qdd)])
    M = dyn.mass_matrix(q)
    M_pin = np.array([pin_mass(a) for a in q])
    T, J = tool_pose_and_jacobian(device, q, mount)
    J_pin = []
    for a in q:
        pin.forwardKinematics(model, data, a)
        J_pin.append(pin.computeFrameJacobian(model, data, a, tool, frame))
    try:
        qdd_fd = dyn.forward(q, qd, tau, g)
        forward_note = ""
    except ValueError as error:  # the UR5's point-mass links: joint 6 moves no inertia
        qdd_fd = qdd
        aba = pin.aba(model, data, q[0], qd[0], tau[0])
        forward_note = f" (no forward dynamics: {error}; pinocchio's aba gives {aba[-1]})"
    own = max(
        np.abs(dyn._gen(mode).evaluate(inputs) - dyn._gen(mode).evaluate(inputs, compiled=False))
        .max()
        .item()
        for mode, inputs in (
            ("full", [q, qd, qdd, g]),
            ("forward", [q, qd, tau, g]),
            ("mass", [q]),
        )
        if not (forward_note and mode == "forward")
    )
    print(
        f"agreement with pinocchio: tau {np.abs(tau - tau_pin).max():.1e}, mass matrix "
        f"{np.abs(M - M_pin).max():.1e}, jacobian {np.abs(J - np.array(J_pin)).max():.1e}, "
        f"forward dynamics {np.abs(qdd_fd - qdd).max():.1e}; compiled against numpy {own:.1e}"
        f"{forward_note}\n"
    )
    header = (
        f"{'operation':18s} {'N':>7s} {'rworld':>8s} {'numpy':>8s} {'pin loop':>9s} "
        f"{'pin batch':>10s} {'ratio':>7s}"
    )
    print(header)
    print("-" * len(header))
    os.environ["RWORLD_THREADS"] = "1"  # one thread against Pinocchio's one-thread batch
    for N in args.sizes:
        q, qd, qdd = (rng.uniform(-2, 2, (N, n)) for _ in range(3))
        qT, qdT, qddT = (np.asfortranarray(x.T) for x in (q, qd, qdd))
        out = np.zeros((n, N), order="F")
        tau = dyn.inverse(q, qd, qdd, g)
        tauT = np.asfortranarray(tau.T)
        fkj = generated(device, mount, True)

        def pin_rnea_loop():
            for a, b, c in zip(q, qd, qdd):
                pin.rnea(model, data, a, b, c)

        def pin_aba_loop():
            for a, b, c in zip(q, qd, tau):
                pin.aba(model, data, a, b, c)

        def pin_crba_loop():
            for a in q:
                pin.crba(model, data, a)

        def pin_fkj_loop():
            for a in q:
                pin.forwardKinematics(model, data, a)
                pin.computeFrameJacobian(model, data, a, tool, frame)

        rows = [
            (
                "inverse dynamics",
                lambda: dyn.inverse(q, qd, qdd, g),
                lambda: dyn._gen("full").evaluate([q, qd, qdd, g], compiled=False),
                pin_rnea_loop,
                lambda: pin.rneaInParallel(1, pool, qT, qdT, qddT, out),
            ),
            (
                "forward dynamics",
                lambda: dyn.forward(q, qd, tau, g),
                lambda: dyn._gen("forward").evaluate([q, qd, tau, g], compiled=False),
                pin_aba_loop,
                lambda: pin.abaInParallel(1, pool, qT, qdT, tauT, out),
            ),
            (
                "mass matrix",
                lambda: dyn.mass_matrix(q),
                lambda: dyn._gen("mass").evaluate([q], compiled=False),
                pin_crba_loop,
                None,
            ),
            (
                "FK + Jacobian",
                lambda: tool_pose_and_jacobian(device, q, mount),
                lambda: fkj.evaluate([q], compiled=False),
                pin_fkj_loop,
                None,
            ),
        ]
        for label, ours, ours_numpy, loop, batch in rows:
            if forward_note and label == "forward dynamics":
                continue
            t_ours = best_time(ours, args.repeat) / N * 1e6
            t_numpy = best_time(ours_numpy, args.repeat) / N * 1e6
            t_loop = best_time(loop, args.repeat) / N * 1e6
            t_batch = best_time(batch, args.repeat) / N * 1e6 if batch else float("nan")
            reference = t_batch if batch else t_loop
            print(
                f"{label:18s} {N:7d} {t_ours:8.3f} {t_numpy:8.3f} {t_loop:9.3f} {t_batch:10.3f} "
                f"{t_ours / reference:7.2f}"
            )

    # both cores: the largest batch against Pinocchio's rneaInParallel on 2 threads
    os.environ.pop("RWORLD_THREADS")
    N = max(args.sizes)
    q, qd, qdd = (rng.uniform(-2, 2, (N, n)) for _ in range(3))
    qT, qdT, qddT = (np.asfortranarray(x.T) for x in (q, qd, qdd))
    out = np.zeros((n, N), order="F")
    t_ours = best_time(lambda: dyn.inverse(q, qd, qdd, g), args.repeat) / N * 1e6
    t_pin2 = (
        best_time(lambda: pin.rneaInParallel(2, pool, qT, qdT, qddT, out), args.repeat) / N * 1e6
    )
    print(
        f"\nboth cores, N = {N}: rworld inverse dynamics {t_ours:.3f} us ({kernels.thread_count()} "
        f"threads), pinocchio rneaInParallel(2) {t_pin2:.3f} us: ratio {t_ours / t_pin2:.2f}"
    )

    # single states, Python call included
    q1, qd1, qdd1 = q[0].copy(), qd[0].copy(), qdd[0].copy()
    tau1 = dyn.inverse(q1, qd1, qdd1, g)
    reps = 20000

    def per_call(fn) -> float:
        """A loop that drops each result, as an IK iteration or a simulator step does."""

        def loop() -> None:
            for _ in range(reps):
                fn()

        return best_time(loop, args.repeat) / reps * 1e6

    def per_call_kept(fn) -> float:
        """A loop that keeps every result: each call's arrays come from fresh memory (numpy's
        small-block cache and the freed blocks are not reused), and rworld returns two arrays
        for FK + Jacobian (T and J) where Pinocchio returns J alone."""
        return best_time(lambda: [fn() for _ in range(reps)], args.repeat) / reps * 1e6

    def pin_fkj():
        pin.forwardKinematics(model, data, q1)
        return pin.computeFrameJacobian(model, data, q1, tool, frame)

    singles = [
        (
            "inverse dynamics",
            lambda: dyn.inverse(q1, qd1, qdd1, g),
            lambda: pin.rnea(model, data, q1, qd1, qdd1),
        ),
        (
            "forward dynamics",
            lambda: dyn.forward(q1, qd1, tau1, g),
            lambda: pin.aba(model, data, q1, qd1, tau1),
        ),
        ("mass matrix", lambda: dyn.mass_matrix(q1), lambda: pin.crba(model, data, q1)),
        ("FK + Jacobian", lambda: tool_pose_and_jacobian(device, q1, mount), pin_fkj),
    ]
    print("single state (us per call, Python call included; results dropped | results kept):")
    for label, ours, theirs in singles:
        if forward_note and label == "forward dynamics":
            continue
        t_ours, t_pin = per_call(ours), per_call(theirs)
        k_ours, k_pin = per_call_kept(ours), per_call_kept(theirs)
        print(
            f"  {label:18s} rworld {t_ours:6.2f}   pinocchio {t_pin:6.2f}   "
            f"ratio {t_ours / t_pin:5.2f}   | rworld {k_ours:6.2f}   pinocchio {k_pin:6.2f}   "
            f"ratio {k_ours / k_pin:5.2f}"
        )


COLD = """
import sys, time
t0 = time.perf_counter()
sys.path.insert(0, {repo!r})
import numpy as np
from rworld_cli.dynamics import DeviceDynamics
from rworld_cli.kinematics.jacobian import tool_pose_and_jacobian
from rworld_cli.schema.loader import load_cell
device = load_cell({cell!r}).cell.devices[{name!r}]
t1 = time.perf_counter()
dyn = DeviceDynamics(device)
q = np.zeros((10, device.dof))
dyn.inverse(q, q, q); dyn.forward(q, q, q); dyn.mass_matrix(q); tool_pose_and_jacobian(device, q)
dyn.gravity_torques(q)
print(time.perf_counter() - t1)
"""


def compile_cost() -> None:
    """What a new model costs the first command: inverse and forward dynamics, mass matrix,
    gravity and FK + Jacobian, in fresh processes (best of 3)."""
    print("\ncompile cost of a new model (fresh process, first call of 5 kernels, best of 3):")
    for cell, name in (("workcells/puma560", "puma"), ("bench/cells/stanford", "stanford")):
        code = COLD.format(repo=str(REPO), cell=str(REPO / cell), name=name)
        results = {}
        with tempfile.TemporaryDirectory() as cache:
            for label, env in (
                ("numpy (generation only)", {"RWORLD_KERNELS": "numpy"}),
                ("compiled, empty cache", {"RWORLD_CACHE_DIR": cache}),
                ("compiled, warm cache", {"RWORLD_CACHE_DIR": cache}),
            ):
                times = []
                for attempt in range(3):
                    if label == "compiled, empty cache":
                        for f in Path(cache).glob("kernels/*.o"):
                            f.unlink()
                    run = subprocess.run(
                        [sys.executable, "-c", code],
                        env={**os.environ, **env},
                        capture_output=True,
                        text=True,
                        check=True,
                    )
                    times.append(float(run.stdout.strip().splitlines()[-1]))
                results[label] = min(times)
        added = results["compiled, empty cache"] - results["numpy (generation only)"]
        print(
            f"  {name:9s} "
            + ", ".join(f"{label} {t * 1e3:.0f} ms" for label, t in results.items())
            + f"; compiling adds {added * 1e3:.0f} ms"
        )


if __name__ == "__main__":
    main()
