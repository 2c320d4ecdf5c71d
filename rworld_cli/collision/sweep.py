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
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..model.cell import WORLD
from .allowed import allowed_pairs, touch_bodies
from .bodies import Body, CollisionModel, distances

MAX_SPLITS = 40  # bisections of one sample interval; 2^-40 of 10 ms is 1e-14 s
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
        ``states(times) -> {device: (q, qd, qdd)}`` each (N, n), SI, for every device.
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
    states: Callable[[np.ndarray], dict]
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
    """Check one stretch of one affixment tree (module docstring), adding to ``run``."""
    world, model, states, clock = run.world, run.model, run.states, run.clock
    tolerance, clearance, report_within = run.tolerance, run.clearance, run.report_within
    found, close, touch_windows, stats = run.found, run.close, run.touch_windows, run.stats
    bodies = model.bodies
    B = len(bodies)
    inside = clock[(clock > iv.t0) & (clock < iv.t1)]
    times = np.unique(np.concatenate([[iv.t0], inside, [iv.t1]]))
    K = len(times)
    joints = states(times)
    poses = _poses(world, bodies, {d: v[0] for d, v in joints.items()})  # (B, K, 4, 4)
    levers = _Levers.of(world, bodies, joints)
    allowed = allowed_pairs(world, model)
    pairs = np.array(
        [(i, j) for i in range(B) for j in range(i + 1, B) if (i, j) not in allowed],
        dtype=int,
    ).reshape(-1, 2)
    if not len(pairs):
        return
    centres = np.einsum("bkij,bj->bki", poses[:, :, :3, :3], np.stack([b.center for b in bodies]))
    centres += poses[:, :, :3, 3]
    radius = np.array([b.radius for b in bodies])
    I, J = pairs[:, 0], pairs[:, 1]
    # lower bounds on every pair's distance: bounding spheres, and each bounding sphere
    # against the other body's bounding box (a long rail's sphere alone tells little)
    lower = (
        np.linalg.norm(centres[I] - centres[J], axis=2) - radius[I, None] - radius[J, None]
    )  # (P, K)
    T_box = poses @ np.stack([b.shape.bounding_box.T_owner_box for b in bodies])[:, None]
    half = np.stack([b.shape.bounding_box.half_extents for b in bodies])
    for a, c in ((I, J), (J, I)):
        local = np.einsum("pkji,pkj->pki", T_box[a, :, :3, :3], centres[c] - T_box[a, :, :3, 3])
        outside = np.linalg.norm(np.maximum(np.abs(local) - half[a, None, :], 0.0), axis=2)
        lower = np.maximum(lower, outside - radius[c, None])
    slack = 2.0 * (clearance - tolerance)
    weights = levers.pair_weights(I, J)  # (P, L)
    before = {d: tuple(x[:-1] for x in v) for d, v in joints.items()}
    after = {d: tuple(x[1:] for x in v) for d, v in joints.items()}
    M = weights @ levers.travel(before, after, np.diff(times)).T  # (P, K-1) motion bounds
    static = ~np.any(M > 0, axis=1)  # the pair moves, if at all, as one rigid body
    if K > 1:
        need_interval = lower[:, :-1] + lower[:, 1:] - M < slack
        need_interval[static] = False
    else:
        need_interval = np.zeros((len(pairs), 0), dtype=bool)
    watch = max(clearance, report_within)
    need_sample = lower < watch if watch > 0 else lower <= 0
    need_sample[:, 1:] |= need_interval
    need_sample[:, :-1] |= need_interval
    need_sample[static, 1:] = False  # a pair that does not move: its first state tells all
    exact = np.full(lower.shape, np.nan)  # signed: distance, or minus the penetration depth
    qp, qk = np.nonzero(need_sample)
    res = distances(bodies, I[qp], J[qp], poses[I[qp], qk], poses[J[qp], qk], SWEEP_ITERATIONS)
    stats["queries"] += len(qp)
    exact[qp, qk] = _signed(res)
    sample = run.sample_index(times[qk])
    for n in _reportable(res, tolerance, clearance):
        p, t = qp[n], float(times[qk[n]])
        found.append(_finding(I[p], J[p], t, res, n, sample[n] < 0, tolerance))
        if static[p]:  # a pair that does not move: the same for the whole interval
            found.append(found[-1][:2] + (float(iv.t1),) + found[-1][3:])
    if report_within > 0:
        keep = (sample >= 0) & (res.distance < report_within)
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
    if K == 1:
        return
    # intervals whose exact end distances still do not pass: bisect them
    da, db = exact[:, :-1], exact[:, 1:]
    fail = need_interval & ~np.isnan(da) & ~np.isnan(db)
    # an end that is already reported (a collision, or closer than the clearance) ends the search
    floor = clearance if clearance > 0 else -tolerance
    fail &= (da >= floor) & (db >= floor)
    fail &= da + db - M < slack
    p_idx, k_idx = np.nonzero(fail)
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
        tm = 0.5 * (items["ta"] + items["tb"])
        n = len(tm)
        stats["refinements"] += n
        all_t = np.concatenate([items["ta"], tm, items["tb"]])
        st = states(all_t)
        q_mid = {d: v[0][n : 2 * n] for d, v in st.items()}
        involved = np.unique(pairs[items["p"]])
        mid_poses = _poses(world, [bodies[b] for b in involved], q_mid)
        slot = {int(b): s for s, b in enumerate(involved)}
        I2, J2 = pairs[items["p"], 0], pairs[items["p"], 1]
        sI = np.array([slot[int(b)] for b in I2], dtype=int)
        sJ = np.array([slot[int(b)] for b in J2], dtype=int)
        rows = np.arange(n)
        res = distances(bodies, I2, J2, mid_poses[sI, rows], mid_poses[sJ, rows], SWEEP_ITERATIONS)
        stats["queries"] += n
        dm = _signed(res)
        for r in _reportable(res, tolerance, clearance):
            found.append(_finding(I2[r], J2[r], float(tm[r]), res, r, True, tolerance))
        # the two halves, with motion bounds from the states at their ends
        lo = {d: (v[0][:n], v[1][:n], v[2][:n]) for d, v in st.items()}
        mi = {d: (v[0][n : 2 * n], v[1][n : 2 * n], v[2][n : 2 * n]) for d, v in st.items()}
        hi = {d: (v[0][2 * n :], v[1][2 * n :], v[2][2 * n :]) for d, v in st.items()}
        W = weights[items["p"]]
        M1 = np.einsum("nl,nl->n", W, levers.travel(lo, mi, tm - items["ta"]))
        M2 = np.einsum("nl,nl->n", W, levers.travel(mi, hi, items["tb"] - tm))
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


def _signed(res) -> np.ndarray:
    """Distance, or minus the penetration depth where the bodies overlap [m]."""
    return np.where(res.overlap, -np.maximum(res.depth, 0.0), res.distance)


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


@dataclass
class _Levers:
    """Which joints move each body, and by how much at most (module docstring).

    Attributes
    ----------
    joints : list of (device, joint index)
        The L joints that move any body.
    limits : ndarray, shape (L,)
        Their acceleration limits (inf: none).
    arm : ndarray, shape (B, L)
        Bound on the distance from each joint's axis to each body [m]; 1 for a prismatic joint
        (it moves the body by its own travel); 0 where the joint does not move the body.
    """

    joints: list[tuple[str, int]]
    limits: np.ndarray
    arm: np.ndarray

    @classmethod
    def of(cls, world, bodies: list[Body], joints: dict) -> _Levers:
        """The levers of ``bodies`` in the world's tree, for the joint samples ``joints``
        (device -> (q, qd, qdd), each (K, n)) of one stretch."""
        cell = world.cell
        link_of = {
            f: (d, i) for d, dev in cell.devices.items() for i, f in enumerate(dev.link_frames)
        }
        # each link frame's offset from its parent frame, at its longest over the samples; a
        # prismatic joint may extend further between samples: add its largest step
        length = {}
        for d, dev in cell.devices.items():
            q = joints[d][0]
            norms = np.linalg.norm(dev.joint_transforms(q)[..., :3, 3], axis=-1).max(axis=0)
            steps = np.abs(np.diff(q, axis=0)).max(axis=0, initial=0.0)
            prismatic = np.array([j.kind == "prismatic" for j in dev.joints])
            for i, f in enumerate(dev.link_frames):
                length[f] = float(norms[i] + (steps[i] if prismatic[i] else 0.0))
        columns: dict[tuple[str, int], int] = {}
        arms: list[dict[int, float]] = []
        for body in bodies:
            reach = float(np.linalg.norm(body.center)) + body.radius  # from the body's frame
            arm: dict[int, float] = {}
            node = body.frame
            while node is not None and node != WORLD:
                if node in link_of:
                    d, i = link_of[node]
                    joint = cell.devices[d].joints[i]
                    column = columns.setdefault((d, i), len(columns))
                    arm[column] = 1.0 if joint.kind == "prismatic" else reach + abs(joint.a)
                    reach += length[node]
                else:
                    reach += float(np.linalg.norm(world.T_parent(node)[:3, 3]))
                node = world.parent(node)
            arms.append(arm)
        table = np.zeros((len(bodies), len(columns)))
        for b, arm in enumerate(arms):
            for column, r in arm.items():
                table[b, column] = r
        keys = list(columns)
        limits = np.array([cell.devices[d].joints[i].limits.acceleration for d, i in keys])
        return cls(keys, limits, table)

    def travel(self, lo: dict, hi: dict, h: np.ndarray) -> np.ndarray:
        """Bound on each joint's travel over N intervals of length ``h`` (N,), from the states
        at their ends (device -> (q, qd, qdd), each (N, n)): shape (N, L) [rad or m].

        ``h (|qd_a| + |qd_b|) / 2 + A h^2 / 4``, A the acceleration limit or, when larger, the
        acceleration at either end.
        """
        h = np.asarray(h, dtype=float)
        out = np.zeros((len(h), len(self.joints)))
        for column, (d, j) in enumerate(self.joints):
            qd_a, qd_b = lo[d][1][:, j], hi[d][1][:, j]
            A = np.maximum(np.abs(lo[d][2][:, j]), np.abs(hi[d][2][:, j]))
            if np.isfinite(self.limits[column]):
                A = np.maximum(A, self.limits[column])
            out[:, column] = h * (np.abs(qd_a) + np.abs(qd_b)) / 2 + A * h * h / 4
        return out

    def pair_weights(self, I: np.ndarray, J: np.ndarray) -> np.ndarray:
        """Per pair (I[p], J[p]) and joint, the lever that counts for their distance: a joint
        that moves both bodies moves them as one rigid body and leaves their distance alone.
        Shape (P, L); the pairs' motion bound is this times the joints' travel."""
        a, b = self.arm[I], self.arm[J]
        return np.where(b > 0, 0.0, a) + np.where(a > 0, 0.0, b)


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
