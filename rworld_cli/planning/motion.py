"""Collision-free joint paths: bidirectional sampling (RRT-Connect), lazy continuous checks,
shortcutting.

The planner takes plain data and two questions it may ask as often as it likes:

* ``states_free(Q)``: Q (N, n) joint states -> (N,) bool, free at that instant (for rworld,
  ``ConfigurationChecker.free(Q)``: no overlap deeper than the collision
  tolerance, nothing buried, the clearance kept);
* ``segment_free(q0, q1)``: the straight joint-space segment free everywhere, between its
  states too (``ConfigurationChecker.check_segment``: the continuous guarantee of
  ``rworld check``);
* ``blend_free(p0, corner, p2)`` (optional): the same of the quadratic Bezier curve a corner
  is blended by (``ConfigurationChecker.check_blend``).

Why this shape: a state costs tens of microseconds in a batch and a continuous segment check
milliseconds, so the search asks states - each edge as the states along it at
``resolution`` apart, in batches that double (coarse to fine where only yes or no is asked,
so that a blocked line is found blocked early) - and the continuous check is asked only of
the path's final segments (lazy).  A final segment the states passed but the continuous check
does not (an obstacle thinner than the spacing) is planned again between its ends at a
quarter of the spacing.

The search (Kuffner and LaValle, *RRT-Connect*, ICRA 2000): two trees, one from the start
and one from every goal (several IK solutions may be given: the first reached is taken),
grown in turn towards uniform samples of the joint box; the tree that grew is then
connected towards the other's new state as far as it is free.  Shortcutting: the path's
waypoints joined to the farthest one a straight segment reaches (greedy), then straight
segments between random points of the path kept when free and shorter, then the greedy pass
again.  Straight segments
between states inside the joint box stay inside it, so every path keeps the joint limits.

Smoothing: each corner of the final path is cut by a parabolic blend (``planning.path``'s
``blended`` path: the device keeps moving through it instead of stopping) as wide as the
continuous check allows - half the shorter of its two segments, else a quarter, an eighth,
a sixteenth; a corner where none passes is passed at rest.  A blend lies in the triangle of
its corner and its two ends, so inside the joint box too.

Deterministic for a seed: the same problem and seed give the same path, unless ``timeout``
cuts the search (then it fails).  Probabilistically complete: if a free path with some
clearance exists, the probability of not finding it falls to zero as the search goes on; a
failure within ``timeout`` proves nothing.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .path import JointPath, blend_corners, length_knots

FIRST_BATCH = 8  # states of a line's first batch (then 16, 32, ...)
SHORTCUT_PATIENCE = 30  # random shortcuts stop after this many in a row that found nothing
BLEND_TRIALS = (0.5, 0.25, 0.125, 0.0625)  # a corner's blend widths tried, widest first
StatesFree = Callable[[np.ndarray], np.ndarray]
SegmentFree = Callable[[np.ndarray, np.ndarray], bool]
BlendFree = Callable[[np.ndarray, np.ndarray, np.ndarray], bool]


@dataclass
class PathPlan:
    """A planned joint path (:func:`plan_path`).

    Attributes
    ----------
    found : bool
    waypoints : ndarray, shape (W, n)
        Start first, the goal reached last [rad or m]; straight joint-space segments between
        them, each checked continuously.  Empty (0, n) when not found.
    goal : int
        Index of the goal reached (-1: none).
    reason : str or None
        Why none was found (the start or every goal not free, the timeout, the iteration
        bound).
    iterations : int
        Growth rounds of the trees.
    tree_states : int
        States in both trees.
    states_checked : int
        States asked of ``states_free``.
    segments_checked : int
        Segments asked of ``segment_free``.
    seconds : float
        Wall time of the search, shortcuts and checks.
    raw_length, length : float
        Joint-space length (Euclidean, rad or m) of the path found and after shortcutting.
    repairs : int
        Final segments planned again (the states passed, the continuous check did not).
    knots : ndarray, shape (W,)
        The waypoints' path parameters, by joint-space length from 0 to 1
        (``planning.path.length_knots``).
    blends : ndarray, shape (W,)
        Each waypoint's blend (``planning.path.JointPath``'s ``blended`` path with these
        knots): its half-width as a fraction of the shorter knot interval beside it, 0 at the
        ends and at corners passed at rest.  All 0 without ``blend_free``.
    blend_seconds : float
        Of ``seconds``, the time spent blending the corners.
    attempts : int
        Tree searches run: a path whose states passed but a segment of which failed the
        continuous check (and its repair) is dropped and the search starts again, while time
        is left.
    blocked : ndarray, shape (2, n), or None
        The ends of the last segment that failed the continuous check (None: none failed).
    bodies : list of str
        The labels of the bodies that segment met (``plan_in_world`` names them).
    inside_margin : list of str
        Pairs already inside the search margin at the start or a goal, in words (``plan_in_world``:
        searched without the margin, keeping ``tight_kept``; the margin kept for the others).
    kept : float
        The clearance the path keeps from everything but those pairs [m] (``plan_in_world``).
    tight_kept : float
        The clearance those pairs keep [m]: ``kept``, or less where an end holds one closer
        (half the nearest's distance there, at least the clearance asked); a pair touching at
        the start keeps the tolerance rule only.
    outcome : str
        "found", or why not in a word a script can test: "start_not_free", "goal_not_free",
        "goal_touching" (every free goal touches something), "goal_outside_limits",
        "timeout", "iterations" (the bound on growth rounds).
    """

    found: bool
    waypoints: np.ndarray
    goal: int = -1
    reason: str | None = None
    iterations: int = 0
    tree_states: int = 0
    states_checked: int = 0
    segments_checked: int = 0
    seconds: float = 0.0
    raw_length: float = float("nan")
    length: float = float("nan")
    repairs: int = 0
    knots: np.ndarray = field(default_factory=lambda: np.zeros(0))
    blends: np.ndarray = field(default_factory=lambda: np.zeros(0))
    blend_seconds: float = 0.0
    attempts: int = 0
    blocked: np.ndarray | None = None
    bodies: list[str] = field(default_factory=list)
    outcome: str = "found"
    inside_margin: list[str] = field(default_factory=list)
    kept: float = 0.0
    tight_kept: float = 0.0

    def joint_path(self):
        """The path as a :class:`~rworld_cli.planning.path.JointPath` (``blended``: the
        segments, their corners blended as :attr:`blends` says)."""
        return JointPath(self.waypoints, self.knots, "blended", self.blends)


def path_length(waypoints: np.ndarray) -> float:
    """Joint-space length of a polyline (W, n): the sum of its segments' Euclidean lengths."""
    waypoints = np.asarray(waypoints, dtype=float)
    return float(np.linalg.norm(np.diff(waypoints, axis=0), axis=1).sum())


@dataclass
class _Tree:
    """States (capacity grows) with their parents; roots have parent -1."""

    n: int
    states: np.ndarray = field(init=False)
    parent: np.ndarray = field(init=False)
    count: int = 0

    def __post_init__(self) -> None:
        self.states = np.empty((256, self.n))
        self.parent = np.empty(256, dtype=np.int64)

    def add(self, q: np.ndarray, parent: int) -> int:
        if self.count == len(self.states):
            self.states = np.concatenate([self.states, np.empty_like(self.states)])
            self.parent = np.concatenate([self.parent, np.empty_like(self.parent)])
        self.states[self.count] = q
        self.parent[self.count] = parent
        self.count += 1
        return self.count - 1

    def nearest(self, q: np.ndarray) -> int:
        d = self.states[: self.count] - q
        return int(np.argmin(np.einsum("ij,ij->i", d, d)))

    def branch(self, index: int) -> np.ndarray:
        """The states from ``index`` back to its root (M, n)."""
        out = []
        while index >= 0:
            out.append(self.states[index])
            index = int(self.parent[index])
        return np.array(out)


class _Search:
    """One planning problem's counters, clock and questions."""

    def __init__(self, states_free, segment_free, resolution, deadline, clock):
        self.states_free, self.segment_free = states_free, segment_free
        self.resolution, self.deadline, self.clock = resolution, deadline, clock
        self.states_checked = 0
        self.segments_checked = 0
        self.iterations = 0
        self.tree_states = 0

    def out_of_time(self) -> bool:
        return self.clock() > self.deadline

    def free_prefix(self, q0: np.ndarray, q1: np.ndarray, resolution: float | None = None):
        """How far along q0 -> q1 the states at ``resolution`` apart (q0 excluded: known free)
        are free: (fraction reached in [0, 1], all free)."""
        resolution = self.resolution if resolution is None else resolution
        span = float(np.abs(q1 - q0).max())
        count = max(1, int(np.ceil(span / resolution)))
        s = np.arange(1, count + 1) / count
        Q = q0 + s[:, None] * (q1 - q0)
        first = self._first_blocked(Q)
        if first is None:
            return 1.0, True
        return (float(s[first - 1]) if first else 0.0), False

    def _first_blocked(self, Q: np.ndarray) -> int | None:
        """The first of the states ``Q`` (M, n), in order, that is not free (None: all are),
        asked in batches that double (8, 16, 32, ...): a line blocked early costs a few
        states, a free one a few calls more than one batch."""
        done, size = 0, FIRST_BATCH
        while done < len(Q):
            part = slice(done, min(len(Q), done + size))
            free = np.asarray(self.states_free(Q[part]), dtype=bool)
            self.states_checked += len(free)
            if not free.all():
                return done + int(np.argmin(free))
            done, size = part.stop, 2 * size
        return None

    def line_free(self, q0, q1, resolution: float | None = None) -> bool:
        """Whether every state along q0 -> q1 at ``resolution`` apart (q0 excluded) is free:
        coarse to fine (every 2^k-th state first, then the ones between), in batches that
        double, so that a blocked line is found blocked after a few states wherever it is
        blocked."""
        resolution = self.resolution if resolution is None else resolution
        span = float(np.abs(q1 - q0).max())
        count = max(1, int(np.ceil(span / resolution)))
        k = np.arange(1, count + 1)
        # the largest power of two dividing k, largest first: 1/2, 1/4 and 3/4, ...
        order = k[np.argsort(-(k & -k), kind="stable")]
        return self._first_blocked(q0 + (order / count)[:, None] * (q1 - q0)) is None

    def segment(self, q0, q1) -> bool:
        self.segments_checked += 1
        return bool(self.segment_free(q0, q1))

    def bezier_free(self, p0, corner, p2, blend_free) -> bool:
        """The blend's curve: its states screened (16 along it, one call), then checked
        continuously by ``blend_free``."""
        s = (np.arange(1, 17) / 17)[:, None]
        Q = (1 - s) ** 2 * p0 + 2 * s * (1 - s) * corner + s**2 * p2
        free = np.asarray(self.states_free(Q), dtype=bool)
        self.states_checked += len(Q)
        if not free.all():
            return False
        self.segments_checked += 1
        return bool(blend_free(p0, corner, p2))


def plan_path(
    states_free: StatesFree,
    segment_free: SegmentFree,
    start,
    goals,
    lower,
    upper,
    *,
    seed: int = 0,
    timeout: float = 10.0,
    step: float = 0.5,
    resolution: float = 0.05,
    shortcuts: int = 60,
    max_iterations: int = 100_000,
    progress: Callable[[int, int], None] | None = None,
    clock: Callable[[], float] = time.perf_counter,
    blend_free: BlendFree | None = None,
) -> PathPlan:
    """A collision-free joint path from ``start`` to one of ``goals`` (module docstring).

    Parameters
    ----------
    states_free : callable
        (N, n) joint states -> (N,) bool.
    segment_free : callable
        (q0 (n,), q1 (n,)) -> bool: free everywhere between them (the continuous check).
    start : array_like, shape (n,)
    goals : array_like, shape (G, n) or (n,)
        Goal states, in order of preference (the first one a tree reaches wins).
    lower, upper : array_like, shape (n,)
        The joint box sampled [rad or m] (finite).
    seed : int
        Random generator seed: the same problem and seed give the same path.
    timeout : float
        Wall-time budget [s] of the search.
    step : float
        Longest tree edge, Euclidean in joint space [rad or m].
    resolution : float
        Spacing of the states checked along an edge, largest joint change [rad or m].
    shortcuts : int
        Random shortcut attempts after the greedy pass.
    max_iterations : int
        Growth rounds at most.
    progress : callable, optional
        ``progress(iterations, tree_states)`` now and then during the search.
    blend_free : callable, optional
        (p0, corner, p2 (n,) each) -> bool: the corner's blend (the quadratic Bezier curve
        of the three) free everywhere (the continuous check).  None: no blends.

    Returns
    -------
    PathPlan
    """
    t0 = clock()
    start = np.asarray(start, dtype=float).ravel()
    goals = np.atleast_2d(np.asarray(goals, dtype=float))
    lower = np.asarray(lower, dtype=float).ravel()
    upper = np.asarray(upper, dtype=float).ravel()
    n = len(start)
    if goals.shape[1] != n or lower.shape != (n,) or upper.shape != (n,):
        raise ValueError("start, goals and limits must have the device's joint count")
    if not (np.isfinite(lower).all() and np.isfinite(upper).all() and (lower <= upper).all()):
        raise ValueError("the joint box to sample must be finite, lower <= upper")
    search = _Search(states_free, segment_free, resolution, t0 + timeout, clock)
    empty = np.zeros((0, n))

    attempts, iterations, blocked = 0, 0, None

    def failed(reason: str, iterations: int = 0, states: int = 0, outcome="timeout") -> PathPlan:
        return PathPlan(
            False,
            empty,
            outcome=outcome,
            reason=reason,
            iterations=iterations,
            tree_states=states,
            states_checked=search.states_checked,
            segments_checked=search.segments_checked,
            seconds=clock() - t0,
            attempts=attempts,
            blocked=blocked,
        )

    inside = np.all((goals >= lower - 1e-12) & (goals <= upper + 1e-12), axis=1)
    ends = np.concatenate([start[None], goals])
    free = np.asarray(states_free(ends), dtype=bool)
    search.states_checked += len(ends)
    if not free[0]:
        return failed("the start state is not free", outcome="start_not_free")
    usable = np.flatnonzero(free[1:] & inside)
    if not len(usable):
        return failed(
            "no goal state is free"
            if inside.any()
            else "every goal state lies outside the joint limits",
            outcome="goal_not_free" if inside.any() else "goal_outside_limits",
        )
    rng = np.random.default_rng(seed)
    # the straight line first: most moves in an open cell need nothing else
    for g in usable:
        if search.line_free(start, goals[g]) and search.segment(start, goals[g]):
            way = np.stack([start, goals[g]])
            length = path_length(way)
            return PathPlan(
                True,
                way,
                int(g),
                None,
                0,
                1 + len(usable),
                search.states_checked,
                search.segments_checked,
                clock() - t0,
                length,
                length,
                knots=length_knots(way),
                blends=np.zeros(2),
            )
    # trees grown until a path passes the continuous check whole: one that does not (its
    # states free, a segment between them not, and no repair found) is dropped and the
    # search starts again with the generator where it is, while time is left
    while True:
        attempts += 1
        found = _connect_trees(
            search, rng, start, goals, usable, lower, upper, step, max_iterations, progress
        )
        if isinstance(found, _GaveUp):
            reason = found.reason
            if blocked is not None:
                reason += (
                    f" ({attempts - 1} path(s) found before failed the continuous check "
                    "and could not be planned around)"
                )
            return failed(reason, iterations + search.iterations, search.tree_states, found.outcome)
        raw, goal, its, states = found
        iterations += its
        way = _shortcut(search, rng, raw, shortcuts)
        way, repairs, bad = _validated(search, rng, way, lower, upper, step)
        if way is not None:
            break
        if bad is None:  # the time ran out in the middle of the path's continuous check
            before = (
                f"; {attempts - 1} path(s) before failed it and could not be planned around"
                if blocked is not None
                else ""
            )
            return failed(
                "no path found within the time limit (it ran out during the continuous check "
                f"of a path found{before})",
                iterations,
                states,
            )
        blocked = np.stack(bad)
        if search.out_of_time():
            return failed(
                f"{attempts} path(s) whose states passed failed the continuous check and could "
                "not be planned around within the time limit",
                iterations,
                states,
            )
    knots = length_knots(way)
    t_blend = clock()
    blends = np.zeros(len(way))
    if blend_free is not None:
        blends = _blended(search, way, knots, blend_free)
    return PathPlan(
        True,
        way,
        goal,
        None,
        iterations,
        states,
        search.states_checked,
        search.segments_checked,
        clock() - t0,
        path_length(raw),
        path_length(way),
        repairs,
        knots,
        blends,
        clock() - t_blend,
        attempts,
        blocked,
    )


def _blended(search: _Search, way: np.ndarray, knots: np.ndarray, blend_free) -> np.ndarray:
    """Each corner's blend: the widest of :data:`BLEND_TRIALS` whose curve is free (0: none;
    and none once the time is up - the path stays valid, at rest there).  Corners are
    independent: a blend is at most half of either knot interval beside it, so two never
    overlap."""
    blends = np.zeros(len(way))
    for k in range(1, len(way) - 1):
        for width in BLEND_TRIALS:
            if search.out_of_time():
                return blends
            trial = np.zeros(len(way))
            trial[k] = width
            p0, corner, p2 = blend_corners(knots, way, trial)[k]
            if search.bezier_free(p0, corner, p2, blend_free):
                blends[k] = width
                break
    return blends


class _GaveUp(NamedTuple):
    """Why a tree search ended without a path: :attr:`PathPlan.outcome`'s word, and in words."""

    outcome: str
    reason: str


def _connect_trees(search, rng, start, goals, usable, lower, upper, step, max_iterations, progress):
    """RRT-Connect: (the path's states (M, n) start to goal, goal index, iterations, tree
    states), or why it failed (:class:`_GaveUp`)."""
    n = len(start)
    from_start, from_goals = _Tree(n), _Tree(n)
    from_start.add(start, -1)
    root_goal = {}
    for g in usable:
        root_goal[from_goals.add(goals[g], -1)] = int(g)
    grow, other = from_start, from_goals
    for iteration in range(1, max_iterations + 1):
        search.iterations = iteration
        search.tree_states = from_start.count + from_goals.count
        if progress is not None and iteration % 64 == 0:
            progress(iteration, search.tree_states)
        if search.out_of_time():
            return _GaveUp("timeout", "no path found within the time limit")
        q_rand = rng.uniform(lower, upper)
        new = _extend(search, grow, q_rand, step, connect=False)
        if new is not None:
            q_new = grow.states[new]
            reached = _extend(search, other, q_new, step, connect=True)
            if reached is not None and np.array_equal(other.states[reached], q_new):
                a, b = (new, reached) if grow is from_start else (reached, new)
                path = np.concatenate([from_start.branch(a)[::-1], from_goals.branch(b)[1:]])
                root = b
                while from_goals.parent[root] >= 0:
                    root = int(from_goals.parent[root])
                search.tree_states = from_start.count + from_goals.count
                return path, root_goal[root], iteration, search.tree_states
        grow, other = other, grow
    return _GaveUp("iterations", "no path found within the iteration bound")


def _extend(search: _Search, tree: _Tree, target: np.ndarray, step: float, connect: bool):
    """Grow ``tree`` from its state nearest ``target`` towards it: one ``step`` (RRT's
    extend), or as far as it is free (``connect``: RRT-Connect's connect, every state along
    the line checked in one batch).  Returns the index of the last state added (None: none)."""
    near = tree.nearest(target)
    q_near = tree.states[near].copy()
    gap = float(np.linalg.norm(target - q_near))
    if gap == 0.0:
        return near
    reach = gap if connect else min(gap, step)
    q_end = q_near + (target - q_near) * (reach / gap)
    fraction, whole = search.free_prefix(q_near, q_end)
    if not whole:
        fraction = fraction if connect else 0.0
    if fraction <= 0.0:
        return None
    # states every `step` along the free part, and its end (the target itself when reached)
    length = reach * fraction
    pieces = max(1, int(np.ceil(length / step - 1e-12)))
    reached = whole and reach == gap  # the target itself, exactly (the trees meet on it)
    index = near
    for k in range(1, pieces + 1):
        last = k == pieces
        q = target if reached and last else q_near + (q_end - q_near) * (fraction * k / pieces)
        index = tree.add(q, index)
    return index


def _shortcut(search: _Search, rng, way: np.ndarray, attempts: int) -> np.ndarray:
    """The path shortened: each waypoint joined to the farthest later one a free straight line
    reaches (greedy), then ``attempts`` straight lines between random points of two different
    segments kept where free and shorter."""
    way = _greedy(search, np.asarray(way, dtype=float))
    misses = 0
    for _ in range(attempts):
        if len(way) < 3 or misses >= SHORTCUT_PATIENCE or search.out_of_time():
            break
        misses += 1
        i, j = np.sort(rng.choice(len(way) - 1, size=2, replace=False))
        if j == i:
            continue
        a = way[i] + rng.uniform() * (way[i + 1] - way[i])
        b = way[j] + rng.uniform() * (way[j + 1] - way[j])
        old = (
            np.linalg.norm(way[i + 1] - a)
            + path_length(way[i + 1 : j + 1])
            + np.linalg.norm(b - way[j])
        )
        if np.linalg.norm(b - a) < old - 1e-9 and search.line_free(a, b):
            way = np.concatenate([way[: i + 1], a[None], b[None], way[j + 1 :]])
            way = _without_repeats(way)
            misses = 0
    return _greedy(search, way)


def _greedy(search: _Search, way: np.ndarray) -> np.ndarray:
    """Each kept waypoint joined to the farthest later one a free straight line reaches.  The
    lines from a waypoint to every later one are screened together first (their middle and
    quarter states in one call: most blocked lines are blocked there), then checked whole
    from the farthest of those that passed: fewer calls.  A line blocked at a screened point
    that falls between its checked states is passed over (stricter, never looser); on the
    bench's 60 problems the paths are the same as without the screening."""
    kept = [way[0]]
    i = 0
    while i < len(way) - 1:
        far = np.arange(len(way) - 1, i + 1, -1)  # the candidates, farthest first
        if len(far):
            s = np.array([0.5, 0.25, 0.75])
            Q = way[i] + s[None, :, None] * (way[far] - way[i])[:, None, :]
            free = np.asarray(search.states_free(Q.reshape(-1, way.shape[1])), dtype=bool)
            search.states_checked += len(free)
            far = far[free.reshape(len(far), 3).all(axis=1)]
        j = next((int(k) for k in far if search.line_free(way[i], way[k])), i + 1)
        kept.append(way[j])
        i = j
    return np.array(kept)


def _without_repeats(way: np.ndarray) -> np.ndarray:
    keep = np.r_[True, np.abs(np.diff(way, axis=0)).max(axis=1) > 1e-12]
    return way[keep]


def _validated(search: _Search, rng, way, lower, upper, step, depth: int = 0):
    """Every segment checked continuously; one that fails is planned again between its ends
    with a quarter of the spacing (:data:`REPAIR_DEPTH` deep at most).  (path, repairs, None),
    or (None, repairs, (q0, q1)): the segment of ``way`` that failed and could not be
    repaired; (None, repairs, None): the time ran out first."""
    out = [way[0]]
    repairs = 0
    for q0, q1 in zip(way[:-1], way[1:]):
        if search.out_of_time():  # a segment's check can take seconds: none begun after time
            return None, repairs, None
        if search.segment(q0, q1):
            out.append(q1)
            continue
        repairs += 1
        if depth >= REPAIR_DEPTH or search.out_of_time():
            return None, repairs, (q0, q1)
        # a repair may take a share of the time left: one that cannot be found (a gap the
        # finer states cannot pass either) leaves the rest to a new search
        now = search.clock()
        finer = _Search(
            search.states_free,
            search.segment_free,
            search.resolution / 4,
            min(search.deadline, now + REPAIR_SHARE * max(search.deadline - now, 0.0)),
            search.clock,
        )
        found = _connect_trees(
            finer, rng, q0, q1[None], np.array([0]), lower, upper, step, 100_000, None
        )
        piece, more = None, 0
        if not isinstance(found, _GaveUp):
            piece = _shortcut(finer, rng, found[0], 20)
            piece, more, _ = _validated(finer, rng, piece, lower, upper, step, depth + 1)
        search.states_checked += finer.states_checked
        search.segments_checked += finer.segments_checked
        repairs += more
        if piece is None:
            return None, repairs, (q0, q1)
        out.extend(piece[1:])
    return np.array(out), repairs, None


REPAIR_DEPTH = 2  # a failing segment re-planned finer at most twice deep; then a new search
REPAIR_SHARE = 0.1  # of the time left, what one repair may take
SEARCH_MARGIN = 0.005  # [m] the search's states keep this much more than the path keeps
# [m] what a path keeps from everything when no clearance is asked, where its ends allow it: a
# path may not touch (as MoveIt's and MotionBenchMaker's checks see it) although touches
# within the collision tolerance pass `rworld check`.  On 35 MotionBenchMaker problems it cost
# nothing measurable (median 0.139 s either way); 5 mm cost (34 of 35 solved, p95 3.5 s
# against 1.1 s): states at the 5 mm margin and segments held to 5 mm between them
PATH_CLEARANCE = 0.001


class WorldChecks:
    """The questions :func:`plan_path` asks, for ``device`` in ``world`` as it is now (other
    devices, grasps and tools where the world has them), answered by the collision room.

    ``clearance`` is asked of every pair everywhere (the ends checked at it: ``exact``);
    ``kept`` (at least the clearance; :data:`PATH_CLEARANCE` where the caller asks none) is
    what the path keeps: a state is free by ``ConfigurationChecker.check`` at ``kept`` plus
    :data:`SEARCH_MARGIN`, a segment or a blend by ``check_segment`` / ``check_blend`` at
    ``kept`` (``kept_check``).  A pair already inside the margin at the start or a goal (a goal
    just above a table, a probe's stylus 0.7 mm from the wrist it is mounted beside at every
    state) is searched without the margin everywhere in the problem (``tight``): with it, no
    state near that end would be free and no path found.  Those pairs keep ``tight_kept``,
    states and segments alike: ``kept`` where the ends hold them that far apart, else half
    the nearest one's distance at an end (at least the clearance asked), so that a path never
    touches what its ends keep clear of (with the tolerance rule alone a pair 2.7 mm apart at
    a goal passed 0.19 mm into each other mid-path); a pair touching at the start keeps the
    tolerance rule (``touching``).  Every other pair keeps the margin up to the ends.  Built
    once per world and device (the pairs, the trees); :meth:`problem` sets the ends."""

    def __init__(
        self,
        world,
        model,
        device: str,
        tolerance: float,
        clearance: float = 0.0,
        kept: float | None = None,
    ):
        from ..collision.configurations import ConfigurationChecker

        self.device = world.cell.devices[device]
        self.clearance = float(clearance)
        self.kept = max(self.clearance, float(kept if kept is not None else clearance))
        self._make = lambda extra, **pairs: ConfigurationChecker(
            world, model, device, tolerance=tolerance, clearance=clearance + extra, **pairs
        )
        extra = self.kept - self.clearance
        # every pair: a problem no end of which is inside the margin
        self._with_margin = self._make(extra + SEARCH_MARGIN)
        self.search = self._with_margin
        self.exact = self._make(0.0)
        self._kept_all = self._make(extra) if extra > 0 else self.exact
        self.kept_check = self._kept_all  # the segments' check: pairs not tight keep `kept`
        self.tight: set[tuple[int, int]] = set()  # pairs searched without the margin
        self.touching: set[tuple[int, int]] = set()  # of those, touching at the start
        self.tight_kept = self.kept  # what the tight pairs (not touching) keep
        self.inside_margin: list[str] = []  # those pairs at the ends, in words
        self.outcome = "found"  # why the last problem has no path, when it has none
        self._tight_checks: list = []  # the tight pairs' checks: states and segments
        self.ends = np.zeros((0, self.device.dof))

    def problem(self, start, goals) -> tuple[np.ndarray, str | None]:
        """Set the ends: the goals that are free and touch nothing (an overlap within the
        tolerance: every way into such a goal grazes what it touches) - (their indices, None),
        or (empty, why no path can start or end), the why in a word in :attr:`outcome`
        (:attr:`PathPlan.outcome`'s)."""
        start = np.asarray(start, dtype=float).ravel()
        goals = np.atleast_2d(np.asarray(goals, dtype=float))
        self.outcome = "found"
        ends = np.concatenate([start[None], goals])
        # free or not, and touching (an overlap within the tolerance: measured, negative) from
        # the free-only check; the nearest pairs, for the words, only when an end fails
        report = self.exact.check(ends, nearest=False)
        free, touching = report.free[1:], report.distance[1:] < 0.0
        usable = np.flatnonzero(free & ~touching)
        if not report.free[0] or not len(usable):
            report = self.exact.check(ends)
        if not report.free[0]:
            words = nearest_words(self.exact, report, 0)
            self.outcome = "start_not_free"
            return np.zeros(0, dtype=int), f"the start is not free ({words})"
        if not len(usable):
            words = "; ".join(
                nearest_words(self.exact, report, 1 + k) for k in range(min(3, len(goals)))
            )
            words += f"; and {len(goals) - 3} more" if len(goals) > 3 else ""
            if (free & touching).any():
                self.outcome = "goal_touching"
                return usable, (
                    f"every free goal state touches something ({words}): a motion into contact "
                    "is a guarded or straight move's work (with 'touch:'); plan to a state clear "
                    "of it (an offset) and approach from there"
                )
            self.outcome = "goal_not_free"
            return usable, f"no goal state is free ({words})"
        self.ends = np.concatenate([start[None], goals[usable]])
        self._relax_margin()
        return usable, None

    def _relax_margin(self) -> None:
        """The pairs inside the search margin at an end (free at the clearance asked) move to
        ``tight``: searched without the margin, keeping ``tight_kept``; the others keep the
        margin.  Those of this problem's ends only: checks kept for several problems start
        each with none."""
        self.tight, self.touching, self.tight_kept = set(), set(), self.kept
        self.search, self._tight_checks = self._with_margin, []
        self.kept_check = self._kept_all
        self.inside_margin = []
        for _ in range(len(self.exact.pairs)):  # a pair an end a round: few are that close
            # free-only: a state not free names a pair within the margin, measured
            report = self.search.check(self.ends, nearest=False)
            inside = np.flatnonzero(~report.free)
            added = {
                tuple(int(x) for x in report.pair[k]) for k in inside if report.pair[k][0] >= 0
            }
            if not added - self.tight:
                break
            for k in inside:
                if report.pair[k][0] >= 0 and tuple(report.pair[k]) not in self.tight:
                    end = "the start" if k == 0 else "a goal"
                    words = (
                        f"{nearest_words(self.search, report, k)} at {end}, inside the search's "
                        f"{SEARCH_MARGIN * 1000:g} mm margin"
                    )
                    if words not in self.inside_margin:
                        self.inside_margin.append(words)
            self.tight |= added
            self.search = self._make(self.kept - self.clearance + SEARCH_MARGIN, skip=self.tight)
        if not self.tight:
            return
        if self.kept == self.clearance:  # every pair keeps the clearance asked, these too
            self._tight_checks = [self._make(0.0, only=self.tight)]
            return
        # the start's touching pairs (an overlap within the tolerance: negative, measured), a
        # pair a round; the goals touch nothing (``problem`` dropped those that do)
        for _ in range(len(self.tight)):
            report = self._make(1e-9, only=self.tight - self.touching).check(
                self.ends[:1], nearest=False
            )
            if report.free[0] or report.pair[0][0] < 0:
                break
            self.touching.add(tuple(int(x) for x in report.pair[0]))
        rest = self.tight - self.touching
        if rest:
            # the nearest of the rest at the ends, measured (each end free at the clearance)
            nearest = float(self._make(0.0, only=rest).check(self.ends).distance.min())
            self.tight_kept = max(self.clearance, min(self.kept, 0.5 * nearest))
            self._tight_checks.append(self._make(self.tight_kept - self.clearance, only=rest))
        if self.touching:
            self._tight_checks.append(self._make(0.0, only=self.touching))
        self.kept_check = self._make(self.kept - self.clearance, skip=self.tight)

    def states_free(self, Q) -> np.ndarray:
        """(N, n) joint states -> (N,) bool (the class docstring's rule)."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        free = self.search.free(Q)
        for check in self._tight_checks:
            if free.any():
                free[free] = check.free(Q[free])
        return free

    def _segment_checks(self) -> list:
        """The continuous checks a segment or blend must pass: ``kept_check``, then the tight
        pairs' own where ``kept_check`` leaves them out."""
        if self.kept_check is self.exact:  # every pair at the clearance asked, in one
            return [self.kept_check]
        return [self.kept_check, *self._tight_checks]

    def segment_free(self, qa, qb) -> bool:
        """The straight segment free everywhere (continuous): ``kept`` from everything, the
        tight pairs ``tight_kept``."""
        return all(c.check_segment(qa, qb).free for c in self._segment_checks())

    def blend_free(self, p0, corner, p2) -> bool:
        """A corner's blend (the quadratic Bezier curve) free everywhere, as a segment."""
        return all(c.check_blend(p0, corner, p2).free for c in self._segment_checks())

    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """The joint box sampled (:func:`sampled_box` of the limits)."""
        return sampled_box(self.device.limit_array("lower")), sampled_box(
            self.device.limit_array("upper")
        )


def plan_in_world(
    world,
    model,
    device: str,
    start,
    goals,
    *,
    tolerance: float,
    clearance: float = 0.0,
    seed: int = 0,
    timeout: float = 10.0,
    progress: Callable[[int, int], None] | None = None,
    checks: WorldChecks | None = None,
    blend: bool = True,
    kept: float | None = None,
) -> tuple[PathPlan, WorldChecks]:
    """:func:`plan_path` for ``device`` in ``world`` as it is now, checked as
    :class:`WorldChecks` says (``checks``: one built before for this world and device;
    ``clearance`` asked everywhere, ``kept`` where the ends allow), its corners blended where
    the blends are free (``blend``).  Goals that are not free or touch something are dropped
    first; with none left the plan is not found and its reason names the nearest pairs.
    Returns (plan, the checks)."""
    checks = checks or WorldChecks(world, model, device, tolerance, clearance, kept)
    start = np.asarray(start, dtype=float).ravel()
    goals = np.atleast_2d(np.asarray(goals, dtype=float))
    # a continuous joint (no limits) is an angle: each goal the turn nearest the start, and
    # the box sampled a turn around the start (a state at 244 deg is -116 deg)
    endless = ~np.isfinite(checks.device.limit_array("lower")) & ~np.isfinite(
        checks.device.limit_array("upper")
    )
    endless &= np.array([j.kind == "revolute" for j in checks.device.joints], dtype=bool)
    if endless.any():
        turn = np.remainder(goals[:, endless] - start[endless] + np.pi, 2 * np.pi) - np.pi
        goals = goals.copy()
        goals[:, endless] = start[endless] + turn
    usable, why = checks.problem(start, goals)
    if why is not None:
        plan = PathPlan(False, np.zeros((0, len(start))), reason=why, outcome=checks.outcome)
        return plan, checks
    lower, upper = checks.box()
    lower = np.where(endless, start - np.pi, lower)
    upper = np.where(endless, start + np.pi, upper)
    plan = plan_path(
        checks.states_free,
        checks.segment_free,
        start,
        goals[usable],
        lower,
        upper,
        seed=seed,
        timeout=timeout,
        progress=progress,
        blend_free=checks.blend_free if blend else None,
    )
    plan.inside_margin = list(checks.inside_margin)
    plan.kept, plan.tight_kept = checks.kept, checks.tight_kept
    if plan.found:
        plan.goal = int(usable[plan.goal])  # an index of the goals given
    elif plan.blocked is not None:
        words, plan.bodies = segment_words(checks, plan.blocked)
        plan.reason = f"{plan.reason}; {words}"
    return plan, checks


def joint_words(device, q) -> str:
    """Joint values in words: '(12.5, -40, 90) deg', a prismatic joint's in mm."""
    values = []
    for joint, value in zip(device.joints, np.asarray(q, dtype=float)):
        prismatic = joint.kind == "prismatic"
        values.append(f"{value * 1000:.4g} mm" if prismatic else f"{np.degrees(value):.4g}")
    return "(" + ", ".join(values) + ") deg"


def segment_words(checks: WorldChecks, segment: np.ndarray) -> tuple[str, list[str]]:
    """A segment ``(2, n)`` the continuous check refused, in words: its ends, the first
    contact found and the deepest of its states measured (the pair and how deep); and the
    bodies named (their labels)."""
    q0, q1 = np.asarray(segment, dtype=float)
    # the check that refused it: what the path keeps, or the tight pairs'
    for exact in checks._segment_checks():
        found = exact.check_segment(q0, q1)
        if not found.free:
            break
    s = np.linspace(0.0, 1.0, 65)
    report = exact.check(q0 + s[:, None] * (q1 - q0), nearest=True)
    k = int(np.argmin(report.distance))
    deepest = ""
    pairs = [found.pair] if found.pair is not None else []
    if report.pair[k][0] >= 0:
        deepest = f"; nearest along it: {nearest_words(exact, report, k)} at {100 * s[k]:.0f} %"
        pairs.append(tuple(report.pair[k]))
    bodies = list(dict.fromkeys(exact.model.bodies[i].label for pair in pairs for i in pair))
    return (
        f"the segment that failed was from {joint_words(checks.device, q0)} to "
        f"{joint_words(checks.device, q1)}: {first_contact_words(exact, found)}{deepest}"
    ), bodies


def sampled_box(limits: np.ndarray) -> np.ndarray:
    """Joint limits with a turn in place of none (a joint without limits samples +-pi)."""
    return np.where(np.isfinite(limits), limits, np.sign(limits) * np.pi)


def nearest_words(checker, report, k: int) -> str:
    """State ``k``'s nearest pair of a ``ConfigurationChecker`` report in words: 'link_2 and
    table 3.1 mm deep'."""
    i, j = report.pair[k]
    if i < 0:
        return "nothing near"
    bodies = checker.model.bodies
    return f"{bodies[i].label} and {bodies[j].label} {_how(report, k)}"


def first_contact_words(checker, found) -> str:
    """Where a segment's check (``check_segment``'s report ``found``) found its first contact,
    in words: 'link_2 into link_4 at 40 % of the move'."""
    bodies = checker.model.bodies
    i, j = found.pair if found.pair is not None else (-1, -1)
    if i < 0:
        return "not proved free"
    return f"{bodies[i].label} into {bodies[j].label} at {100 * found.first:.0f} % of the move"


def _how(report, k: int) -> str:
    d = float(report.distance[k])
    if report.buried[k]:
        return "buried"
    if d < 0:
        return f"{-d * 1000:.3g} mm deep"
    return f"{d * 1000:.3g} mm apart"
