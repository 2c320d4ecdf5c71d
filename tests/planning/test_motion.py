"""Collision-free joint paths: the planner on a plane with walls (exact answers), then on the
Panda and the GP7 scenes of tests/data/motion with the collision room's checks, through the
API, the program step ``path: free`` and ``rworld plan path``.

Each planned path is re-checked by a checker the planner did not use: a fresh
``ConfigurationChecker``'s continuous segment check and the states along it; a planned run
passes ``rworld check`` (collisions with the guarantee between samples).
"""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from rworld_cli.planning.motion import path_length, plan_path
from tests.conftest import REPO

MOTION = REPO / "tests" / "data" / "motion"
PROBLEMS = yaml.safe_load((MOTION / "problems.yaml").read_text())["problems"]

# ------------------------------------------------------------------ a plane with two walls
# walls: x in (-0.05, 0.05) below y = 0.6; x in (0.45, 0.55) above y = -0.6


def blocked(Q, margin: float = 0.0) -> np.ndarray:
    Q = np.atleast_2d(Q)
    first = (np.abs(Q[:, 0]) < 0.05 + margin) & (Q[:, 1] < 0.6 + margin)
    second = (np.abs(Q[:, 0] - 0.5) < 0.05 + margin) & (Q[:, 1] > -0.6 - margin)
    return first | second


def segment_hits_box(a, b, lo, hi) -> bool:
    """Whether the segment a-b meets the open box (lo, hi): slab clipping, exact."""
    t0, t1 = 0.0, 1.0
    d = b - a
    for k in range(len(a)):
        if abs(d[k]) < 1e-15:
            if not lo[k] < a[k] < hi[k]:
                return False
            continue
        ta, tb = sorted(((lo[k] - a[k]) / d[k], (hi[k] - a[k]) / d[k]))
        t0, t1 = max(t0, ta), min(t1, tb)
        if t0 >= t1:
            return False
    return True


WALLS = [
    (np.array([-0.05, -np.inf]), np.array([0.05, 0.6])),
    (np.array([0.45, -0.6]), np.array([0.55, np.inf])),
]


def exact_segment_free(a, b, walls=WALLS) -> bool:
    return not any(segment_hits_box(np.asarray(a), np.asarray(b), lo, hi) for lo, hi in walls)


def plane_plan(seed=0, **kw):
    return plan_path(
        lambda Q: ~blocked(Q, 0.01),
        exact_segment_free,
        [-0.8, -0.8],
        [0.8, 0.8],
        [-1, -1],
        [1, 1],
        seed=seed,
        **kw,
    )


@pytest.mark.parametrize("seed", range(6))
def test_a_path_round_two_walls_is_free_inside_the_box_and_shortened(seed):
    plan = plane_plan(seed)
    assert plan.found and plan.reason is None
    way = plan.waypoints
    assert np.allclose(way[0], [-0.8, -0.8]) and np.allclose(way[-1], [0.8, 0.8])
    assert all(exact_segment_free(a, b) for a, b in zip(way[:-1], way[1:]))
    assert (way >= -1).all() and (way <= 1).all()
    # around both walls: at least 2 + 2 * 1.2 long; shortcuts never lengthen
    assert 4.4 < plan.length <= plan.raw_length + 1e-12
    assert plan.length == pytest.approx(path_length(way))
    assert plan.length < 5.3  # the raw tree paths run 6-8 (loose bound: any sane shortcutting)


def test_the_same_seed_gives_the_same_path_and_another_seed_another():
    a, b, c = plane_plan(3), plane_plan(3), plane_plan(4)
    assert np.array_equal(a.waypoints, b.waypoints)
    assert not np.array_equal(a.waypoints, c.waypoints)


def test_a_straight_line_that_is_free_is_the_path():
    plan = plan_path(
        lambda Q: ~blocked(Q), exact_segment_free, [-0.8, -0.8], [-0.8, 0.8], [-1, -1], [1, 1]
    )
    assert plan.found and len(plan.waypoints) == 2 and plan.iterations == 0


def test_a_wall_thinner_than_the_state_spacing_is_caught_by_the_continuous_check():
    """The states 0.05 apart step over a 4 mm wall; the segment check does not, and the
    segment is planned again between its ends with finer spacing."""
    thin = [(np.array([0.298, -np.inf]), np.array([0.302, 0.5]))]

    def states_free(Q):
        Q = np.atleast_2d(Q)
        return ~((np.abs(Q[:, 0] - 0.3) < 0.002) & (Q[:, 1] < 0.5))

    repaired = 0
    for seed in range(4):
        plan = plan_path(
            states_free,
            lambda a, b: exact_segment_free(a, b, thin),
            [0.0, 0.0],
            [0.6, 0.0],
            [-1, -1],
            [1, 1],
            seed=seed,
        )
        assert plan.found
        way = plan.waypoints
        assert all(exact_segment_free(a, b, thin) for a, b in zip(way[:-1], way[1:]))
        assert way[:, 1].max() >= 0.5  # over the wall's end: the only way round
        repaired += plan.repairs
    assert repaired > 0


def _behind_a_thin_wall(gap: float | None):
    """A block the paths go over (|x| < 0.2, y < 0.3) and a wall 20 mm thick across their way
    (x = 0, up to y = ``gap``; None: to the box's top), thin beside the states' 0.05 spacing:
    the trees step over it, the continuous check does not."""

    def states_free(Q):
        Q = np.atleast_2d(Q)
        block = (np.abs(Q[:, 0]) < 0.2) & (Q[:, 1] < 0.3)
        wall = (np.abs(Q[:, 0]) < 0.01) & (Q[:, 1] < (np.inf if gap is None else gap))
        return ~(block | wall)

    def segment_free(a, b):
        s = np.linspace(0.0, 1.0, 4001)[:, None]
        return bool(states_free(a + s * (b - a)).all())

    return states_free, segment_free


@pytest.mark.parametrize("seed", [0, 2, 4, 12])
def test_a_path_refused_by_the_continuous_check_starts_the_search_again(seed):
    """Seeds whose first path crosses the wall where the states step over it and whose repair
    fails: that path is dropped and the trees grown again (the planner gave up here before,
    with most of its time left); the path found passes the continuous check whole."""
    states_free, segment_free = _behind_a_thin_wall(0.8)
    plan = plan_path(
        states_free,
        segment_free,
        [-0.5, -0.5],
        [0.5, -0.5],
        [-1, -1],
        [1, 1],
        seed=seed,
        timeout=60.0,
    )
    assert plan.found and plan.attempts >= 2, (plan.attempts, plan.reason)
    assert plan.blocked is not None and not segment_free(*plan.blocked)
    way = plan.waypoints
    assert all(segment_free(a, b) for a, b in zip(way[:-1], way[1:]))
    assert way[:, 1].max() >= 0.8  # over the wall's end


def test_a_wall_with_no_way_round_ends_at_the_time_limit_naming_the_failed_paths():
    states_free, segment_free = _behind_a_thin_wall(None)
    plan = plan_path(
        states_free, segment_free, [-0.5, -0.5], [0.5, -0.5], [-1, -1], [1, 1], timeout=0.5
    )
    assert not plan.found and plan.attempts >= 1 and plan.seconds < 2.0
    assert re.fullmatch(
        r"\d+ path\(s\) whose states passed failed the continuous check and could not be "
        r"planned around within the time limit|no path found within the time limit \(\d+ "
        r"path\(s\) found before failed the continuous check and could not be planned around\)"
        r"|no path found within the time limit \(it ran out during the continuous check of a "
        r"path found; \d+ path\(s\) before failed it and could not be planned around\)",
        plan.reason,
    ), plan.reason
    assert not segment_free(*plan.blocked)


def test_failures_say_why():
    inside = plan_path(
        lambda Q: ~blocked(Q), exact_segment_free, [0, 0], [0.8, 0.8], [-1, -1], [1, 1]
    )
    assert not inside.found and inside.reason == "the start state is not free"
    goal = plan_path(
        lambda Q: ~blocked(Q), exact_segment_free, [-0.8, 0], [0.5, 0], [-1, -1], [1, 1]
    )
    assert goal.reason == "no goal state is free"
    # a goal walled in: the search runs out of time
    ring = [
        (np.array([0.6, 0.6]), np.array([0.95, 0.65])),
        (np.array([0.6, 0.95]), np.array([0.95, 1.0])),
        (np.array([0.6, 0.6]), np.array([0.65, 1.0])),
        (np.array([0.9, 0.6]), np.array([0.95, 1.0])),
    ]

    def states_free(Q):
        Q = np.atleast_2d(Q)
        return ~np.any([np.all((Q > lo) & (Q < hi), axis=1) for lo, hi in ring], axis=0)

    walled = plan_path(
        states_free,
        lambda a, b: exact_segment_free(a, b, ring),
        [-0.8, -0.8],
        [0.8, 0.8],
        [-1, -1],
        [1, 1],
        timeout=0.3,
    )
    assert not walled.found and walled.reason == "no path found within the time limit"
    with pytest.raises(ValueError, match="finite"):
        plan_path(
            lambda Q: Q[:, 0] == Q[:, 0], exact_segment_free, [0, 0], [1, 1], [-1, -np.inf], [1, 1]
        )


# ------------------------------------------------------------------ the scenes


def scene(name: str):
    from rworld_cli.api import device_context

    device = "motoman_gp7" if name.startswith("gp7") else "panda"
    return device_context(str(MOTION / name), device)


def independent_check(ctx, way: np.ndarray, tolerance=1e-3, blends=None):
    """A checker the planner did not build: every segment and every corner's blend
    continuous, and 50 states along each piece of the path driven (the ``blended`` path:
    lines and blends) exactly (their nearest pair's signed distance above minus the
    tolerance)."""
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.collision.configurations import ConfigurationChecker
    from rworld_cli.planning.path import JointPath, blend_corners, length_knots

    checker = ConfigurationChecker(
        ctx.world, collision_model(ctx.world.cell), ctx.device.name, tolerance=tolerance
    )
    blends = np.zeros(len(way)) if blends is None else blends
    for a, b in zip(way[:-1], way[1:]):
        assert checker.check_segment(a, b).free
    for k in np.flatnonzero(blends):
        assert checker.check_blend(*blend_corners(length_knots(way), way, blends)[k]).free
    breaks = JointPath(way, None, "blended", blends).pieces[0]
    s = (breaks[:-1, None] + np.linspace(0.0, 1.0, 50)[None] * np.diff(breaks)[:, None]).ravel()
    report = checker.check(JointPath(way, None, "blended", blends).evaluate(s)[0])
    assert report.free.all() and (report.distance > -tolerance).all()


@pytest.mark.parametrize(
    "problem", [p for p in PROBLEMS if p["scene"] in ("panda_fixtures", "gp7_shelf")][::4]
)
def test_planned_paths_pass_an_independent_checker(problem):
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.planning.motion import plan_in_world

    ctx = scene(problem["scene"])
    start, goal = np.array(problem["start"]), np.array(problem["goal"])
    plan, checks = plan_in_world(
        ctx.world,
        collision_model(ctx.world.cell),
        ctx.device.name,
        start,
        goal,
        tolerance=1e-3,
        timeout=30.0,
    )
    assert plan.found, plan.reason
    assert np.array_equal(plan.waypoints[0], start) and np.array_equal(plan.waypoints[-1], goal)
    assert not checks.segment_free(start, goal)  # the straight line was no answer
    lo, hi = ctx.device.limit_array("lower"), ctx.device.limit_array("upper")
    assert (plan.waypoints >= lo).all() and (plan.waypoints <= hi).all()
    path = plan.joint_path()
    q_min, _, q_max, _ = path.extrema()  # the blends too
    assert (q_min >= lo).all() and (q_max <= hi).all()
    assert plan.blends.any()  # corners blended (every one of these problems has some)
    independent_check(ctx, plan.waypoints, blends=plan.blends)


def test_a_slow_continuous_check_does_not_run_past_the_time_limit():
    """A segment's continuous check can take seconds (meshes in contact along it): none is
    begun after the time is up (a GP7 problem's search ran 22 s of a 10 s limit so)."""
    import time

    states_free, segment_free = _behind_a_thin_wall(None)

    def slow(a, b):
        time.sleep(0.05)
        return segment_free(a, b)

    plan = plan_path(states_free, slow, [-0.5, -0.5], [0.5, -0.5], [-1, -1], [1, 1], timeout=0.3)
    assert not plan.found and plan.seconds < 0.3 + 0.2, plan.seconds
    assert "time limit" in plan.reason


def test_checks_kept_for_several_problems_keep_no_tight_pair_of_an_earlier_one():
    """The pairs a problem's ends hold inside the search margin are searched without it for
    that problem only: kept over the next problems they made a GP7 shelf problem fail."""
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.planning.motion import WorldChecks, plan_in_world

    ctx = scene("gp7_shelf")
    model = collision_model(ctx.world.cell)
    checks = WorldChecks(ctx.world, model, ctx.device.name, 1e-3)
    shelf = [p for p in PROBLEMS if p["scene"] == "gp7_shelf"]
    tights = []
    for problem in shelf[2:5]:
        plan, _ = plan_in_world(
            ctx.world,
            model,
            ctx.device.name,
            problem["start"],
            problem["goal"],
            tolerance=1e-3,
            checks=checks,
            seed=0,
        )
        assert plan.found, plan.reason
        alone = WorldChecks(ctx.world, model, ctx.device.name, 1e-3)
        alone.problem(problem["start"], problem["goal"])
        assert checks.tight == alone.tight  # as a fresh one sets them
        tights.append(set(checks.tight))
    assert tights[0] and not tights[2]  # these problems have some, then none


def test_a_segment_that_failed_is_named_with_its_pair_and_depth():
    """What a failed plan says of the segment the continuous check refused: its ends in
    degrees, the first contact (the pair, where along it) and the deepest state measured."""
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.planning.motion import WorldChecks, segment_words

    problem = next(p for p in PROBLEMS if p["scene"] == "gp7_shelf")
    ctx = scene("gp7_shelf")
    checks = WorldChecks(ctx.world, collision_model(ctx.world.cell), ctx.device.name, 1e-3)
    start, goal = np.array(problem["start"]), np.array(problem["goal"])
    words, bodies = segment_words(checks, np.stack([start, goal]))
    first = f"{np.degrees(start[0]):.4g}, {np.degrees(start[1]):.4g}"
    assert words.startswith(f"the segment that failed was from ({first}, "), words
    found = re.search(
        r": (\S+) into (\S+) at (\d+) % of the move; nearest along it: (\S+) "
        r"and (\S+) ([\d.]+) mm deep at (\d+) %$",
        words,
    )
    assert found, words
    assert {found[1], found[2], found[4], found[5]} == set(bodies)
    assert set(bodies) <= {b.label for b in checks.exact.model.bodies}
    # the depth said is the deepest of the states along it, measured again here
    s = np.linspace(0.0, 1.0, 65)[:, None]
    report = checks.exact.check(start + s * (goal - start), nearest=True)
    assert float(found[6]) == pytest.approx(-report.distance.min() * 1000, rel=1e-3)


def test_a_second_robot_is_planned_around_where_it_stands():
    """panda_pair: the other Panda holds its reaching pose; paths of the first keep clear of
    it, and a goal inside it is refused naming the pair."""
    from rworld_cli.api import plan_free_path

    ctx = scene("panda_pair")
    problem = next(p for p in PROBLEMS if p["scene"] == "panda_pair")
    planned = plan_free_path(ctx, ",".join(map(repr, problem["goal"])), problem["start"])
    independent_check(ctx, planned.plan.waypoints, blends=planned.plan.blends)


def test_a_path_keeps_a_millimetre_from_everything_where_none_is_asked():
    """No clearance asked: the path keeps PATH_CLEARANCE (1 mm) from every pair its ends
    leave room for, between states and through its blends (the continuous checks at 1 mm),
    so that a checker that calls any overlap a collision (MoveIt's, MotionBenchMaker's) finds
    none; measured here at 4 001 states along each path by the exact distances of every
    pair.  A pair an end holds inside the search margin (the GP7's link 2 and link 4, 1.39 mm
    apart at a start) keeps half that (with the tolerance rule alone such a pair passed 0.19 mm
    into each other mid-path on an MBM shelf), and the path file says so."""
    from rworld_cli.api import plan_free_path
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.collision.configurations import ConfigurationChecker
    from rworld_cli.planning.motion import PATH_CLEARANCE, plan_in_world

    tight_seen = False
    for name in ("panda_fixtures", "gp7_shelf"):
        ctx = scene(name)
        model = collision_model(ctx.world.cell)
        for problem in [p for p in PROBLEMS if p["scene"] == name][:3]:
            plan, checks = plan_in_world(
                ctx.world,
                model,
                ctx.device.name,
                problem["start"],
                problem["goal"],
                tolerance=1e-3,
                kept=PATH_CLEARANCE,
            )
            assert plan.found and plan.kept == 0.001
            q = plan.joint_path().evaluate(np.linspace(0.0, 1.0, 4001))[0]
            others = ConfigurationChecker(
                ctx.world, model, ctx.device.name, skip=checks.tight or None
            )
            assert others.check(q).distance.min() >= 0.001 - 1e-9
            if checks.tight:
                tight_seen = True
                assert not checks.touching and 0 < checks.tight_kept < 0.001
                held = ConfigurationChecker(ctx.world, model, ctx.device.name, only=checks.tight)
                assert held.check(q).distance.min() >= checks.tight_kept - 1e-9
                ends = held.check(np.stack([q[0], q[-1]])).distance.min()
                assert checks.tight_kept == pytest.approx(ends / 2, abs=1e-9)
                words = plan_free_path(
                    ctx, ",".join(map(repr, problem["goal"])), problem["start"]
                ).kept_words()
                assert words.startswith("clearance 1 mm (none asked) except 1 pair(s) an end")
            else:
                words = plan_free_path(
                    ctx, ",".join(map(repr, problem["goal"])), problem["start"]
                ).kept_words()
                assert words == "clearance 1 mm (none asked)"
    assert tight_seen


def test_a_segment_closer_than_the_kept_clearance_is_refused():
    """A segment ending 0.5 mm from a fixture: free at the tolerance rule (kept 0), refused
    when the path keeps 1 mm - the continuous check, not only the states, holds the path to
    it."""
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.collision.configurations import ConfigurationChecker
    from rworld_cli.planning.motion import WorldChecks

    problem = next(p for p in PROBLEMS if p["scene"] == "panda_fixtures")
    ctx = scene("panda_fixtures")
    model = collision_model(ctx.world.cell)
    exact = ConfigurationChecker(ctx.world, model, ctx.device.name)
    start, goal = np.asarray(problem["start"]), np.asarray(problem["goal"])
    s = np.linspace(0.0, 1.0, 2001)
    distance = exact.check(start + s[:, None] * (goal - start)).distance
    first = int(np.argmax(distance < 0.0005))  # the straight line runs into something
    assert first > 0 and distance[:first].min() >= 0.0005
    lo, hi = s[first - 1], s[first]
    for _ in range(60):  # the state 0.5 mm from it
        mid = 0.5 * (lo + hi)
        near = exact.check((start + mid * (goal - start))[None]).distance[0]
        lo, hi = (mid, hi) if near >= 0.0005 else (lo, mid)
    end = start + lo * (goal - start)
    assert 0.0004 < exact.check(end[None]).distance[0] < 0.0006
    loose = WorldChecks(ctx.world, model, ctx.device.name, 1e-3)
    kept = WorldChecks(ctx.world, model, ctx.device.name, 1e-3, kept=0.001)
    assert loose.segment_free(start, end)
    assert not kept.segment_free(start, end)


def test_the_path_file_is_the_polyline_and_blends_checked_and_times(tmp_path):
    from rworld_cli.api import load_joint_path, plan_free_path, time_optimal_plan
    from rworld_cli.planning.path import blend_corners

    ctx = scene("panda_fixtures")
    # its second problem: three corners, all blended (the first's one corner is not, with the
    # path's 1 mm kept)
    problem = [p for p in PROBLEMS if p["scene"] == "panda_fixtures"][1]
    goal = ",".join(map(repr, problem["goal"]))
    out = tmp_path / "p.yaml"
    planned = plan_free_path(ctx, goal, problem["start"], output=str(out))
    assert "clearance 1 mm (none asked)" in out.read_text()
    again = tmp_path / "q.yaml"
    plan_free_path(ctx, goal, problem["start"], output=str(again))
    assert out.read_bytes() == again.read_bytes()  # same seed, same file
    assert "boundary: blended" in out.read_text()
    path = load_joint_path(str(out), ctx.device)
    way, blends = planned.plan.waypoints, planned.plan.blends
    assert np.array_equal(path.waypoints, way)  # rad, written with repr: bit for bit
    assert np.array_equal(path.blends, blends) and blends.any()
    s = np.linspace(0, 1, 4001)
    q = path.evaluate(s)[0]
    knots = planned.knots
    h = np.diff(knots)
    tau = np.r_[0.0, blends[1:-1] * np.minimum(h[:-1], h[1:]), 0.0]  # each blend's half-width
    corner = np.argmin(np.abs(s[:, None] - knots[None]), axis=1)
    inside = np.abs(s - knots[corner]) < tau[corner]
    # outside the blends: on the straight lines between the waypoints
    piece = np.clip(np.searchsorted(knots, s, side="right") - 1, 0, len(way) - 2)
    a, b = way[piece], way[piece + 1]
    along = np.einsum("ij,ij->i", q - a, b - a) / np.einsum("ij,ij->i", b - a, b - a)
    off_line = np.abs(q - (a + along[:, None] * (b - a))).max(axis=1)
    assert off_line[~inside].max() < 1e-12
    assert (along[~inside] > -1e-12).all() and (along[~inside] < 1 + 1e-12).all()
    # inside: the quadratic Bezier curve of the blend's ends and corner (what was checked)
    ends = blend_corners(knots, way, blends)
    k = corner[inside]
    u = ((s[inside] - (knots[k] - tau[k])) / (2 * tau[k]))[:, None]
    bezier = (1 - u) ** 2 * ends[k, 0] + 2 * u * (1 - u) * ends[k, 1] + u**2 * ends[k, 2]
    assert np.abs(q[inside] - bezier).max() < 1e-12
    timed = time_optimal_plan(ctx, str(out), samples=200)
    assert timed.timing.duration > 0 and timed.peak_ratio["velocity"] <= 1 + 1e-9


def run_program(tmp_path: Path, steps: list[str], name: str, where="panda_fixtures"):
    from rworld_cli.api import simulate_run

    device = "motoman_gp7" if where.startswith("gp7") else "panda"
    program = tmp_path / f"{name}.yaml"
    program.write_text(
        f"device: {device}\nunits: {{length: mm, angle: rad}}\nsteps:\n"
        + "".join(f"  - {s}\n" for s in steps)
    )
    return simulate_run(str(MOTION / where), str(program))


SEEDED = [p for p in PROBLEMS if p["scene"] == "panda_fixtures"][:5] + [
    p for p in PROBLEMS if p["scene"] != "panda_fixtures"
][::10]  # five of the fixtures scene, then one of each other scene


@pytest.mark.parametrize("problem", SEEDED, ids=lambda p: p["scene"])
def test_runs_with_free_paths_pass_the_check_where_straight_moves_collide(tmp_path, problem):
    """Seeded problems of the scenes as programs: the straight joint move collides; with
    ``path: free`` the run passes the collision check with its guarantee between samples
    (0 failures over the set), and its events name the via points."""
    start = "[" + ", ".join(map(repr, problem["start"])) + "]"
    goal = "[" + ", ".join(map(repr, problem["goal"])) + "]"
    scene_name = problem["scene"]
    _, straight = run_program(
        tmp_path,
        [f"move: {{joints: {start}, path: free}}", f"move: {{joints: {goal}}}"],
        "s",
        scene_name,
    )
    assert straight.collisions.collisions
    _, free = run_program(
        tmp_path,
        [f"move: {{joints: {start}, path: free}}", f"move: {{joints: {goal}, path: free}}"],
        "f",
        scene_name,
    )
    assert not free.collisions.collisions and not free.collisions.clearance_violations
    moves = [e.detail for e in free.events if e.kind == "move" and e.step == 1]
    assert len(moves) >= 2 and "via point 1 of" in moves[0]
    assert np.allclose(free.devices[problem["device"]].q[-1], problem["goal"])


def _shelf_with_a_calibration(tmp_path: Path) -> Path:
    """The gp7 shelf scene copied, with a calibrated overlay (provenance: written by
    'rworld calibrate') that moves the right-hand board 1 mm along x."""
    cell = tmp_path / "gp7_shelf"
    shutil.copytree(MOTION / "gp7_shelf", cell)
    text = (
        (cell / "cell.yaml").read_text().replace("../../../../tests/data", str(REPO / "tests/data"))
    )
    (cell / "cell.yaml").write_text(
        text.replace("- poses.yaml\n", "- poses.yaml\n- calibrated.yaml\n")
    )
    (cell / "calibrated.yaml").write_text(
        "units: {length: mm, angle: deg}\n"
        "poses:\n  shelf_right: {xyz: [651, -360, 425]}\n"
        "provenance: {date: '2026-11-29T00:00:00', measurements: [], frames: {}}\n"
    )
    return cell


def test_a_program_sets_the_planners_seed_and_time(tmp_path, cli):
    """'seed:' and 'timeout:' on a 'path: free' move and in the run: another seed another
    path, the same seed the same; a search out of time says how long it had and how to give it
    longer, and what the cell's calibration moved."""
    problem = next(p for p in PROBLEMS if p["scene"] == "gp7_shelf")
    start = "[" + ", ".join(map(repr, problem["start"])) + "]"
    goal = "[" + ", ".join(map(repr, problem["goal"])) + "]"

    def planned(extra: str, run_extra: str = "", first: str = ""):
        program = tmp_path / "p.yaml"
        program.write_text(
            "device: motoman_gp7\nunits: {length: mm, angle: rad}\nsteps:\n"
            f"  - move: {{joints: {start}, path: free{first}}}\n"
            f"  - move: {{joints: {goal}, path: free{extra}}}\n"
        )
        run = tmp_path / "r.yaml"
        run.write_text(f"programs: [p.yaml]\n{run_extra}")
        from rworld_cli.api import simulate_run

        _, result = simulate_run(str(MOTION / "gp7_shelf"), str(run))
        return result.devices["motoman_gp7"].q

    default = planned("")
    assert np.array_equal(planned(", seed: 1"), default)  # the step's index is its default seed
    other = planned(", seed: 7")
    assert not np.array_equal(other, default) and np.allclose(other[-1], default[-1])
    # the run's seed plus the index (the first move kept on its default, 0)
    assert np.array_equal(planned("", "seed: 6\n", ", seed: 0"), other)
    # out of time, in a calibrated cell: the timeout said, and what the calibration moved
    cell = _shelf_with_a_calibration(tmp_path)
    (cell / "p.yaml").write_text(
        "device: motoman_gp7\nunits: {length: mm, angle: rad}\nsteps:\n"
        f"  - move: {{joints: {start}, path: free}}\n"
        f"  - move: {{joints: {goal}, path: free, timeout: 1ms}}\n"
    )
    r = cli(["simulate", str(cell), str(cell / "p.yaml")])
    assert r.exit_code == 1
    assert re.search(
        r"p\.yaml:5: motoman_gp7 step 2 .*no path found within the time limit \(0\.001 s; "
        r"'timeout:' on the step or the run gives it longer\); the calibration "
        r"\(calibrated\.yaml\) moved shelf_right by 1 mm, 0 deg",
        r.stderr,
    ), r.stderr


def test_seed_and_timeout_belong_to_planned_moves(tmp_path, cli):
    program = tmp_path / "p.yaml"
    program.write_text(
        "device: motoman_gp7\nunits: {length: mm, angle: rad}\nsteps:\n"
        "  - move: {joints: [0, 0, 0, 0, 0, 0], path: straight, seed: 3}\n"
        "  - move: {joints: [0, 0, 0, 0, 0, 0], path: free, timeout: -2s}\n"
    )
    r = cli(["validate", str(MOTION / "gp7_shelf"), str(program)])
    assert r.exit_code == 2
    assert re.search(r"p\.yaml:4:\d+: .*'seed' steer the planner of a 'path: free' move", r.stderr)
    assert re.search(r"p\.yaml:5:\d+: .*timeout '-2s' is not a positive duration", r.stderr)


def test_the_calibrated_frames_carrying_a_failed_segments_bodies_come_first(tmp_path):
    from rworld_cli.schema.programs import load_run
    from rworld_cli.simulate.engine import _Scheduler

    cell = _shelf_with_a_calibration(tmp_path)
    (cell / "p.yaml").write_text("device: motoman_gp7\nsteps:\n  - move: {to: home}\n")
    run = load_run(str(cell), str(cell / "p.yaml"))
    assert set(run.cell.calibrated) == {"shelf_right"}
    _, shift, turn = run.cell.calibrated["shelf_right"]
    assert shift == pytest.approx(1e-3, abs=1e-12) and turn == 0.0
    words = _Scheduler(run)._calibrated_near(["motoman_gp7.link_4_r", "shelf_right"])
    assert words == (
        "; the calibration (calibrated.yaml) moved shelf_right by 1 mm, 0 deg (it carries "
        "shelf_right, met here)"
    )


def touching_state(ctx) -> np.ndarray:
    """A Panda state whose hand touches something within the 1 mm tolerance (the divider's
    top: the open fingers straddle it): the shoulder lowered from home until the nearest pair
    overlaps by less than 0.9 mm (bisection)."""
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.collision.configurations import ConfigurationChecker

    checker = ConfigurationChecker(ctx.world, collision_model(ctx.world.cell), "panda")
    home = np.asarray(ctx.device.home, dtype=float)
    way = np.zeros(7)
    way[1], way[3] = 1.0, 0.6  # shoulder forward, elbow opened: the hand goes down ahead

    def signed(t):
        return float(checker.check((home + t * way)[None]).distance[0])

    lo, hi = 0.0, 1.5
    assert signed(lo) > 0 > signed(hi)
    for _ in range(60):
        mid = (lo + hi) / 2
        d = signed(mid)
        if -9e-4 < d < 0:
            return home + mid * way
        lo, hi = (mid, hi) if d > 0 else (lo, mid)
    raise AssertionError("no touching state found")


def test_a_goal_in_contact_is_refused_with_the_reason(cli):
    """A goal free only by touching (an overlap within the tolerance): every way into it
    grazes what it touches, so it is refused before any search, naming the pair."""
    from rworld_cli.errors import CheckFailed

    ctx = scene("panda_fixtures")
    goal = touching_state(ctx)
    from rworld_cli.api import plan_free_path

    with pytest.raises(CheckFailed, match="touches something .*mm deep.*approach from there"):
        plan_free_path(ctx, ",".join(map(repr, goal.tolist())), "home")
    r = cli(
        ["plan", "path", str(MOTION / "panda_fixtures"), "--to", ",".join(map(repr, goal.tolist()))]
    )
    assert r.exit_code == 1 and "touches something" in r.stderr


def test_path_free_is_refused_on_linear_and_guarded_moves(tmp_path):
    from rworld_cli.errors import UserError

    with pytest.raises(UserError) as raised:
        run_program(tmp_path, ["move: {to: home, motion: linear, path: free}"], "l")
    assert "'path: free' plans a joint move" in str(raised.value.issues[0])


def test_plan_path_command(cli, tmp_path):
    problem = next(p for p in PROBLEMS if p["scene"] == "panda_fixtures")
    cell = str(MOTION / "panda_fixtures")
    start = ",".join(map(repr, problem["start"]))
    goal = ",".join(map(repr, problem["goal"]))
    out = tmp_path / "p.yaml"
    r = cli(["plan", "path", cell, "--from", start, "--to", goal, "-o", str(out), "--no-progress"])
    assert r.exit_code == 0, r.output
    assert "a free path" in r.stdout and out.is_file()
    r = cli(["--json", "plan", "path", cell, "--from", start, "--to", goal])
    doc = json.loads(r.stdout)
    assert r.exit_code == 0 and doc["found"] and len(doc["waypoints"]) >= 3
    assert doc["waypoints"][0] == problem["start"] and doc["written"] is None
    r = cli(["plan", "path", cell, "--to", "nowhere"])
    assert r.exit_code == 2 and "neither a named position" in r.stderr
    r = cli(["plan", "path", cell, "--to", "home", "--clearance", "-3mm"])
    assert r.exit_code == 2
    r = cli(["plan", "path", "--help"])
    assert "Examples:" in r.stdout
    # a frame target moved back along its own axes: the Panda example's block, approached
    # from 120 mm above (its grasp frame itself: the fingers touch the block)
    panda = str(REPO / "workcells" / "panda")
    r = cli(["--json", "plan", "path", panda, "--to", "block.grasp", "--offset", "0,0,-0.12"])
    doc = json.loads(r.stdout)
    assert r.exit_code == 0 and doc["offset"] == [0.0, 0.0, -0.12]
    from rworld_cli.api import device_context, forward_kinematics

    ctx = device_context(panda, "panda")
    T = forward_kinematics(ctx, np.array(doc["waypoints"][-1]))
    T_grasp = ctx.world.T_world("block.grasp")
    assert np.allclose(T[:3, 3], T_grasp[:3, 3] - 0.12 * T_grasp[:3, 2], atol=1e-6)
    r = cli(["plan", "path", panda, "--to", "block.grasp", "--no-progress"])
    assert r.exit_code == 1 and "touches something (block and panda.panda_link7" in r.stderr
    r = cli(["plan", "path", panda, "--to", "home", "--offset", "0,0,1"])
    assert r.exit_code == 2 and "--offset moves a frame" in r.stderr


def test_a_failed_plan_says_in_json_why_and_what_it_cost(cli):
    """``--json`` on failure: the fields of a found plan with ``found: false`` and an
    ``outcome`` a script can test (a timeout apart from a goal that touches something), the
    time, the counts and the error (exit 1)."""
    problem = next(p for p in PROBLEMS if p["scene"] == "panda_fixtures")
    cell = str(MOTION / "panda_fixtures")
    start = ",".join(map(repr, problem["start"]))
    goal = ",".join(map(repr, problem["goal"]))
    r = cli(["--json", "plan", "path", cell, "--from", start, "--to", goal, "--timeout", "0.001"])
    doc = json.loads(r.stdout)
    assert r.exit_code == 1 and doc["found"] is False and doc["outcome"] == "timeout"
    assert doc["error"].startswith("no path to") and "time limit" in doc["reason"]
    assert doc["seconds"] >= 0.001 and doc["states_checked"] > 0 and doc["waypoints"] == []
    panda = str(REPO / "workcells" / "panda")
    r = cli(["--json", "plan", "path", panda, "--to", "block.grasp"])
    doc = json.loads(r.stdout)
    assert r.exit_code == 1 and doc["outcome"] == "goal_touching" and not doc["found"]
    assert "block and panda.panda_link7" in doc["reason"]


# ------------------------------------------------------------------ free turns chosen clear


@pytest.fixture(scope="module")
def gp7_edges(tmp_path_factory):
    """The GP7 vendor cell (its meshes, the table, the holed plate) with three edges of the
    plate as line features, and programs that follow them or move to them from a joint
    state above the plate."""
    import shutil

    folder = tmp_path_factory.mktemp("gp7") / "gp7"
    shutil.copytree(REPO / "tests" / "data" / "vendor_cells" / "gp7", folder)
    cell = (folder / "cell.yaml").read_text()
    cell = cell.replace(
        "    geometry: {mesh: {file: meshes/plate.stl, units: mm}}\n",
        "    geometry: {mesh: {file: meshes/plate.stl, units: mm}}\n"
        "    features:\n"
        "      - {name: far_edge, line: {point: [0.16, 0, 0.015], direction: [0, 1, 0]}}\n"
        "      - {name: side_edge, line: {point: [0, 0, 0.015], direction: [1, 0, 0]}}\n",
    )
    (folder / "cell.yaml").write_text(cell)
    start = "  - move: {joints: [0, 20, -20, 0, -70, 0]}\n"
    head = "device: motoman_gp7\nunits: {angle: deg, length: mm}\nsteps:\n" + start
    follow = "  - follow: {edge: plate.%s, speed: 20mm/s, from: 10, to: 100, approach: 30}\n"
    for edge in ("far_edge", "side_edge"):
        (folder / "programs" / f"follow_{edge}.yaml").write_text(head + follow % edge + start)
    (folder / "programs" / "move_far.yaml").write_text(
        head + "  - move: {to: {feature: plate.far_edge, standoff: 30}}\n"
    )
    return folder


def test_a_follow_takes_a_turn_whose_moves_collide_with_nothing(gp7_edges, monkeypatch):
    """The soonest-reached turn about the far edge drives the wrist into the table (the
    choice before this rule, had here by switching the route check off); the turn taken now
    passes the check."""
    from rworld_cli.api import simulate_run
    from rworld_cli.simulate.feature_steps import FeatureSteps

    program = str(gp7_edges / "programs" / "follow_far_edge.yaml")
    _, result = simulate_run(str(gp7_edges), program)
    assert not result.collisions.collisions
    monkeypatch.setattr(FeatureSteps, "_route_collision", lambda *args: None)
    _, blind = simulate_run(str(gp7_edges), program)
    assert {c.contact.a for c in blind.collisions.collisions} == {"table"}


def test_a_follow_no_turn_of_which_is_clear_names_each_turn_and_its_collision(gp7_edges):
    """The side edge: every reachable turn runs link 2 into link 4 or the wrist into the plate
    on the way (the issue's GP7 case): the first reachable is driven, so that the check
    reports the collision and the run can be watched, with a warning naming each of the 24
    turns and what stopped it."""
    from rworld_cli.api import simulate_run

    folder = gp7_edges
    _, result = simulate_run(str(folder), str(folder / "programs" / "follow_side_edge.yaml"))
    assert result.collisions.collisions
    warnings = [e.detail for e in result.events if e.kind == "warning"]
    assert len(warnings) == 1
    assert "no turn about plate.side_edge works without a collision" in warnings[0]
    assert "tried 24" in warnings[0] and warnings[0].count("spin ") == 25  # and the one taken
    assert "link_2_l into motoman_gp7.link_4_r at" in warnings[0] and "unreachable" in warnings[0]


@pytest.fixture
def puma_post(tmp_path) -> Path:
    """The Puma cell with a post in the way of its move from ready to above the workpiece."""
    import shutil

    cell = tmp_path / "puma"
    shutil.copytree(REPO / "workcells" / "puma560", cell)
    text = (cell / "cell.yaml").read_text()
    (cell / "cell.yaml").write_text(
        text.replace(
            "\nsensors:\n",
            "  - name: post\n    mass: 5.0\n    geometry: {box: [0.12, 0.12, 0.12]}\n\nsensors:\n",
            1,
        )
    )
    with (cell / "poses.yaml").open("a") as f:
        f.write("  post: {xyz: [0.72, 0.05, 0.79]}\n")
    (cell / "programs" / "blocked.yaml").write_text(
        "device: puma\nunits: {length: mm, angle: deg}\nsteps:\n  - move: {to: ready}\n"
        "  - move: {to: workpiece.grasp, tcp: probe, offset: {xyz: [0, 0, -100]}}\n"
        "  - move: {to: home}\n"
    )
    return cell


def test_a_blocked_frame_target_tries_its_other_joint_solutions(puma_post):
    """The straight joint move of the solution IK reaches from the joints now runs into the
    post: the target's other joint solutions are tried (here the second differs by a turn of
    the wrist, and is blocked too); the first is driven and reported, with a warning naming
    each solution and its first contact."""
    from rworld_cli.api import simulate_run

    _, result = simulate_run(str(puma_post), str(puma_post / "programs" / "blocked.yaml"))
    assert {c.contact.a for c in result.collisions.collisions} == {"post"}
    (warning,) = [e.detail for e in result.events if e.kind == "warning"]
    assert "no joint solution for 'workpiece.grasp' is reached without a collision" in warning
    assert "tried 2: shoulder front, elbow up, wrist noflip: post into puma.link4 at" in warning


def test_a_run_makes_free_paths_its_default(puma_post):
    """``paths: free`` in the run file: every joint move that gives no ``path:`` is planned
    (the blocked program passes); a move that says ``path: straight`` keeps its line."""
    from rworld_cli.api import simulate_run

    runs = puma_post / "runs"
    (runs / "free.yaml").write_text("programs: [../programs/blocked.yaml]\ndt: 0.01\npaths: free\n")
    _, result = simulate_run(str(puma_post), "free")
    assert not result.collisions.collisions
    legs = [e.detail for e in result.events if e.kind == "move" and e.step == 1]
    assert len(legs) >= 2 and "via point 1 of" in legs[0]
    program = (puma_post / "programs" / "blocked.yaml").read_text()
    (puma_post / "programs" / "blocked.yaml").write_text(
        program.replace(
            "offset: {xyz: [0, 0, -100]}}", "offset: {xyz: [0, 0, -100]}, path: straight}"
        )
    )
    _, straight = simulate_run(str(puma_post), "free")
    assert {c.contact.a for c in straight.collisions.collisions} == {"post"}


def test_a_move_to_a_feature_takes_a_clear_turn(gp7_edges, monkeypatch):
    """A joint move to a feature target: the soonest turn's move runs the wrist into the
    table (had by switching the rule off); the turn taken is reached without a collision."""
    from rworld_cli.api import simulate_run
    from rworld_cli.simulate.engine import _Scheduler

    program = str(gp7_edges / "programs" / "move_far.yaml")
    _, result = simulate_run(str(gp7_edges), program)
    assert not result.collisions.collisions
    monkeypatch.setattr(_Scheduler, "_joint_line_collision", lambda *args: None)
    _, blind = simulate_run(str(gp7_edges), program)
    assert {c.contact.a for c in blind.collisions.collisions} == {"table"}


def test_feature_steps_take_path_free_for_their_approach(gp7_edges):
    """``follow: {..., path: free}``: the approach planned (the far edge: the run passes);
    where no turn's approach state is free (the side edge: link 2 into link 4), each turn is
    named with the planner's reason."""
    from rworld_cli.api import simulate_run
    from rworld_cli.simulate.errors import UnreachableTarget

    programs = gp7_edges / "programs"
    for edge in ("far_edge", "side_edge"):
        text = (programs / f"follow_{edge}.yaml").read_text()
        (programs / f"free_{edge}.yaml").write_text(
            text.replace("approach: 30}", "approach: 30, path: free}")
        )
    _, result = simulate_run(str(gp7_edges), str(programs / "free_far_edge.yaml"))
    assert not result.collisions.collisions
    with pytest.raises(UnreachableTarget) as raised:
        simulate_run(str(gp7_edges), str(programs / "free_side_edge.yaml"))
    message = str(raised.value)
    assert "spin 0 deg: no free path (no goal state is free (motoman_gp7.link_2_l and" in message


def test_a_probe_steps_move_to_its_first_point_takes_path_free(tmp_path, monkeypatch):
    """``probe: {feature, path: free}``: its transits - to the first point's lift, and from
    point to point (joint moves since issue 60) - are planned (the real planner, its calls
    counted), the run passes the collision check and records its contacts; without ``path:``
    the planner is asked only for a transit whose straight move collides (none here), and
    never with ``path: straight``."""
    import shutil

    import rworld_cli.planning.motion as motion
    from rworld_cli.api import simulate_run

    cell = tmp_path / "probing"
    shutil.copytree(REPO / "workcells" / "probing", cell)
    asked = []
    real = motion.plan_in_world

    def counted(*args, **kwargs):
        asked.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(motion, "plan_in_world", counted)
    program = cell / "programs" / "free.yaml"
    program.write_text(
        "device: puma\nsteps:\n  - move: {to: ready}\n"
        "  - probe: {feature: plate.top, points: 3, path: free}\n"
    )
    _, result = simulate_run(str(cell), str(program))
    assert len(asked) == 3  # to the first point, then to each of the two others
    assert not result.collisions.collisions
    assert sum(e.kind == "probe" for e in result.events) == 3
    program.write_text(
        "device: puma\nsteps:\n  - move: {to: ready}\n  - probe: {feature: plate.top, points: 3}\n"
    )
    simulate_run(str(cell), str(program))
    assert len(asked) == 3
    program.write_text(
        "device: puma\nsteps:\n  - move: {to: ready}\n"
        "  - probe: {feature: plate.top, points: 3, path: straight}\n"
    )
    simulate_run(str(cell), str(program))
    assert len(asked) == 3


def test_a_program_drives_a_planned_path_file(tmp_path):
    """``rworld plan path -o`` then ``move: {path: FILE}``: the run goes through the file's
    waypoints and passes the check; a path that does not start where the device is, a spline
    path file and a path with a goal of its own are refused, located."""
    from rworld_cli.api import plan_free_path, simulate_run, time_optimal_plan
    from rworld_cli.errors import UserError
    from rworld_cli.simulate.errors import SimulationError

    ctx = scene("panda_fixtures")
    problem = next(p for p in PROBLEMS if p["scene"] == "panda_fixtures")
    planned = plan_free_path(
        ctx, ",".join(map(repr, problem["goal"])), "home", output=str(tmp_path / "p.yaml")
    )
    cell = str(MOTION / "panda_fixtures")

    def program(name: str, steps: str) -> str:
        (tmp_path / name).write_text(f"device: panda\nsteps:\n{steps}")
        return str(tmp_path / name)

    _, result = simulate_run(
        cell, program("ok.yaml", "  - move: {to: home}\n  - move: {path: p.yaml}\n")
    )
    assert not result.collisions.collisions
    assert np.allclose(result.devices["panda"].q[-1], problem["goal"])
    legs = [e for e in result.events if e.kind == "move" and e.step == 1]
    assert len(legs) == len(planned.plan.waypoints) - 1
    # the path timed as one: the time-optimal timing of the file's path (the same limits),
    # through its blended via points without stopping, at rest at the others
    timed = time_optimal_plan(ctx, str(tmp_path / "p.yaml"), samples=50)
    run, t = result.devices["panda"], result.times
    first_leg = result.events.index(legs[0])
    t0 = result.events[first_leg].t  # the path starts when its first leg does
    end = t0 + timed.timing.duration
    assert np.abs(run.qd[t >= end + 1e-9]).max(initial=0.0) < 1e-12  # at rest after
    if planned.plan.blends[1:-1].all():  # every corner blended: never still on the way
        assert np.abs(run.qd[(t > t0) & (t < end - 0.05)]).max(axis=1).min() > 0
    assert np.nanmax(run.ratios["velocity"]) <= 1 + 1e-9
    assert np.nanmax(run.ratios["acceleration"]) <= 1 + 1e-6
    for k, blend in enumerate(planned.plan.blends[1:-1]):  # at each via point's knot
        at = np.argmin(np.abs(t - legs[k + 1].t))
        speed = np.abs(run.qd[at]).max()
        assert (speed > 1e-3) if blend > 0 else (speed < 1e-2), (k, blend, speed)
    with pytest.raises(SimulationError, match="the path starts with panda_joint2 at -0.785398"):
        simulate_run(cell, program("off.yaml", "  - move: {to: ready}\n  - move: {path: p.yaml}\n"))
    (tmp_path / "spline.yaml").write_text((REPO / "workcells/panda/paths/sweep.yaml").read_text())
    with pytest.raises(UserError) as raised:
        simulate_run(cell, program("s.yaml", "  - move: {path: spline.yaml}\n"))
    assert "is a spline ('boundary: clamped')" in str(raised.value.issues[0])
    with pytest.raises(UserError) as raised:
        simulate_run(cell, program("b.yaml", "  - move: {path: p.yaml, to: home}\n"))
    assert "has its goal there" in str(raised.value.issues[0])


def test_blended_via_points_are_exported_as_the_controllers_blends(tmp_path):
    """A planned path driven by a GP7 program and exported: each blended via point is the
    controller's blended joint move (URScript ``r=`` the TCP distance, KRL ``C_PTP`` with
    ``$APO.CPTP``, RAPID's largest predefined zone within it, FANUC ``CNT``), the corners
    at rest and the last leg end exactly (``fine``, ``FINE``, no ``r``)."""
    from rworld_cli.api import export_program, plan_free_path

    ctx = scene("gp7_shelf")
    problem = [p for p in PROBLEMS if p["scene"] == "gp7_shelf"][5]  # 2 corners blended, 1 not
    planned = plan_free_path(
        ctx, ",".join(map(repr, problem["goal"])), problem["start"], output=str(tmp_path / "p.yaml")
    )
    blends = planned.plan.blends[1:-1]
    assert (blends > 0).sum() >= 2
    start = "[" + ", ".join(map(repr, problem["start"])) + "]"
    program = tmp_path / "gp7.yaml"
    program.write_text(
        "device: motoman_gp7\nunits: {length: mm, angle: rad}\nsteps:\n"
        f"  - move: {{joints: {start}, path: free}}\n  - move: {{path: p.yaml}}\n"
    )
    cell = str(MOTION / "gp7_shelf")
    texts = {}
    for fmt in ("urscript", "krl", "rapid", "fanuc", "val3", "drl"):
        out = tmp_path / fmt
        export_program(cell, str(program), fmt, str(out))
        texts[fmt] = "\n".join(f.read_text() for f in sorted(out.rglob("*")) if f.is_file())
    blended = int((blends > 0).sum())
    assert len(re.findall(r"movej\(\[[^]]*\], a=[^,]*, v=[^,)]*, r=", texts["urscript"])) == blended
    assert texts["krl"].count(" C_PTP") == blended
    assert len(re.findall(r"\$APO\.CPTP = \d+", texts["krl"])) == blended
    zones = re.findall(r"MoveAbsJ j\d+, s\d+, (\w+),", texts["rapid"])
    assert zones[-1] == "fine" and sum(z != "fine" for z in zones) <= blended
    assert len(re.findall(r"J P\[\d+\] \d+% CNT\d+", texts["fanuc"])) == blended
    assert texts["val3"].count('blend="joint"') == blended
    assert len(re.findall(r"^movej\(posj\(.*radius=", texts["drl"], re.M)) == blended
    # URScript's radius is the TCP's distance from the via point where rworld's blend starts
    radii = [float(r) for r in re.findall(r", r=([0-9.e-]+)\)", texts["urscript"])]
    assert all(0 < r < 2.0 for r in radii)


def test_a_7_axis_arms_blended_via_points_are_sunrise_blends(tmp_path):
    """A planned Panda path exported as KUKA Sunrise (a 7-axis arm's language): each blended
    via point an asynchronous ``ptp`` with ``setBlendingCart`` (Sunrise blends asynchronous
    motions only), the last leg a synchronous move."""
    from rworld_cli.api import export_program, plan_free_path

    ctx = scene("panda_fixtures")
    problem = next(p for p in PROBLEMS if p["scene"] == "panda_fixtures")
    planned = plan_free_path(
        ctx, ",".join(map(repr, problem["goal"])), "home", output=str(tmp_path / "p.yaml")
    )
    blended = int((planned.plan.blends[1:-1] > 0).sum())
    assert blended >= 1
    program = tmp_path / "arm.yaml"
    program.write_text("device: panda\nsteps:\n  - move: {to: home}\n  - move: {path: p.yaml}\n")
    export_program(str(MOTION / "panda_fixtures"), str(program), "sunrise", str(tmp_path / "out"))
    text = (tmp_path / "out" / "Arm.java").read_text()
    assert len(re.findall(r"\.moveAsync\(ptp\(.*\.setBlendingCart\([0-9.]+\)\);", text)) == blended
    assert re.findall(r"^\s+\w+\.(move|moveAsync)\(", text, re.M)[-1] == "move"  # the end: waits


def test_a_reader_that_leaves_early_is_no_bug():
    """``rworld plan path ... | head -c 10``: exit 141 (the shell's broken pipe), no 'internal
    error', nothing written."""
    import subprocess
    import sys

    problem = next(p for p in PROBLEMS if p["scene"] == "panda_fixtures")
    goal = ",".join(map(repr, problem["goal"]))
    code = (
        "import sys; from rworld_cli.cli import main; sys.argv = ['rworld'] + sys.argv[1:]; main()"
    )
    args = [sys.executable, "-c", code, "plan", "path", str(MOTION / "panda_fixtures"), "--from"]
    args += ["home", "--to", goal, "--no-progress"]
    read, write = os.pipe()
    os.close(read)  # the reader is gone before the first line
    done = subprocess.run(args, stdout=write, stderr=subprocess.PIPE, text=True, cwd=REPO)
    os.close(write)
    assert done.returncode == 141, done.stderr
    assert "internal error" not in done.stderr


def test_a_path_file_whose_first_via_point_is_where_the_device_is_runs(tmp_path):
    """A 'segments' path file whose second waypoint repeats its first (the device's home):
    the repeat is dropped and the run ends at the file's last waypoint (a joint move), not an
    internal error."""
    from rworld_cli.api import simulate_run

    home = "[0, -0.785398163397, 0, -2.356194490192, 0, 1.570796326795, 0.785398163397]"
    (tmp_path / "path.yaml").write_text(
        "device: panda\nunits: {angle: rad}\nwaypoints:\n"
        f"  - {home}\n  - {home}\n  - [0.3, -0.6, 0, -2.2, 0, 1.6, 0.8]\nboundary: segments\n"
    )
    program = tmp_path / "p.yaml"
    program.write_text("device: panda\nsteps:\n  - move: {to: home}\n  - move: {path: path.yaml}\n")
    _, result = simulate_run(str(MOTION / "panda_fixtures"), str(program))
    assert np.allclose(result.devices["panda"].q[-1], [0.3, -0.6, 0, -2.2, 0, 1.6, 0.8])
    legs = [e for e in result.events if e.kind == "move" and e.step == 1]
    assert len(legs) == 1  # one joint move once the repeat is gone


def test_goals_are_taken_at_the_turns_nearest_the_start(tmp_path):
    """A frame's goal states (its IK solutions from random starts) each at the turns nearest
    the start: on the UR5 (every joint +-360 deg) a wrist at -200 deg is the same pose at +160,
    and the start at +170 makes +160 the goal (issue 61: 'took A6 at -200 deg')."""
    from rworld_cli.api import device_context
    from rworld_cli.api.motion import goal_states
    from rworld_cli.kinematics.jacobian import tool_pose

    cell = tmp_path / "ur5"
    shutil.copytree(REPO / "workcells" / "ur5", cell)
    ctx = device_context(str(cell), "ur5")
    q_goal = np.radians([30.0, -80.0, 70.0, -60.0, -90.0, 160.0])
    T = ctx.T_world_base @ tool_pose(ctx.device, q_goal, ctx.mount)
    data = yaml.safe_load((cell / "cell.yaml").read_text())
    data["frames"] = [*data.get("frames", []), {"name": "target"}]
    (cell / "cell.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    poses = yaml.safe_load((cell / "poses.yaml").read_text())
    from rworld_cli import spatial

    units = poses.get("units", {})  # the pose file's own
    scale = 1000.0 if units.get("length") == "mm" else 1.0
    rpy = spatial.matrix_to_rpy(T[:3, :3])
    poses["poses"]["target"] = {
        "xyz": [float(v) * scale for v in T[:3, 3]],
        "rpy": [float(v) for v in (np.degrees(rpy) if units.get("angle") == "deg" else rpy)],
    }
    (cell / "poses.yaml").write_text(yaml.safe_dump(poses, sort_keys=False))
    ctx = device_context(str(cell), "ur5")
    start = np.radians([20.0, -70.0, 60.0, -50.0, -80.0, 170.0])
    goals = goal_states(ctx, "target", start, seed=0)
    assert len(goals) >= 2
    assert (np.abs(goals - start) <= np.pi + 1e-9).all()  # no joint a turn further than needed
    for g in goals:  # each the frame's pose; no two the same state
        assert np.allclose(ctx.T_world_base @ tool_pose(ctx.device, g, ctx.mount), T, atol=1e-6)
    apart = np.abs(goals[:, None] - goals[None]).max(axis=2) + np.eye(len(goals))
    assert apart.min() > 1e-6
    travel = np.linalg.norm(goals - start, axis=1)
    assert (np.diff(travel) >= 0).all()


def test_a_static_overlap_is_said_once_and_is_not_a_collision_of_the_run(tmp_path, cli):
    """Two boards of a shelf set 20 mm into each other, a can 10 mm into a board (as MBM and
    most MoveIt scenes build them), nothing moving them: ``check`` says it once, as the cell's
    geometry, and passes the program the planner planned (which never counted those pairs);
    listed in ``--json``; gone once ``allowed_contacts`` accepts them."""
    cell = tmp_path / "panda_fixtures"
    shutil.copytree(MOTION / "panda_fixtures", cell)
    text = (cell / "cell.yaml").read_text().replace("../../../../", str(REPO) + "/")
    data = yaml.safe_load(text)
    data["objects"] += [
        {"name": "board", "mass": 1.0, "geometry": {"box": [0.3, 0.3, 0.02]}},
        {"name": "side", "mass": 1.0, "geometry": {"box": [0.02, 0.3, 0.3]}},
        {"name": "can", "mass": 0.2, "geometry": {"cylinder": {"radius": 0.03, "length": 0.12}}},
    ]
    (cell / "cell.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    poses = yaml.safe_load((cell / "poses.yaml").read_text())
    poses["poses"]["board"] = {"xyz": [-1.5, 0.0, 0.5]}
    poses["poses"]["side"] = {"xyz": [-1.36, 0.0, 0.5]}  # 20 mm into the board's end
    poses["poses"]["can"] = {"xyz": [-1.5, 0.0, 0.56]}  # 10 mm into the board
    (cell / "poses.yaml").write_text(yaml.safe_dump(poses, sort_keys=False))
    problem = next(p for p in PROBLEMS if p["scene"] == "panda_fixtures")
    (cell / "p.yaml").write_text(
        "device: panda\nunits: {length: m, angle: rad}\nsteps:\n"
        f"  - move: {{joints: {problem['start']}, path: free}}\n"
        f"  - move: {{joints: {problem['goal']}, path: free}}\n"
    )
    r = cli(["check", str(cell), str(cell / "p.yaml")])
    assert r.exit_code == 0, r.output
    notes = [line for line in r.stderr.splitlines() if "static overlaps" in line]
    assert len(notes) == 1 and "(2;" in notes[0]
    assert "board and can 10.0 mm deep" in notes[0] and "board and side 20.0 mm deep" in notes[0]
    r = cli(["--json", "check", str(cell), str(cell / "p.yaml")])
    doc = json.loads(r.stdout)
    overlaps = doc["collisions"]["static_overlaps"]
    assert sorted((o["a"], o["b"]) for o in overlaps) == [("board", "can"), ("board", "side")]
    assert not doc["collisions"]["collisions"]
    data["allowed_contacts"] = [
        *data.get("allowed_contacts", []),
        {"between": ["board", "can"], "reason": "set into it"},
        {"between": ["board", "side"], "reason": "one piece"},
    ]
    (cell / "cell.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    r = cli(["check", str(cell), str(cell / "p.yaml")])
    assert r.exit_code == 0 and "static overlaps" not in r.stderr
