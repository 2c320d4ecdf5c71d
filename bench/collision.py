"""Collision checking beside python-fcl: exactness, pair queries per second, buried bodies, and
what the continuous check costs `rworld check`.

Run:  .venv/bin/pip install -e ".[bench]" && .venv/bin/python bench/collision.py [--pairs 5000]

1. Exactness on random poses against reference distances that share no code with either
   library (rworld_cli.collision.oracle: closed forms for sphere pairs, vertex/edge enumeration
   for boxes, a convex solver for cylinders): wrong overlap decisions outside 1e-9 m of touching,
   and the largest distance error on separated pairs.
2. Distance queries per second on the same shapes and poses.  fcl's best ordinary setup: the
   collision objects built once, one setTransform and one fcl.distance per pair.  rworld answers
   a batch in one call (the way the sweep asks), with its compiled GJK, and with the numpy GJK
   it falls back to (``RWORLD_KERNELS=numpy``).
3. A small box buried inside a closed mesh: fcl (meshes are surfaces) against rworld (solids).
4. `rworld check` with the continuous collision check against `--no-collisions`, fresh
   processes, best of REPEAT.
5. (``--vendor``) The vendor cells of issue 47 (tests/data/vendor_cells: the vendors' own ROS
   meshes, a table, a holed plate of 2 900 triangles): `rworld check` against
   `--no-collisions` with its peak memory (best of 3); then configuration checks of each robot
   in its cell (``ConfigurationChecker.check(q, nearest=False)``: free or not) at batches of 1,
   64 and 4096 random joint states (at least 256 states a batch size, in calls of that size;
   a first batch of 256 warms the checker), beside coal 3 (the FCL successor; OBBRSS trees of
   the same triangles, one ``coal.collide`` per pair the device may not touch, stopping at a
   state's first contact).  Their decisions differ where they mean different things: rworld's solids
   collide when overlapping deeper than the 1 mm tolerance or buried; coal's surfaces at any
   contact and never when buried.  Then segment checks (``check_segment``, the guarantee
   between states) per second.

Ratios are of one run on one machine; the machines are shared and noisy.
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from rworld_cli.collision import convex as cv
from rworld_cli.collision.oracle import (
    box_box,
    cylinder_distance,
    cylinder_points,
    point_box,
    point_cylinder,
)
from rworld_cli.geometry import obb_overlap

REPO = Path(__file__).resolve().parents[1]
TOL = 1e-9


def poses(n: int, seed: int, spread: float = 0.35) -> np.ndarray:
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = Rotation.random(n, random_state=seed).as_matrix()
    T[:, :3, 3] = np.random.default_rng(seed).uniform(-spread, spread, (n, 3))
    return T


# the shapes: a is at the origin, b at random poses (sizes in metres)
SPHERE_A, SPHERE_B = 0.1, 0.08
BOX_A, BOX_B = np.array([0.05, 0.1, 0.15]), np.array([0.1, 0.05, 0.025])
CYL_A, CYL_B = (0.05, 0.15), (0.04, 0.1)  # radius, half length


def rworld_pieces(kind: str, T: np.ndarray, which: str) -> cv.Pieces:
    if kind == "sphere":
        return cv.spheres(T[:, :3, 3], np.full(len(T), SPHERE_A if which == "a" else SPHERE_B))
    if kind == "box":
        return cv.boxes(T, BOX_A if which == "a" else BOX_B)
    r, h = CYL_A if which == "a" else CYL_B
    return cv.cylinders(T, r, h)


def fcl_geometry(kind: str, which: str):
    import fcl

    if kind == "sphere":
        return fcl.Sphere(SPHERE_A if which == "a" else SPHERE_B)
    if kind == "box":
        return fcl.Box(*(2 * (BOX_A if which == "a" else BOX_B)))
    r, h = CYL_A if which == "a" else CYL_B
    return fcl.Cylinder(r, 2 * h)


def reference(kind_a: str, kind_b: str, Tb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance, overlap) from the oracle; NaN distance where it cannot tell (touching)."""
    n = len(Tb)
    origin = np.zeros((n, 3))
    pair = (kind_a, kind_b)
    if kind_a == "sphere":
        r = SPHERE_A
        if kind_b == "sphere":
            d = np.linalg.norm(Tb[:, :3, 3], axis=1) - r - SPHERE_B
        elif kind_b == "box":
            d = point_box(origin, Tb, BOX_B) - r
        else:
            d = point_cylinder(origin, Tb, *CYL_B) - r
        return np.maximum(d, 0), d <= 0
    if pair == ("box", "box"):
        I = np.tile(np.eye(4), (n, 1, 1))
        over = obb_overlap(I, np.tile(BOX_A, (n, 1)), Tb, np.tile(BOX_B, (n, 1)))
        d = np.where(over, 0.0, box_box(I, BOX_A, Tb, BOX_B))
        return d, over
    # cylinder a against a box or a cylinder: a witness point decides overlap, else the solver
    u = np.random.default_rng(7).uniform(size=(3000, 3))
    d, over = np.full(n, np.nan), np.zeros(n, dtype=bool)
    for k in range(n):
        pts = cylinder_points(np.eye(4), *CYL_A, u)
        Tk = np.repeat(Tb[k : k + 1], len(pts), 0)
        inside = (
            point_box(pts, Tk, BOX_B) if kind_b == "box" else point_cylinder(pts, Tk, *CYL_B)
        ) == 0
        if inside.any():
            d[k], over[k] = 0.0, True
            continue
        other = (
            (lambda p, k=k: point_box(p[None], Tb[k : k + 1], BOX_B)[0])
            if kind_b == "box"
            else (lambda p, k=k: point_cylinder(p[None], Tb[k : k + 1], *CYL_B)[0])
        )
        value = cylinder_distance(np.eye(4), *CYL_A, other)
        d[k] = value if value > 1e-6 else np.nan  # touching within the solver's reach: skip
    return d, over


def fcl_distances(kind_a: str, kind_b: str, Tb: np.ndarray) -> tuple[np.ndarray, float]:
    import fcl

    a = fcl.CollisionObject(fcl_geometry(kind_a, "a"), fcl.Transform())
    b = fcl.CollisionObject(fcl_geometry(kind_b, "b"), fcl.Transform())
    # fcl's fastest accurate request: unsigned distance with nearest points (its signed mode
    # runs GJK/EPA everywhere: slower, and off by up to 2 mm even for two spheres)
    request = fcl.DistanceRequest(enable_nearest_points=True)
    out = np.empty(len(Tb))
    t0 = time.perf_counter()
    for k in range(len(Tb)):
        b.setTransform(fcl.Transform(Tb[k, :3, :3], Tb[k, :3, 3]))
        out[k] = fcl.distance(a, b, request, fcl.DistanceResult())
    return out, time.perf_counter() - t0


@contextmanager
def numpy_kernels():
    """rworld with ``RWORLD_KERNELS=numpy``: the numpy GJK instead of the compiled one."""
    before = os.environ.get("RWORLD_KERNELS")
    os.environ["RWORLD_KERNELS"] = "numpy"
    try:
        yield
    finally:
        if before is None:
            del os.environ["RWORLD_KERNELS"]
        else:
            os.environ["RWORLD_KERNELS"] = before


def rworld_distances(kind_a: str, kind_b: str, Tb: np.ndarray) -> tuple[cv.Distances, float]:
    I = np.tile(np.eye(4), (len(Tb), 1, 1))
    a, b = rworld_pieces(kind_a, I, "a"), rworld_pieces(kind_b, Tb, "b")
    t0 = time.perf_counter()
    res = cv.distance(a, b)
    return res, time.perf_counter() - t0


def exactness_and_rate(n: int, n_cyl: int, repeat: int) -> None:
    print(
        f"\n## 1-2. Exactness ({n} poses; cylinders against the solver: {n_cyl}) and distance "
        f"queries per second ({n} poses)\n"
    )
    print(
        "| pair | poses | rworld wrong | rworld max error [m] | fcl wrong | fcl max error [m] "
        "| rworld us/query | fcl us/query | rate ratio rworld/fcl | numpy GJK wrong "
        "| numpy GJK us/query | numpy GJK / fcl |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    cases = [
        ("sphere", "sphere"),
        ("sphere", "box"),
        ("sphere", "cylinder"),
        ("box", "box"),
        ("cylinder", "box"),
        ("cylinder", "cylinder"),
    ]
    for seed, (ka, kb) in enumerate(cases):
        m = n_cyl if ka == "cylinder" else n
        T_all = poses(n, 100 + seed)
        Tb = T_all[:m]
        ref_d, ref_over = reference(ka, kb, Tb)
        # rates on all n poses, best of repeat; exactness on the first m
        res_all, t_r = min(
            (rworld_distances(ka, kb, T_all) for _ in range(repeat)), key=lambda x: x[1]
        )
        f_all, t_f = min((fcl_distances(ka, kb, T_all) for _ in range(repeat)), key=lambda x: x[1])
        with numpy_kernels():  # the fallback: the same GJK vectorised in numpy
            np_all, t_n = min(
                (rworld_distances(ka, kb, T_all) for _ in range(repeat)), key=lambda x: x[1]
            )
        res = cv.Distances(*(value[:m] for value in vars(res_all).values()))
        wrong_n = int(
            np.sum(
                (ref_over | (np.nan_to_num(ref_d, nan=0.0) > TOL))
                & (np_all.overlap[:m] != ref_over)
            )
        )
        f = f_all[:m]
        known = ref_over | (np.nan_to_num(ref_d, nan=0.0) > TOL)
        wrong_r = int(np.sum(known & (res.overlap != ref_over)))
        wrong_f = int(np.sum(known & ((f <= 0) != ref_over)))
        sep = known & ~ref_over
        err_r = float(np.max(np.abs(res.distance[sep] - ref_d[sep]), initial=0))
        err_f = float(np.max(np.abs(np.maximum(f[sep], 0) - ref_d[sep]), initial=0))
        us_r, us_f, us_n = 1e6 * t_r / n, 1e6 * t_f / n, 1e6 * t_n / n
        print(
            f"| {ka}-{kb} | {m} | {wrong_r} | {err_r:.1e} | {wrong_f} | {err_f:.1e} "
            f"| {us_r:.2f} | {us_f:.2f} | {us_f / us_r:.2f} | {wrong_n} | {us_n:.2f} "
            f"| {us_f / us_n:.2f} |"
        )


def buried() -> None:
    import fcl
    import trimesh

    from rworld_cli.collision.bodies import Body, pair_distance
    from rworld_cli.model.cell import Box, Shape

    print("\n## 3. A 20 mm cube buried in a closed 400 x 300 x 200 mm mesh block\n")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "block.stl"
        block = trimesh.creation.box(extents=[0.4, 0.3, 0.2])
        block.export(path)
        size = np.array([0.4, 0.3, 0.2])
        mesh = Shape("mesh", np.eye(4), size, Box(np.eye(4), size / 2), mesh_file=path)
        cube = Shape("box", np.eye(4), np.full(3, 0.02), Box(np.eye(4), np.full(3, 0.01)))
        a = Body("block", "block", "block", mesh, np.zeros(3), 0.27)
        b = Body("cube", "cube", "cube", cube, np.zeros(3), 0.0174)
        T = np.eye(4)
        T[:3, 3] = [0.05, 0.02, 0.01]
        ours = pair_distance(a, b, np.eye(4)[None], T[None])
        bvh = fcl.BVHModel()
        bvh.beginModel(len(block.vertices), len(block.faces))
        bvh.addSubModel(np.asarray(block.vertices), np.asarray(block.faces))
        bvh.endModel()
        fa = fcl.CollisionObject(bvh, fcl.Transform())
        fb = fcl.CollisionObject(fcl.Box(0.02, 0.02, 0.02), fcl.Transform(T[:3, :3], T[:3, 3]))
        collide = fcl.collide(fa, fb, fcl.CollisionRequest(), fcl.CollisionResult())
        dist = fcl.distance(fa, fb, fcl.DistanceRequest(), fcl.DistanceResult())
    print("| | collision? | distance [mm] |")
    print("|---|---|---:|")
    print(
        f"| rworld | {'yes (buried)' if ours.buried[0] else 'no'} | 0 (at least "
        f"{1000 * ours.depth[0]:.1f} deep) |"
    )
    print(f"| fcl | {'yes' if collide else 'no'} | {1000 * dist:.1f} |")


def check_cost(repeat: int) -> None:
    rworld = shutil.which("rworld", path=str(Path(sys.executable).parent)) or "rworld"
    print(f"\n## 4. `rworld check` with the continuous collision check (best of {repeat})\n")
    print("| run | --no-collisions [s] | with collisions [s] | ratio |")
    print("|---|---:|---:|---:|")
    for cell, run in (("workcells/puma560", "pick_place"), ("workcells/paper_fig9", "transfer")):
        times = {}
        for label, extra in (("off", ["--no-collisions"]), ("on", [])):
            best = np.inf
            for _ in range(repeat):
                t0 = time.perf_counter()
                subprocess.run(
                    [rworld, "check", cell, run, *extra],
                    cwd=REPO,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                    check=True,
                )
                best = min(best, time.perf_counter() - t0)
            times[label] = best
        print(
            f"| {cell.split('/')[-1]} {run} | {times['off']:.3f} | {times['on']:.3f} "
            f"| {times['on'] / times['off']:.2f} |"
        )


VENDOR_CELLS = ("tx2_60", "iiwa14", "gp7")


def _timed(command: list[str]) -> tuple[float, float]:
    """Wall time [s] and peak memory [MB] of a fresh process."""
    t0 = time.perf_counter()
    child = subprocess.Popen(
        command, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    _, _, usage = os.wait4(child.pid, 0)
    return time.perf_counter() - t0, usage.ru_maxrss / 1024


def _cpu() -> str:
    try:
        for line in subprocess.run(["lscpu"], capture_output=True, text=True).stdout.splitlines():
            if line.startswith("Model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def vendor_checks() -> None:
    rworld = shutil.which("rworld", path=str(Path(sys.executable).parent)) or "rworld"
    print(
        "\n## 5a. `rworld check` on the vendor cells (fresh processes, best of 3; a first run "
        "before them fills the user's caches: kernels, cells, hull parts)\n"
    )
    print("| cell | --no-collisions [s] | check [s] | ratio | check peak [MB] |")
    print("|---|---:|---:|---:|---:|")
    for name in VENDOR_CELLS:
        cell = str(REPO / "tests/data/vendor_cells" / name)
        _timed([rworld, "check", cell, "tour"])
        off = min(_timed([rworld, "check", cell, "tour", "--no-collisions"])[0] for _ in range(3))
        on, peak = min(_timed([rworld, "check", cell, "tour"]) for _ in range(3))
        print(f"| {name} | {off:.2f} | {on:.2f} | {on / off:.1f} | {peak:.0f} |")


def _vendor_checker(name: str):
    """A vendor cell's collision model, a configuration checker for its robot, and the
    robot's joint ranges (n, 2) clipped to one turn [rad]."""
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.collision.configurations import ConfigurationChecker
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.world.tree import World

    loaded = load_cell(str(REPO / "tests/data/vendor_cells" / name / "cell.yaml"))
    cell = getattr(loaded, "cell", loaded)
    model = collision_model(cell)
    device = next(iter(cell.devices))
    check = ConfigurationChecker(World(cell), model, device)
    joints = cell.devices[device].joints
    limits = np.clip([(j.limits.lower, j.limits.upper) for j in joints], -np.pi, np.pi)
    return model, check, limits


def vendor_configurations(batches=(1, 64, 4096)) -> None:
    import coal
    from peers import coal_mesh

    print("\n## 5b. Configuration checks: microseconds per joint state (one run)\n")
    print(
        "| robot | batch | rworld [us/state] | coal [us/state] | coal / rworld | decisions alike |"
    )
    print("|---|---:|---:|---:|---:|---:|")
    for name in VENDOR_CELLS:
        model, check, limits = _vendor_checker(name)
        geometry = {}
        for body in model.bodies:  # coal: an OBBRSS tree of the body's triangles, in its frame
            geometry[body.label] = coal_mesh(body.mesh().triangles())
        pairs = [(model.bodies[i], model.bodies[j]) for i, j in check.pairs]
        rng = np.random.default_rng(0)
        check.check(rng.uniform(limits[:, 0], limits[:, 1], (256, len(limits))), nearest=False)
        request = coal.CollisionRequest()
        for batch in batches:
            # at least 256 states a batch size, in calls of that size: one call of one state
            # is too short to time on a shared machine
            calls = max(1, 256 // batch)
            q = rng.uniform(limits[:, 0], limits[:, 1], (calls, batch, len(limits)))
            t0 = time.perf_counter()
            free = np.concatenate([check.check(qc, nearest=False).free for qc in q])
            ours = time.perf_counter() - t0
            t0 = time.perf_counter()
            theirs_free = np.ones(calls * batch, dtype=bool)
            for c, qc in enumerate(q):
                poses = check.poses(qc)
                for k in range(batch):
                    for a, b in pairs:
                        Ta, Tb = poses[a.frame][k], poses[b.frame][k]
                        result = coal.CollisionResult()
                        if coal.collide(
                            geometry[a.label],
                            coal.Transform3s(Ta[:3, :3], Ta[:3, 3]),
                            geometry[b.label],
                            coal.Transform3s(Tb[:3, :3], Tb[:3, 3]),
                            request,
                            result,
                        ):
                            theirs_free[c * batch + k] = False
                            break
            theirs = time.perf_counter() - t0
            states = calls * batch
            print(
                f"| {name} | {batch} | {ours / states * 1e6:.0f} | {theirs / states * 1e6:.0f} "
                f"| {theirs / ours:.2f} | {np.mean(free == theirs_free):.3f} |"
            )


def vendor_segments(count: int = 20, step: float = 0.2) -> None:
    """Segment checks (``check_segment``): ``count`` straight joint-space segments of ``step``
    rad each, from free random states, per robot."""
    print(f"\n## 5c. Segment checks: {count} segments of {step} rad from free states (one run)\n")
    print("| robot | segments/s | ms a segment | free | exact queries a segment |")
    print("|---|---:|---:|---:|---:|")
    for name in VENDOR_CELLS:
        model, check, limits = _vendor_checker(name)
        rng = np.random.default_rng(2)
        Q = rng.uniform(limits[:, 0], limits[:, 1], (20 * count, len(limits)))
        starts = Q[check.check(Q, nearest=False).free][:count]
        steps = rng.normal(size=starts.shape)
        steps *= step / np.linalg.norm(steps, axis=1, keepdims=True)
        t0 = time.perf_counter()
        reports = [check.check_segment(q0, q0 + d) for q0, d in zip(starts, steps)]
        elapsed = time.perf_counter() - t0
        queries = np.mean([r.queries for r in reports])
        free = sum(r.free for r in reports)
        print(
            f"| {name} | {len(reports) / elapsed:.1f} | {elapsed / len(reports) * 1e3:.0f} "
            f"| {free} of {len(reports)} | {queries:.0f} |"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--vendor", action="store_true", help="only section 5: the vendor cells, beside coal"
    )
    parser.add_argument("--pairs", type=int, default=5000, help="random poses per shape pair")
    parser.add_argument("--cylinder-pairs", type=int, default=400, help="poses for cylinders")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    if args.vendor:
        print(f"# Collision bench, vendor cells: {_cpu()}, Python {platform.python_version()}")
        vendor_checks()
        vendor_configurations()
        vendor_segments()
        return
    import fcl

    cpu = _cpu()
    print(
        f"# Collision bench: {cpu}, Python {platform.python_version()}, "
        f"python-fcl {getattr(fcl, '__version__', '?')}, numpy {np.__version__}"
    )
    exactness_and_rate(args.pairs, args.cylinder_pairs, args.repeat)
    buried()
    check_cost(args.repeat)
    vendor_checks()
    vendor_configurations()
    vendor_segments()


if __name__ == "__main__":
    main()
