"""Penetration depths beside coal's EPA, on MotionBenchMaker's Panda scenes.

Run:  .venv/bin/pip install -e ".[bench]" && .venv/bin/python bench/depth.py [--per-family 1000]

For each of MBM's 7 scene families (its first problem's cell, ``tests/data/mbm``): random joint
states of the Panda (seeded, uniform in its limits); at each, every pair the planner checks of
a link and one of the scene's boxes or cylinders whose bodies overlap by rworld's
``bodies.pair_distance`` (depths exact: ``exact_above`` 0), until ``--per-family``
overlapping pairs.  Each is measured again by coal (``coal.collide``, every contact) and
coal's deepest contact compared with rworld's depth (the deepest piece pair, the same
definition).  A link is what rworld checks: the import closes MBM's Panda meshes (their seams
merged), and a closed link that is one convex part is its hull - given to coal as the same
hull (``coal.Convex``: coal's GJK and EPA on the solid); link 6, an open surface, is its
triangles (coal: each triangle against the primitive).  Link against link is left out: coal
measures two meshes' crossing triangles by its triangle intersection test, whose depth is not
the pair's penetration depth.  So are link 7 and the hand, several convex parts each (coal
would need each part as its own object).  Printed per family: pairs, the median
depth, and |rworld - coal|: median, 99th percentile, largest, and the share within 1e-6 m;
then the time each took.  A pair coal
reports no contact for (it and rworld disagree whether they overlap at all) is counted apart.
"""

from __future__ import annotations

import argparse
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "bench"))


def coal_convex(vertices: np.ndarray):
    """coal's convex hull of ``vertices`` (V, 3) [m] (its own qhull)."""
    import coal

    points = coal.StdVec_Vec3s()
    for p in np.asarray(vertices, dtype=float):
        points.append(p)
    return coal.Convex.convexHull(points, False, None)


def coal_depth(geometry, a, b, Ta, Tb) -> float:
    """coal's deepest contact between two bodies at their poses [m] (nan: no contact)."""
    import coal

    (ga, Sa), (gb, Sb) = geometry[a.label], geometry[b.label]
    A, B = Ta @ Sa, Tb @ Sb
    request = coal.CollisionRequest()
    request.enable_contact = True
    request.num_max_contacts = 100_000
    result = coal.CollisionResult()
    coal.collide(
        ga,
        coal.Transform3s(A[:3, :3], A[:3, 3]),
        gb,
        coal.Transform3s(B[:3, :3], B[:3, 3]),
        request,
        result,
    )
    if not result.isCollision():
        return float("nan")
    # coal's penetration_depth is a signed distance: minus the depth
    return max(-c.penetration_depth for c in result.getContacts())


def main() -> None:
    from machine import cpu_model
    from motion import coal_geometry

    from rworld_cli.api import device_context
    from rworld_cli.collision.bodies import collision_model, pair_distance
    from rworld_cli.planning.motion import WorldChecks
    from tests.planning import mbm_cells as mbm

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-family", type=int, default=1000, help="overlapping pairs each")
    parser.add_argument("--only", nargs="*", default=None, help="families to run")
    args = parser.parse_args()
    cpu = cpu_model()
    print(f"# Penetration depths beside coal: {cpu}, Python {platform.python_version()}\n")
    print(
        "| family | pairs | median depth [mm] | |rworld - coal| median [m] | p99 [m] | max [m] "
        "| within 1e-6 m | coal: no contact | rworld [ms a pair] | coal [ms a pair] |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    root = Path(tempfile.mkdtemp(prefix="rworld-depth-"))
    robot = mbm.robot_cell(root)
    rng = np.random.default_rng(61)
    for family in args.only or mbm.FAMILIES:
        problem = next(mbm.problems([family], 1))
        folder = mbm.write_cell(problem, root / family, robot)
        ctx = device_context(str(folder), "panda")
        model = collision_model(ctx.world.cell)
        checks = WorldChecks(ctx.world, model, "panda", 1e-3)
        geometry = coal_geometry(model)
        for body in model.bodies:  # one convex part: that hull, as rworld checks it
            if body.shape.kind == "mesh" and not body.is_mesh and body.single_piece:
                geometry[body.label] = (coal_convex(body.parts[0][0]), np.eye(4))
        lower, upper = checks.box()
        ours, theirs, t_ours, t_theirs, missing = [], [], 0.0, 0.0, 0
        while len(ours) + missing < args.per_family:
            Q = rng.uniform(lower, upper, size=(64, len(lower)))
            poses = checks.exact.poses(Q)
            for i, j in checks.exact.pairs:
                a, b = model.bodies[i], model.bodies[j]
                if (a.shape.kind == "mesh") == (b.shape.kind == "mesh"):
                    continue  # a link against a primitive (module docstring)
                link = a if a.shape.kind == "mesh" else b
                if not (link.is_mesh or link.single_piece):
                    continue
                t0 = time.perf_counter()
                found = pair_distance(a, b, poses[a.frame], poses[b.frame])
                t_ours += time.perf_counter() - t0
                for k in np.flatnonzero((found.depth > 0) & ~found.buried):
                    t0 = time.perf_counter()
                    d = coal_depth(geometry, a, b, poses[a.frame][k], poses[b.frame][k])
                    t_theirs += time.perf_counter() - t0
                    if np.isnan(d):
                        missing += 1
                        continue
                    ours.append(found.depth[k])
                    theirs.append(d)
                if len(ours) + missing >= args.per_family:
                    break
        ours, theirs = np.array(ours), np.array(theirs)
        error = np.abs(ours - theirs)
        count = len(ours) + missing
        print(
            f"| {family} | {len(ours)} | {1000 * np.median(ours):.2f} | {np.median(error):.1e} | "
            f"{np.percentile(error, 99):.1e} | {error.max():.1e} | "
            f"{100 * np.mean(error <= 1e-6):.1f} % | {missing} | "
            f"{1000 * t_ours / count:.2f} | {1000 * t_theirs / count:.2f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
