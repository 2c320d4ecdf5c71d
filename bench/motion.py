"""Collision-free joint paths beside OMPL's RRT-Connect, on the same problems with the same
collision checks.

Run:  .venv/bin/pip install -e ".[bench]" && .venv/bin/python bench/motion.py [--timeout 10]

The problems are ``tests/data/motion/problems.yaml`` (tests/data/motion/build.py: six scenes -
a shelf, a bin, a table with fixtures, two arms on one table for the Franka Panda; a shelf and
the holed-plate fixture cell for the Yaskawa GP7 from the vendor's meshes - ten start/goal pairs
each, both ends free, the straight segment between them not).

Both planners get rworld's own checks (``planning.motion.WorldChecks``, built once per scene):
a state is free by ``ConfigurationChecker.check`` with a 5 mm margin over the clearance (none
near the ends); OMPL (``ompl`` 2.0.1 from PyPI, ``og.RRTConnect`` with its default range, the
default discrete motion validator with states 0.05 rad apart, Euclidean) asks one state at a
time, as its ``StateValidityChecker`` interface does, then simplifies its path
(``simplifySolution``: vertex reduction, shortcuts, B-spline smoothing, each step checked);
rworld asks an edge's states in one batch and checks its final segments continuously
(``check_segment``) itself.  OMPL's final path is then checked with the same
``check_segment`` (not timed): a path that fails it does not count as solved - the guarantee
``rworld check`` gives is continuous.  Times are wall times of one process, both in it; path
lengths are Euclidean in joint space [rad].

Reported per robot and overall: success rate, median and 95th-percentile planning time, median
path length, and each side's median over the problems both solved.  ``--phases``: where
rworld's time goes on each scene (search, shortcuts, the final continuous checks, the blends).
Smoothing: each path's corners and how many were blended, and its time-optimal duration
(velocity and acceleration limits) at rest at every via point and blended; ``--no-blend``
plans without blending.

VAMP (``vamp-planner``, the speed anchor the issue names) is not run: the package index this
machine reaches has its 0.6.4 as a source archive only, no wheel for any Python, and building
it fetches three of its dependencies (nigh, pdqsort, SIMDxorshift) from GitHub at configure
time (CPM), which this machine cannot reach.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
PROBLEMS = REPO / "tests" / "data" / "motion" / "problems.yaml"
OMPL_STEP = 0.05  # [rad] OMPL's motion validator: states this far apart (Euclidean)


def scene_checks(scene: str, device: str, tolerance: float = 1e-3):
    """(world, model, WorldChecks) of a scene."""
    from rworld_cli.api import device_context
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.planning.motion import PATH_CLEARANCE, WorldChecks

    ctx = device_context(str(PROBLEMS.parent / scene), device)
    model = collision_model(ctx.world.cell)
    # as `plan path` plans without --clearance: 1 mm kept where the ends allow
    return ctx.world, model, WorldChecks(ctx.world, model, device, tolerance, kept=PATH_CLEARANCE)


def ompl_plan(checks, start, goal, timeout: float):
    """OMPL's RRT-Connect with ``checks``: (found, waypoints (W, n), seconds, continuous-valid)."""
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    usable, why = checks.problem(start, goal)
    n = len(start)
    if why is not None:
        return False, np.zeros((0, n)), 0.0, False
    lower, upper = checks.box()
    space = ob.RealVectorStateSpace(n)
    bounds = ob.RealVectorBounds(n)
    for i in range(n):
        bounds.setLow(i, float(lower[i]))
        bounds.setHigh(i, float(upper[i]))
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)

    def valid(state) -> bool:
        return bool(checks.states_free(np.array([[state[i] for i in range(n)]]))[0])

    ss.setStateValidityChecker(valid)
    si = ss.getSpaceInformation()
    si.setStateValidityCheckingResolution(OMPL_STEP / space.getMaximumExtent())
    a, b = space.allocState(), space.allocState()
    for i in range(n):
        a[i], b[i] = float(start[i]), float(goal[i])
    ss.setStartAndGoalStates(a, b)
    ss.setPlanner(og.RRTConnect(si))
    t0 = time.perf_counter()
    solved = ss.solve(timeout)
    found = bool(solved) and ss.haveExactSolutionPath()
    if found:
        ss.simplifySolution(max(0.0, timeout - (time.perf_counter() - t0)))
    seconds = time.perf_counter() - t0
    if not found:
        return False, np.zeros((0, n)), seconds, False
    path = ss.getSolutionPath()
    way = np.array([[s[i] for i in range(n)] for s in path.getStates()])
    valid_path = all(checks.segment_free(p, q) for p, q in zip(way[:-1], way[1:]))
    return True, way, seconds, valid_path


def coal_geometry(model) -> dict:
    """An independent checker's view of a collision model: body label -> (coal geometry, its
    pose in the body's frame) - boxes, cylinders and spheres as coal's own primitives, meshes
    as OBBRSS trees of their triangles."""
    import coal
    from peers import coal_mesh

    out = {}
    for body in model.bodies:
        shape = body.shape
        if shape.kind == "box":
            geometry = coal.Box(*[float(v) for v in shape.size])
        elif shape.kind == "cylinder":
            geometry = coal.Cylinder(float(shape.size[0]) / 2, float(shape.size[2]))
        elif shape.kind == "sphere":
            geometry = coal.Sphere(float(shape.size[0]) / 2)
        else:
            out[body.label] = (coal_mesh(body.mesh().triangles()), np.eye(4))
            continue
        out[body.label] = (geometry, np.asarray(shape.T_owner_shape, dtype=float))
    return out


def coal_clearance(checks, model, geometry, way, blends, spacing: float = 0.01) -> float:
    """The least distance [m] coal measures between the pairs the planner checks, over states
    at most ``spacing`` rad apart along the path as driven (its segments and blends): below 0
    the path passes through something (coal's signed distance), 0 a touch.  A pair at a state
    is measured unless its bounding spheres (coal's local boxes' centre and radius) are
    farther apart than the least distance measured so far, nearest first: the least exactly,
    without measuring every pair at every state."""
    import coal

    from rworld_cli.planning.path import JointPath

    path = JointPath(way, None, "blended", blends)
    count = max(2, int(np.ceil(length(way) / spacing)) + 1)
    Q = path.evaluate(np.linspace(0.0, 1.0, count))[0]
    poses = checks.exact.poses(Q)
    request = coal.DistanceRequest()
    request.enable_signed_distance = True
    pairs = [(model.bodies[i], model.bodies[j]) for i, j in checks.exact.pairs]
    bounds = []
    for a, b in pairs:
        ends = []
        for body in (a, b):
            g, S = geometry[body.label]
            g.computeLocalAABB()
            T = poses[body.frame] @ S  # (K, 4, 4) or (4, 4)
            centre = T[..., :3, :3] @ np.asarray(g.aabb_center) + T[..., :3, 3]
            ends.append((np.broadcast_to(centre, (count, 3)), g.aabb_radius))
        (ca, ra), (cb, rb) = ends
        bounds.append(np.linalg.norm(ca - cb, axis=1) - ra - rb)
    bound = np.array(bounds)  # (P, K): no pair nearer than its spheres' gap
    least = np.inf
    for flat in np.argsort(bound, axis=None):
        p, k = divmod(int(flat), count)
        if bound[p, k] >= least:
            break
        (a, b) = pairs[p]
        (ga, Sa), (gb, Sb) = geometry[a.label], geometry[b.label]
        Ta = np.broadcast_to(poses[a.frame], (count, 4, 4))[k] @ Sa
        Tb = np.broadcast_to(poses[b.frame], (count, 4, 4))[k] @ Sb
        result = coal.DistanceResult()
        d = coal.distance(
            ga,
            coal.Transform3s(Ta[:3, :3], Ta[:3, 3]),
            gb,
            coal.Transform3s(Tb[:3, :3], Tb[:3, 3]),
            request,
            result,
        )
        least = min(least, float(d))
    return least


def ompl_solve(ctx, model, device, start, goal, timeout: float) -> bool:
    """For tests/data/motion/build.py: whether OMPL finds a continuously valid path."""
    from rworld_cli.planning.motion import WorldChecks

    checks = WorldChecks(ctx.world, model, device, 1e-3)
    found, _, _, valid = ompl_plan(checks, np.asarray(start), np.asarray(goal), timeout)
    return found and valid


def rworld_plan(world, model, device, checks, start, goal, timeout: float, seed: int, blend=True):
    from rworld_cli.planning.motion import plan_in_world

    t0 = time.perf_counter()
    plan, _ = plan_in_world(
        world,
        model,
        device,
        start,
        goal,
        tolerance=1e-3,
        seed=seed,
        timeout=timeout,
        checks=checks,
        blend=blend,
    )
    return plan.found, plan.waypoints, time.perf_counter() - t0, plan


def phases(scene: str, items: list[dict]) -> None:
    """Where rworld's time goes on a scene's problems: the search, the shortcuts and the
    final segments' continuous checks (wall time, states asked), one process."""
    import rworld_cli.planning.motion as motion

    world, model, checks = scene_checks(scene, items[0]["device"])
    states = [0, 0.0]
    states_free = checks.states_free

    def counted(Q):
        t0 = time.perf_counter()
        out = states_free(Q)
        states[0] += len(np.atleast_2d(Q))
        states[1] += time.perf_counter() - t0
        return out

    checks.states_free = counted
    spent = {name: [0, 0.0] for name in ("_connect_trees", "_shortcut", "_validated", "_blended")}
    originals = {name: getattr(motion, name) for name in spent}
    for name, original in originals.items():

        def timed(*args, _original=original, _name=name, **kw):
            before, t0 = states[0], time.perf_counter()
            out = _original(*args, **kw)
            spent[_name][0] += states[0] - before
            spent[_name][1] += time.perf_counter() - t0
            return out

        setattr(motion, name, timed)
    t0 = time.perf_counter()
    for k, p in enumerate(items):
        rworld_plan(world, model, p["device"], checks, p["start"], p["goal"], 10.0, seed=k)
    total = time.perf_counter() - t0
    for name, original in originals.items():
        setattr(motion, name, original)
    print(
        f"{scene}: {len(items)} problems in {total:.3f} s; states asked {states[0]} in "
        f"{states[1]:.3f} s ({1e6 * states[1] / max(states[0], 1):.0f} us a state)"
    )
    for name, label in (
        ("_connect_trees", "search"),
        ("_shortcut", "shortcuts"),
        ("_validated", "continuous checks of the final segments"),
        ("_blended", "blending the corners (screened states, continuous checks)"),
    ):
        print(f"  {label}: {spent[name][1]:.3f} s, {spent[name][0]} states")


def durations(device, plan) -> dict:
    """The path's corners and blends, and its time-optimal duration (velocity and acceleration
    limits, ``planning.topp``) at rest at every via point and with its corners blended."""
    from rworld_cli.planning.path import JointPath
    from rworld_cli.planning.topp import Limits, time_optimal

    limits = Limits(device.limit_array("velocity"), device.limit_array("acceleration"), None)
    stop = JointPath(plan.waypoints, plan.knots, "segments")
    t_stop = time_optimal(stop, limits, gridpoints=1000)[0].duration
    t_blend = time_optimal(plan.joint_path(), limits, gridpoints=1000)[0].duration
    return {
        "corners": len(plan.waypoints) - 2,
        "blended": int((plan.blends > 0).sum()),
        "stop_s": t_stop,
        "blend_T": t_blend,
    }


def length(way: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(way, axis=0), axis=1).sum()) if len(way) > 1 else 0.0


def summary(rows: list[dict], side: str) -> tuple[float, float, float, float]:
    ok = [r for r in rows if r[f"{side}_ok"]]
    times = np.array([r[f"{side}_s"] for r in rows])
    lengths = np.array([r[f"{side}_len"] for r in ok])
    return (
        len(ok) / max(1, len(rows)),
        float(np.median(times)) if len(times) else float("nan"),
        float(np.percentile(times, 95)) if len(times) else float("nan"),
        float(np.median(lengths)) if len(lengths) else float("nan"),
    )


def _cases(args, scenes: dict, invalid: list):
    """The problems to plan, each a dict: scene (its name), group (the robot; MBM: the family),
    k, device, world, model, checks, start, goal (and MBM: coal's geometry).  MBM problems
    whose start or goal is not free by rworld's check go to ``invalid`` (name, why)."""
    if not args.mbm:
        for scene, items in scenes.items():
            items = items[: args.limit] if args.limit else items
            device = items[0]["device"]
            world, model, checks = scene_checks(scene, device)
            for k, p in enumerate(items):
                yield {
                    "scene": scene,
                    "group": device,
                    "k": k,
                    "device": device,
                    "world": world,
                    "model": model,
                    "checks": checks,
                    "start": np.array(p["start"]),
                    "goal": np.array(p["goal"]),
                }
        return
    import tempfile

    from rworld_cli.api import device_context
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.planning.motion import PATH_CLEARANCE, WorldChecks
    from tests.planning import mbm_cells as mbm

    root = Path(tempfile.mkdtemp(prefix="rworld-mbm-"))
    robot = mbm.robot_cell(root)
    for k, problem in enumerate(mbm.problems(args.only, args.limit or 20)):
        name = f"{problem['family']} {problem['index']}"
        folder = mbm.write_cell(
            problem, root / f"{problem['family']}_{problem['index']:04d}", robot
        )
        ctx = device_context(str(folder), "panda")
        model = collision_model(ctx.world.cell)
        checks = WorldChecks(ctx.world, model, "panda", 1e-3, kept=PATH_CLEARANCE)
        start, goal = np.array(problem["start"]), np.array(problem["goal"])
        _, why = checks.problem(start, goal)
        if why is not None:
            invalid.append((name, why))
            print(f"{name}: left out: {why}", file=sys.stderr, flush=True)
            continue
        yield {
            "scene": problem["family"],
            "group": problem["family"],
            "k": problem["index"] - 1,
            "device": "panda",
            "world": ctx.world,
            "model": model,
            "checks": checks,
            "start": start,
            "goal": goal,
            "geometry": coal_geometry(model),
        }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timeout", type=float, default=10.0, help="per problem and planner [s]")
    parser.add_argument("--only", nargs="*", default=None, help="scenes to run")
    parser.add_argument("--limit", type=int, default=None, help="problems per scene at most")
    parser.add_argument("--no-ompl", action="store_true", help="rworld alone")
    parser.add_argument(
        "--no-blend", action="store_true", help="rworld's corners left at rest (no smoothing)"
    )
    parser.add_argument(
        "--phases", action="store_true", help="where rworld's time goes, per scene (no OMPL)"
    )
    parser.add_argument(
        "--mbm",
        action="store_true",
        help="MotionBenchMaker's Panda problems (tests/data/mbm) instead of the project's scenes; "
        "--only names families, --limit counts per family (default 20)",
    )
    args = parser.parse_args()
    problems = yaml.safe_load(PROBLEMS.read_text())["problems"]
    scenes: dict[str, list[dict]] = {}
    for p in problems:
        if args.only is None or p["scene"] in args.only:
            scenes.setdefault(p["scene"], []).append(p)
    from machine import cpu_model

    cpu = cpu_model()
    print(
        f"# Motion planning beside OMPL: {cpu}, Python {platform.python_version()}, "
        f"timeout {args.timeout:g} s{', MotionBenchMaker Panda' if args.mbm else ''}\n"
    )
    if args.phases:
        for scene, items in scenes.items():
            phases(scene, items[: args.limit] if args.limit else items)
        sys.stdout.flush()
        os._exit(0)
    rows, invalid = [], []
    for case in _cases(args, scenes, invalid):
        scene, k, device = case["scene"], case["k"], case["device"]
        world, model, checks = case["world"], case["model"], case["checks"]
        start, goal = case["start"], case["goal"]
        ok, way, seconds, plan = rworld_plan(
            world, model, device, checks, start, goal, args.timeout, k, not args.no_blend
        )
        row = {"scene": scene, "robot": case["group"], "rworld_ok": ok, "rworld_s": seconds}
        row["rworld_len"] = length(way)
        if ok:
            row.update(durations(checks.device, plan))
            row["blend_s"] = plan.blend_seconds
            if args.mbm:
                row["coal_m"] = coal_clearance(checks, model, case["geometry"], way, plan.blends)
        if not args.no_ompl:
            found, oway, oseconds, valid = ompl_plan(checks, start, goal, args.timeout)
            row.update(
                ompl_ok=found and valid,
                ompl_found=found,
                ompl_s=oseconds,
                ompl_len=length(oway),
            )
            if args.mbm and found:
                row["ompl_coal_m"] = coal_clearance(
                    checks, model, case["geometry"], oway, np.zeros(len(oway))
                )
        rows.append(row)
        print(
            f"{scene} {k + 1}: rworld {'ok' if ok else 'FAIL'} {seconds:.3f} s "
            f"{row['rworld_len']:.3f} rad"
            + (
                f" (corners {row['corners']}, blended {row['blended']}, "
                f"{row['stop_s']:.2f} -> {row['blend_T']:.2f} s)"
                if ok
                else ""
            )
            + (
                ""
                if args.no_ompl
                else f" | ompl {'ok' if row['ompl_ok'] else ('invalid' if found else 'FAIL')} "
                f"{oseconds:.3f} s {row['ompl_len']:.3f} rad"
            ),
            file=sys.stderr,
            flush=True,
        )
    sides = ["rworld"] + ([] if args.no_ompl else ["ompl"])
    group = "family" if args.mbm else "robot"
    print(f"| {group} | planner | problems | solved | median [s] | p95 [s] | median length [rad] |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for robot in sorted({r["robot"] for r in rows}) + ["all"]:
        subset = [r for r in rows if robot in ("all", r["robot"])]
        for side in sides:
            rate, median, p95, med_len = summary(subset, side)
            print(
                f"| {robot} | {side} | {len(subset)} | {100 * rate:.0f} % | {median:.3f} | "
                f"{p95:.3f} | {med_len:.3f} |"
            )
    timed = [r for r in rows if r["rworld_ok"] and r["corners"] > 0]
    if timed:
        corners = sum(r["corners"] for r in timed)
        blended = sum(r["blended"] for r in timed)
        ratio = np.median([r["blend_T"] / r["stop_s"] for r in timed])
        print(
            f"\nSmoothing, on the {len(timed)} paths with corners: {blended} of {corners} corners "
            f"blended; time-optimal duration blended / at rest at every via point, median "
            f"{ratio:.2f} (min {min(r['blend_T'] / r['stop_s'] for r in timed):.2f}); blending "
            f"took a median {1000 * np.median([r['blend_s'] for r in timed]):.1f} ms a path"
        )
    if not args.no_ompl:
        both = [r for r in rows if r["rworld_ok"] and r["ompl_ok"]]
        if both:
            t_ratio = np.median([r["ompl_s"] / r["rworld_s"] for r in both])
            l_ratio = np.median([r["rworld_len"] / r["ompl_len"] for r in both])
            print(
                f"\nOn the {len(both)} problems both solved: OMPL's time / rworld's, median "
                f"{t_ratio:.2f}x; rworld's path length / OMPL's, median {l_ratio:.2f}"
            )
        bad = sum(1 for r in rows if r.get("ompl_found") and not r["ompl_ok"])
        print(f"OMPL paths found but failing the continuous check: {bad} of {len(rows)}")
    if args.mbm:
        print(f"\nLeft out (start or goal not free by rworld's check): {len(invalid)}")
        for name, why in invalid:
            print(f"- {name}: {why}")
        for side, key in (("rworld", "coal_m"), ("ompl", "ompl_coal_m")):
            measured = [r[key] for r in rows if key in r]
            if measured:
                touching = sum(1 for d in measured if d <= 0.0)
                print(
                    f"coal on {side}'s paths (states 0.01 rad apart, blends included): "
                    f"{touching} of {len(measured)} touch or pass through something; the least "
                    f"distance {1000 * min(measured):.3f} mm, median of each path's least "
                    f"{1000 * float(np.median(measured)):.2f} mm"
                )
    sys.stdout.flush()
    os._exit(0)  # ompl's bindings report leaked objects at interpreter exit: not ours


if __name__ == "__main__":
    main()
