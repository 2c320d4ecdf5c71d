"""Collision and clearance along a run, with a guarantee between samples.

**The guarantee.**  For a pair of bodies and two instants ``ta < tb`` with
distances ``da`` and ``db``, no point of either body moves farther than
``M = Ma + Mb`` in between (the motion bound below).  The distance is
1-Lipschitz in that motion, so for every t in between,
``d(t) >= max(da - m(ta, t), db - m(t, tb)) >= (da + db - M) / 2``.
When ``da + db - M >= 2 (c - tol)``, the pair keeps at least the required
clearance ``c`` less the tolerance ``tol`` on the whole interval (``c = 0``:
no contact deeper than ``tol``).  Otherwise the interval is split at its
midpoint, the state there is computed exactly (the motion's own
interpolation, not a straight line between samples), and each half is tested
again, until every interval passes or a contact is found.  So **no contact
deeper than the tolerance is missed between two samples**, however fast the
motion: a 2 mm plate crossed at full speed is found.

**The motion bound.**  A body on a chain moves, when joint j turns by an angle
of at most ``V_j``, by at most ``V_j r_j``, where ``r_j`` bounds the distance
from joint j's axis to any point of the body: the sum of the lengths of the
tree's edges from the joint to the body's frame, plus the body's bounding
sphere (centre distance and radius); a prismatic joint moves it by ``V_j``.
Joints of several devices add (a hand on a robot on a conveyor).  ``V_j``
bounds the joint's travel: ``h (|qd_a| + |qd_b|) / 2 + A h^2 / 4`` over an
interval of length ``h``, with ``A`` the joint's acceleration limit or, when
larger, its acceleration at either end.

**Broad phase.**  Bounding spheres give every pair's distance a lower bound
at each sample for one subtraction; pairs whose lower bounds already pass the
test never reach the exact (GJK) query.

**Exact only as far as needed.**  A sample's distance is asked exactly up to
the larger of the watched distance (the clearance and the report's columns)
and the motion bound of the intervals it ends plus the clearance
(:func:`_within`); a pair farther than that is known only to be farther, which
passes those intervals whatever the other end, and its bodies' trees stop at
that depth instead of finding the nearest triangles.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .allowed import allowed_pairs, touch_bodies
from .bodies import Body, CollisionModel, distances
from .levers import _Levers

CHUNK = 128  # clock samples per chunk of the broad phase: memory is pairs kept x CHUNK
BROAD_PHASE = True  # False: every pair at every sample in one chunk (the reference for tests)
MAX_SPLITS = 40  # bisections of one sample interval; 2^-40 of 10 ms is 1e-14 s
REFINE_BATCH = 1024  # intervals refined per batch: memory ~ batch x the bodies it involves
MAX_ITEMS = 200_000  # intervals refined at once; beyond, the rest count as possible contacts
# GJK iterations per query: a pair short of convergence then (curved pieces nearly tangent)
# counts with GJK's lower bound on its distance, which keeps the guarantee
SWEEP_ITERATIONS = 24


@dataclass
class Contact:
    """Two bodies in contact (or closer than the clearance) over a time span.

    A collision overlaps deeper than the tolerance (or is buried): ``distance`` is 0 and
    ``depth`` estimates the penetration (see :func:`rworld_cli.collision.convex.penetration`).
    Otherwise it is a clearance violation and ``distance`` the least separation found (0 for a
    touch shallower than the tolerance).  ``points`` are the contact (or closest) points in
    world at ``t_worst`` [m].
    """

    a: str
    b: str
    t_start: float
    t_end: float
    t_worst: float
    distance: float
    depth: float
    point_a: list
    point_b: list
    buried: bool
    between_samples: bool  # found only by refining between two samples
    is_collision: bool = True

    @property
    def collision(self) -> bool:
        return self.is_collision

    def as_dict(self) -> dict:
        return {
            "a": self.a,
            "b": self.b,
            "kind": "collision" if self.collision else "clearance",
            "t_start": self.t_start,
            "t_end": self.t_end,
            "t_worst": self.t_worst,
            "distance": self.distance,
            "depth": self.depth,
            "point_a": self.point_a,
            "point_b": self.point_b,
            "buried": self.buried,
            "between_samples": self.between_samples,
        }


@dataclass
class SweepResult:
    """What :func:`sweep` found.

    Attributes
    ----------
    contacts : list of Contact
    close : dict
        Every pair that came within ``report_within`` at a clock sample (pairs that may touch
        left out): ``a``, ``b`` (N,) body indices, ``sample`` (N,) clock index, ``distance``
        (N,) [m], ``point_a``, ``point_b`` (N, 3) closest points in world [m].
    queries : int
        Exact pair distance evaluations.
    refinements : int
        States computed between samples.
    """

    contacts: list[Contact]
    close: dict[str, np.ndarray] = field(default_factory=dict)
    queries: int = 0
    refinements: int = 0


@dataclass
class Interval:
    """A stretch of run with one affixment tree: ``snap`` holds from ``t0`` to ``t1``."""

    t0: float
    t1: float
    snap: dict


def sweep(
    world,
    model: CollisionModel,
    intervals: list[Interval],
    states,
    clock: np.ndarray,
    tolerance: float,
    clearance: float = 0.0,
    touches=(),
    report_within: float = 0.0,
) -> SweepResult:
    """Check a run for collisions and clearance violations (module docstring).

    Parameters
    ----------
    world : World
        Restored to each interval's snapshot in turn (left at the last).
    model : CollisionModel
    intervals : list of Interval
    states : callable
        ``states(times, devices=None) -> {device: (q, qd, qdd)}`` each (N, n), SI, for every
        device or those named.
    clock : ndarray, shape (K,)
        The run's sample instants [s].
    tolerance : float
        Contacts shallower than this may be missed between samples [m] (> 0).
    clearance : float
        Required distance between bodies that may not touch [m] (0: contact only).
    touches : iterable of (t0, t1, device, depths)
        ``touch:`` steps: during [t0, t1] the device's bodies may touch each named body
        (``depths``: name -> the depth allowed [m]); a contact deeper than that, or a body
        buried in the other, is still a collision.
    report_within : float
        Also record every pair closer than this at the clock's samples [m] (``close``).
    """
    run = _Sweep(world, model, states, clock, tolerance, clearance, report_within)
    found, close, touch_windows, stats = run.found, run.close, run.touch_windows, run.stats
    for iv in intervals:
        world.restore(iv.snap)
        for t0, t1, device, depths in touches:
            if t1 < iv.t0 or t0 > iv.t1:
                continue
            pairs: dict[tuple[int, int], float] = {}
            for name, depth in depths.items():
                mine, named = touch_bodies(world, model, device, [name])
                for a in mine:
                    for b in named:
                        if a != b:
                            key = (min(a, b), max(a, b))
                            pairs[key] = max(pairs.get(key, 0.0), depth)
            touch_windows.append((max(t0, iv.t0), min(t1, iv.t1), pairs))
        _sweep_interval(run, iv)
    if intervals:
        world.restore(intervals[-1].snap)
    kept = [f for f in found if not _touch_allows(f, touch_windows)]
    # the clock's step (its last interval may be shorter: the run's end is not on the grid)
    dt = float(np.max(np.diff(clock))) if len(clock) > 1 else 1.0
    keys = ("a", "b", "sample", "distance", "point_a", "point_b")
    near = {
        k: np.concatenate([c[n] for c in close])
        if close
        else np.zeros((0, 3) if "point" in k else 0, dtype=float if k in keys[3:] else int)
        for n, k in enumerate(keys)
    }
    return SweepResult(_spans(model, kept, dt), near, stats["queries"], stats["refinements"])


@dataclass
class _Sweep:
    """What every interval of one sweep reads, and what they add to."""

    world: object
    model: CollisionModel
    states: Callable[..., dict]  # (times, devices=None) -> {device: (q, qd, qdd)}
    clock: np.ndarray
    tolerance: float
    clearance: float
    report_within: float
    found: list = field(default_factory=list)  # (i, j, t, distance, depth, pa, pb, buried,
    # between, collision)
    close: list = field(default_factory=list)  # per interval: (a, b, sample, distance, pa, pb)
    touch_windows: list = field(default_factory=list)  # (t0, t1, {allowed pair: depth})
    stats: dict = field(default_factory=lambda: {"queries": 0, "refinements": 0})

    def sample_index(self, t: np.ndarray) -> np.ndarray:
        """The clock index of each instant of ``t`` (N,), or -1 for instants off the clock."""
        k = np.minimum(np.searchsorted(self.clock, t), len(self.clock) - 1)
        return np.where(self.clock[k] == t, k, -1)


def _sweep_interval(run: _Sweep, iv: Interval) -> None:
    """Check one stretch of one affixment tree (module docstring), adding to ``run``: its
    samples in chunks of ``CHUNK``, each with the pairs the broad phase keeps."""
    world, model, states, clock = run.world, run.model, run.states, run.clock
    bodies = model.bodies
    B = len(bodies)
    inside = clock[(clock > iv.t0) & (clock < iv.t1)]
    # the clock inside, with the stretch's ends (sorted already; an end on the clock once).
    # Not np.unique: its first plain call imports numpy.ma, 12 ms of every check
    times = np.concatenate([[iv.t0], inside, [iv.t1]])
    times = times[np.r_[True, times[1:] != times[:-1]]]
    K = len(times)
    joints = states(times)
    levers = _Levers.of(world, bodies, joints)
    may = np.triu(np.ones((B, B), dtype=bool), 1)  # pairs that may not touch
    for i, j in allowed_pairs(world, model):
        may[i, j] = False
    if not may.any():
        return
    before = {d: tuple(x[:-1] for x in v) for d, v in joints.items()}
    after = {d: tuple(x[1:] for x in v) for d, v in joints.items()}
    travel = levers.travel(before, after, np.diff(times))  # (K-1, L) joint travel bounds
    moving = np.any(travel > 0, axis=0)  # (L,) joints that move at all in the stretch
    reach = levers.arm @ travel.T  # (B, K-1): how far any point of each body moves
    queried: set[tuple[int, int]] = set()
    mark = len(run.close)
    chunk = CHUNK if BROAD_PHASE else max(K - 1, 1)
    for start in range(0, max(K - 1, 1), chunk):
        stop = min(start + chunk, K - 1)
        queried = _sweep_chunk(
            run, iv, times, joints, levers, may, travel, moving, reach, start, stop, queried
        )
    if len(run.close) > mark + 1:  # one record for the interval, by pair, then sample
        parts = [np.concatenate(x) for x in zip(*run.close[mark:])]
        order = np.lexsort((parts[2], parts[1], parts[0]))
        run.close[mark:] = [tuple(x[order] for x in parts)]


def _candidates(centres, radius, reach, may, margin: float) -> np.ndarray:
    """Broad phase: the pairs (P, 2) whose swept bounding boxes over a chunk come within
    ``margin`` [m] of each other.  Each body's box holds its bounding sphere at every sample,
    grown by the most any point of it moves to the neighbouring samples (``reach``), so it
    holds the body at every instant in between; boxes farther apart than ``margin`` prove the
    bodies are, for the whole chunk."""
    grow = radius[:, None] + reach  # (B, Kc)
    lo = (centres - grow[..., None]).min(axis=1) - margin / 2
    hi = (centres + grow[..., None]).max(axis=1) + margin / 2
    # sweep and prune on x, then the other axes on the few pairs that overlap in x
    order = np.argsort(lo[:, 0], kind="stable")
    ends = np.searchsorted(lo[order, 0], hi[order, 0], side="right")
    counts = np.maximum(ends - np.arange(len(order)) - 1, 0)  # partners later in the order
    a = np.repeat(np.arange(len(order)), counts)
    b = a + 1 + np.arange(len(a)) - np.repeat(np.cumsum(counts) - counts, counts)
    I, J = order[a], order[b]
    I, J = np.minimum(I, J), np.maximum(I, J)
    keep = np.all((lo[I] <= hi[J]) & (lo[J] <= hi[I]), axis=1) & may[I, J]
    pairs = np.stack([I[keep], J[keep]], axis=1)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))] if len(pairs) else pairs.reshape(0, 2)


def _sweep_chunk(
    run: _Sweep, iv, times, joints, levers, may, travel, moving, reach, start, stop, queried
) -> set[tuple[int, int]]:
    """Samples ``start..stop`` of an interval and the clock intervals between them: the pairs
    the broad phase keeps, bounded, queried and refined.  ``queried``: the pairs whose distance
    at ``start`` the previous chunk already reported on.  Returns the pairs queried at
    ``stop``."""
    world, model = run.world, run.model
    tolerance, clearance, report_within = run.tolerance, run.clearance, run.report_within
    found, close, touch_windows, stats = run.found, run.close, run.touch_windows, run.stats
    bodies = model.bodies
    times = times[start : stop + 1]
    K = len(times)
    q = {d: v[0][start : stop + 1] for d, v in joints.items()}
    poses = _poses(world, bodies, q)  # (B, K, 4, 4)
    centre_in_frame = np.stack([b.center for b in bodies])[:, None, :, None]  # (B, 1, 3, 1)
    centres = (poses[:, :, :3, :3] @ centre_in_frame)[..., 0] + poses[:, :, :3, 3]
    radius = np.array([b.radius for b in bodies])
    moves = reach[:, start:stop]  # (B, K-1)
    around = np.zeros((len(bodies), K))  # each sample: the most a body moves to a neighbour
    if K > 1:
        around[:, :-1] = moves
        around[:, 1:] = np.maximum(around[:, 1:], moves)
    watch = max(clearance, report_within)
    if BROAD_PHASE:
        pairs = _candidates(centres, radius, around, may, max(watch, 0.0))
    else:
        pairs = np.argwhere(may)
    I, J = pairs[:, 0], pairs[:, 1]
    weights = levers.pair_weights(I, J)
    static = weights.static(moving)  # the pair moves, if at all, as one rigid body
    if start > 0:  # a pair that does not move was settled at the interval's first sample
        pairs, weights, static = pairs[~static], weights.take(~static), static[~static]
        I, J = pairs[:, 0], pairs[:, 1]
    if not len(pairs):
        return set()
    # lower bounds on every pair's distance: bounding spheres, and each bounding sphere
    # against the other body's bounding box (a long rail's sphere alone tells little)
    lower = (
        np.linalg.norm(centres[I] - centres[J], axis=2) - radius[I, None] - radius[J, None]
    )  # (P, K)
    slack = 2.0 * (clearance - tolerance)
    M = weights.bound(travel[start:stop])  # (P, K-1) motion bounds
    # the boxes only where the spheres leave a sample or an interval to check
    unsettled = np.any(lower < watch if watch > 0 else lower <= 0, axis=1)
    if K > 1:
        unsettled |= np.any(lower[:, :-1] + lower[:, 1:] - M < slack, axis=1)
    rows = np.flatnonzero(unsettled)
    if len(rows):
        Ir, Jr = I[rows], J[rows]
        boxed, slot = np.unique(np.concatenate([Ir, Jr]), return_inverse=True)
        T_box = (
            poses[boxed]
            @ np.stack([bodies[b].shape.bounding_box.T_owner_box for b in boxed])[:, None]
        )
        half = np.stack([bodies[b].shape.bounding_box.half_extents for b in boxed])
        sa, sb = slot[: len(rows)], slot[len(rows) :]
        part = lower[rows]
        for a, c in ((sa, Jr), (sb, Ir)):
            local = np.einsum("pkji,pkj->pki", T_box[a, :, :3, :3], centres[c] - T_box[a, :, :3, 3])
            outside = np.linalg.norm(np.maximum(np.abs(local) - half[a, None, :], 0.0), axis=2)
            part = np.maximum(part, outside - radius[c, None])
        lower[rows] = part
    if K > 1:
        need_interval = lower[:, :-1] + lower[:, 1:] - M < slack
        need_interval[static] = False
    else:
        need_interval = np.zeros((len(pairs), 0), dtype=bool)
    need_sample = lower < watch if watch > 0 else lower <= 0
    need_sample[:, 1:] |= need_interval
    need_sample[:, :-1] |= need_interval
    need_sample[static, 1:] = False  # a pair that does not move: its first state tells all
    exact = np.full(lower.shape, np.nan)  # signed: distance, or minus the penetration depth
    qp, qk = np.nonzero(need_sample)
    # how far a sample's distance must be known: exactly within the watched distance, and
    # up to the motion bound of a neighbouring interval to check (with the clearance); past
    # that, a lower bound passes the interval whatever the other end (_within)
    adjacent = np.zeros(lower.shape)
    if K > 1:
        bound = np.where(need_interval, M, 0.0)
        adjacent[:, :-1] = bound
        adjacent[:, 1:] = np.maximum(adjacent[:, 1:], bound)
    within = _within(adjacent[qp, qk], watch, clearance)
    # depths exact above the tolerance (what a collision reports); a touch's bounded from
    # above (a signed distance no larger: the intervals' test stays safe)
    res = distances(
        bodies,
        I[qp],
        J[qp],
        poses[I[qp], qk],
        poses[J[qp], qk],
        SWEEP_ITERATIONS,
        within,
        exact_above=tolerance,
    )
    stats["queries"] += len(qp)
    exact[qp, qk] = _signed(res, within)
    # the first sample is the previous chunk's last: reported there when queried there
    fresh = np.ones(len(qp), dtype=bool)
    if queried:
        for r in np.flatnonzero(qk == 0):
            fresh[r] = (int(I[qp[r]]), int(J[qp[r]])) not in queried
    sample = run.sample_index(times[qk])
    for n in _reportable(res, tolerance, clearance):
        if not fresh[n]:
            continue
        p, t = qp[n], float(times[qk[n]])
        found.append(_finding(I[p], J[p], t, res, n, sample[n] < 0, tolerance))
        if static[p]:  # a pair that does not move: the same for the whole interval
            found.append(found[-1][:2] + (float(iv.t1),) + found[-1][3:])
    if report_within > 0:
        keep = fresh & (sample >= 0) & (res.distance < report_within)
        for t0, t1, tp in touch_windows:  # touching is the point of those steps
            allowed_now = np.array([(int(i), int(j)) in tp for i, j in pairs], dtype=bool)
            keep &= ~(allowed_now[qp] & (times[qk] >= t0) & (times[qk] <= t1))
        close.append(
            (
                I[qp][keep],
                J[qp][keep],
                sample[keep],
                res.distance[keep],
                res.point_a[keep],
                res.point_b[keep],
            )
        )
    last = {(int(I[p]), int(J[p])) for p in qp[qk == K - 1]}
    if K == 1:
        return last
    # intervals whose exact end distances still do not pass: bisect them
    da, db = exact[:, :-1], exact[:, 1:]
    fail = need_interval & ~np.isnan(da) & ~np.isnan(db)
    # an end that is already reported (a collision, or closer than the clearance) ends the search
    floor = clearance if clearance > 0 else -tolerance
    fail &= (da >= floor) & (db >= floor)
    fail &= da + db - M < slack
    p_idx, k_idx = np.nonzero(fail)
    # (B,): each body's first joint that carries it (none at all: a cell whose arm has no
    # shapes, only fixed bodies in the sweep)
    first_joint = (
        np.argmax(levers.arm > 0, axis=1)
        if levers.arm.shape[1]
        else np.zeros(len(levers.arm), dtype=int)
    )
    items = {
        "p": p_idx,
        "ta": times[k_idx],
        "tb": times[k_idx + 1],
        "da": da[p_idx, k_idx],
        "db": db[p_idx, k_idx],
    }
    for _ in range(MAX_SPLITS):
        if not len(items["p"]):
            break
        if len(items["p"]) > MAX_ITEMS:
            break  # reported below as unresolved, so that the check fails safe
        # batches of few devices each: by the first joint that moves the pair's first body
        order = np.lexsort((items["p"], first_joint[pairs[items["p"], 0]]))
        items = {k: v[order] for k, v in items.items()}
        tm = 0.5 * (items["ta"] + items["tb"])
        stats["refinements"] += len(tm)
        stats["queries"] += len(tm)
        parts = [
            _midpoints(run, levers, weights, pairs, items, tm, slice(k, k + REFINE_BATCH))
            for k in range(0, len(tm), REFINE_BATCH)
        ]
        dm, M1, M2 = (np.concatenate(x) for x in zip(*parts, strict=True))
        ok = dm >= floor  # a contact found at the midpoint ends the search there
        left = ok & (items["da"] + dm - M1 < slack)
        right = ok & (dm + items["db"] - M2 < slack)
        items = {
            "p": np.concatenate([items["p"][left], items["p"][right]]),
            "ta": np.concatenate([items["ta"][left], tm[right]]),
            "tb": np.concatenate([tm[left], items["tb"][right]]),
            "da": np.concatenate([items["da"][left], dm[right]]),
            "db": np.concatenate([dm[left], items["db"][right]]),
        }
    if len(items["p"]):
        _unresolved(items, pairs, found)
    return last


def _midpoints(run: _Sweep, levers, weights, pairs, items, tm, rows: slice):
    """One batch of the refinement: the exact distance at each interval's midpoint (findings
    added to ``run``) and the motion bounds of its two halves.  States and poses are computed
    for the batch's devices and bodies only, so memory stays bounded on a line of robots.

    Returns
    -------
    dm, M1, M2 : ndarray, shape (n,)
        Signed midpoint distance [m] and the halves' motion bounds [m].
    """
    world, bodies = run.world, run.model.bodies
    ta, tb, tm = items["ta"][rows], items["tb"][rows], tm[rows]
    p = items["p"][rows]
    n = len(tm)
    involved = np.unique(pairs[p])
    # only the devices that move these bodies
    columns = np.flatnonzero(levers.arm[involved].any(axis=0))
    st = run.states(np.concatenate([ta, tm, tb]), sorted({levers.joints[c][0] for c in columns}))
    q_mid = {d: v[0][n : 2 * n] for d, v in st.items()}
    mid_poses = _poses(world, [bodies[b] for b in involved], q_mid)
    slot = np.searchsorted(involved, pairs[p])  # (n, 2): each pair's bodies among involved
    every = np.arange(n)
    I2, J2 = pairs[p, 0], pairs[p, 1]
    lo = {d: (v[0][:n], v[1][:n], v[2][:n]) for d, v in st.items()}
    mi = {d: (v[0][n : 2 * n], v[1][n : 2 * n], v[2][n : 2 * n]) for d, v in st.items()}
    hi = {d: (v[0][2 * n :], v[1][2 * n :], v[2][2 * n :]) for d, v in st.items()}
    W = weights.take(p).dense(columns)
    M1 = np.einsum("nl,nl->n", W, levers.travel(lo, mi, tm - ta, columns))
    M2 = np.einsum("nl,nl->n", W, levers.travel(mi, hi, tb - tm, columns))
    within = _within(np.maximum(M1, M2), 0.0, run.clearance)
    res = distances(
        bodies,
        I2,
        J2,
        mid_poses[slot[:, 0], every],
        mid_poses[slot[:, 1], every],
        SWEEP_ITERATIONS,
        within,
        exact_above=run.tolerance,
    )
    dm = _signed(res, within)
    for r in _reportable(res, run.tolerance, run.clearance):
        run.found.append(_finding(I2[r], J2[r], float(tm[r]), res, r, True, run.tolerance))
    return dm, M1, M2


def _unresolved(items, pairs, found) -> None:
    """Intervals still open when the refinement stops: reported as possible contacts."""
    for p, ta, tb in zip(items["p"], items["ta"], items["tb"]):
        i, j = pairs[p]
        found.append(
            (
                int(i),
                int(j),
                float(0.5 * (ta + tb)),
                0.0,
                0.0,
                [0.0] * 3,
                [0.0] * 3,
                False,
                True,
                True,
            )
        )


def _within(motion: np.ndarray, watch: float, clearance: float) -> np.ndarray:
    """How far each query's distance must be exact [m]: the watched distance, and the motion
    bound ``motion`` of the intervals it ends plus the clearance.  A farther pair reports
    ``within`` as a lower bound (:func:`_signed`), and an interval with such an end passes
    ``da + db - M >= 2 (c - tol)`` for any other end not reported (``db >= c``, or
    ``>= -tol`` when ``c`` is 0), so no interval is split for want of an exact distance.
    Without the broad phase (the tests' reference) every distance is exact."""
    if not BROAD_PHASE:
        return np.full(np.shape(motion), np.inf)
    return np.maximum(motion + max(clearance, 0.0), max(watch, 0.0))


def _signed(res, within: np.ndarray | float = np.inf) -> np.ndarray:
    """Distance, or minus the penetration depth where the bodies overlap [m]; at most
    ``within``: a query is exact only up to it, and farther reports any value above it (inf,
    or the nearest of the leaf pairs it looked at), so ``within`` is the lower bound there."""
    signed = np.where(res.overlap, -np.maximum(res.depth, 0.0), res.distance)
    return np.minimum(signed, within)


def _reportable(res, tolerance: float, clearance: float) -> np.ndarray:
    """Indices of the states that are collisions (deeper than the tolerance, or buried)
    or closer than the required clearance.
    """
    collide = res.overlap & ((res.depth > tolerance) | res.buried)
    close = (res.distance < clearance) if clearance > 0 else np.zeros_like(collide)
    return np.flatnonzero(collide | close)


def _touch_allows(f: tuple, touch_windows: list) -> bool:
    """A finding within a ``touch:`` window of its pair and no deeper than that window allows
    (a buried body never is)."""
    for t0, t1, pairs in touch_windows:
        allowed = pairs.get((f[0], f[1]))
        if allowed is not None and t0 - 1e-12 <= f[2] <= t1 + 1e-12:
            if not f[9] or (f[4] <= allowed and not f[7]):
                return True
    return False


def _finding(i, j, t: float, res, n: int, between: bool, tolerance: float) -> tuple:
    """(i, j, t, distance, depth, point_a, point_b, buried, between, collision)."""
    collide = bool(res.overlap[n] and (res.depth[n] > tolerance or res.buried[n]))
    return (
        int(i),
        int(j),
        t,
        0.0 if collide else float(res.distance[n]),
        float(res.depth[n]) if collide else 0.0,
        res.point_a[n].tolist(),
        res.point_b[n].tolist(),
        bool(res.buried[n]),
        between,
        collide,
    )


def _poses(world, bodies: list[Body], joints: dict[str, np.ndarray]) -> np.ndarray:
    """``T_world_frame`` of each body's frame at N joint states, shape (B, N, 4, 4)."""
    frames = world.T_world_frames([b.frame for b in bodies], joints)
    return np.stack([frames[b.frame] for b in bodies]) if bodies else np.zeros((0, 0, 4, 4))


def _spans(model: CollisionModel, found: list[tuple], dt: float) -> list[Contact]:
    """Contact instants of each pair merged into spans (gaps of at most 2.5 clock steps)."""
    bodies = model.bodies
    out = []
    by_pair: dict[tuple[int, int], list[tuple]] = {}
    for f in found:
        by_pair.setdefault((f[0], f[1]), []).append(f)
    for (i, j), hits in by_pair.items():
        hits.sort(key=lambda f: f[2])
        groups = [[hits[0]]]
        for f in hits[1:]:
            if f[2] - groups[-1][-1][2] <= 2.5 * dt:
                groups[-1].append(f)
            else:
                groups.append([f])
        for group in groups:
            worst = max(group, key=lambda g: (g[9], g[4], -g[3]))
            out.append(
                Contact(
                    bodies[i].label,
                    bodies[j].label,
                    group[0][2],
                    group[-1][2],
                    worst[2],
                    worst[3],
                    worst[4],
                    worst[5],
                    worst[6],
                    any(g[7] for g in group),
                    all(g[8] for g in group),
                    any(g[9] for g in group),
                )
            )
    out.sort(key=lambda c: (c.t_start, c.a, c.b))
    return out
