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
    touches : iterable of (t0, t1, device, names)
        ``touch:`` steps: the device's bodies may touch the named ones during [t0, t1].
    report_within : float
        Also record every pair closer than this at the clock's samples [m] (``close``).
    """
    run = _Sweep(world, model, states, clock, tolerance, clearance, report_within)
    found, close, touch_windows, stats = run.found, run.close, run.touch_windows, run.stats
    for iv in intervals:
        world.restore(iv.snap)
        for t0, t1, device, names in touches:
            if t1 < iv.t0 or t0 > iv.t1:
                continue
            mine, named = touch_bodies(world, model, device, names)
            pairs = {(min(a, b), max(a, b)) for a in mine for b in named if a != b}
            touch_windows.append((max(t0, iv.t0), min(t1, iv.t1), pairs))
        _sweep_interval(run, iv)
    if intervals:
        world.restore(intervals[-1].snap)
    kept = [
        f
        for f in found
        if not any(
            t0 - 1e-12 <= f[2] <= t1 + 1e-12 and (f[0], f[1]) in p for t0, t1, p in touch_windows
        )
    ]
    dt = float(np.min(np.diff(clock))) if len(clock) > 1 else 1.0
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
    touch_windows: list = field(default_factory=list)  # (t0, t1, set of allowed pairs)
    stats: dict = field(default_factory=lambda: {"queries": 0, "refinements": 0})

    @property
    def index_of(self) -> dict[float, int]:
        return {float(t): k for k, t in enumerate(self.clock)}


def _sweep_interval(run: _Sweep, iv: Interval) -> None:
    """Check one stretch of one affixment tree (module docstring), adding to ``run``."""
    world, model, states, clock = run.world, run.model, run.states, run.clock
    tolerance, clearance, report_within = run.tolerance, run.clearance, run.report_within
    found, close, touch_windows, stats = run.found, run.close, run.touch_windows, run.stats
    index_of = run.index_of
    bodies = model.bodies
    B = len(bodies)
    inside = clock[(clock > iv.t0) & (clock < iv.t1)]
    times = np.unique(np.concatenate([[iv.t0], inside, [iv.t1]]))
    K = len(times)
    joints = states(times)
    poses = _poses(world, bodies, {d: v[0] for d, v in joints.items()})  # (B, K, 4, 4)
    levers = [_levers(world, b, joints) for b in bodies]
    contributions = _contributions(
        levers, joints, joints, times[:-1], times[1:], slice(0, K - 1), slice(1, K)
    )
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
    M = _relative_motion(contributions, I, J, K - 1)  # (P, K-1)
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
    for n in _reportable(res, tolerance, clearance):
        p, t = qp[n], float(times[qk[n]])
        found.append(_finding(I[p], J[p], t, res, n, t not in index_of, tolerance))
        if static[p]:  # a pair that does not move: the same for the whole interval
            found.append(found[-1][:2] + (float(iv.t1),) + found[-1][3:])
    if report_within > 0:
        sample = np.array([index_of.get(float(t), -1) for t in times[qk]], dtype=int)
        keep = (sample >= 0) & (res.distance < report_within)
        for t0, t1, tp in touch_windows:  # touching is the point of those steps
            during = (times[qk] >= t0) & (times[qk] <= t1)
            if during.any():
                keep &= ~(during & np.array([(int(i), int(j)) in tp for i, j in zip(I[qp], J[qp])]))
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
        M1 = _pair_motion(levers, I2, J2, lo, mi, items["ta"], tm)
        M2 = _pair_motion(levers, I2, J2, mi, hi, tm, items["tb"])
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


def _levers(world, body: Body, joints) -> list[tuple[str, int, float, bool, float]]:
    """The joints that move ``body``: (device, joint index, lever r_j [m], prismatic,
    acceleration limit).
    """
    cell = world.cell
    link_of = {f: (d, i) for d, dev in cell.devices.items() for i, f in enumerate(dev.link_frames)}
    reach = float(np.linalg.norm(body.center)) + body.radius  # from the body's frame origin
    out = []
    node = body.frame
    while node is not None and node != WORLD:
        if node in link_of:
            d, i = link_of[node]
            dev = cell.devices[d]
            q = joints[d][0][:, i]
            qs = np.zeros((len(q), dev.dof))
            qs[:, i] = q
            A = dev.joint_transforms(qs)[:, i]
            length = float(np.max(np.linalg.norm(A[:, :3, 3], axis=1)))
            joint = dev.joints[i]
            prismatic = joint.kind == "prismatic"
            if prismatic:  # its extension may grow between samples: add its largest step
                length += float(np.max(np.abs(np.diff(q)), initial=0.0))
            out.append((d, i, reach + abs(joint.a), prismatic, joint.limits.acceleration))
            reach += length
        else:
            reach += float(np.linalg.norm(world.T_parent(node)[:3, 3]))
        node = world.parent(node)
    return out


def _travel(limit: float, qd_a, qd_b, qdd_a, qdd_b, h) -> np.ndarray:
    """Bound on a joint's travel over intervals of length h (module docstring)."""
    A = np.maximum(np.abs(qdd_a), np.abs(qdd_b))
    if np.isfinite(limit):
        A = np.maximum(A, limit)
    return h * (np.abs(qd_a) + np.abs(qd_b)) / 2 + A * h * h / 4


def _contributions(levers, ja, jb, ta, tb, sa, sb) -> list[dict]:
    """Per body, joint (device, index) -> its share of the body's motion bound over the
    intervals [ta, tb] [m] (module docstring).
    """
    h = np.asarray(tb) - np.asarray(ta)
    out = []
    for lv in levers:
        shares = {}
        for d, j, r, prismatic, limit in lv:
            V = _travel(
                limit, ja[d][1][sa, j], jb[d][1][sb, j], ja[d][2][sa, j], jb[d][2][sb, j], h
            )
            shares[(d, j)] = V * (1.0 if prismatic else r)
        out.append(shares)
    return out


def _relative_motion(shares: list[dict], I, J, n: int) -> np.ndarray:
    """Motion bound of pairs: a joint that moves both bodies moves them as one rigid body and
    leaves their distance alone, so only the joints that move one of them count. (P, n) [m].
    """
    out = np.zeros((len(I), n))
    for p, (i, j) in enumerate(zip(I, J)):
        a, b = shares[i], shares[j]
        for key in a.keys() ^ b.keys():
            out[p] += a[key] if key in a else b[key]
    return out


def _pair_motion(levers, I, J, lo, hi, ta, tb) -> np.ndarray:
    """Motion bound of pairs (I[k], J[k]) over [ta[k], tb[k]] (k-th states in lo and hi)."""
    h = tb - ta
    out = np.zeros(len(I))
    for k_side, (side, other) in enumerate(((I, J), (J, I))):
        for b in np.unique(side):
            rows = np.flatnonzero(side == b)
            for d, j, r, prismatic, limit in levers[b]:
                # shared joints move the pair rigidly: count the joint only where the other
                # body does not depend on it
                mine = np.array([(d, j) not in _keys(levers[o]) for o in other[rows]])
                if not mine.any():
                    continue
                rr = rows[mine]
                V = _travel(
                    limit, lo[d][1][rr, j], hi[d][1][rr, j], lo[d][2][rr, j], hi[d][2][rr, j], h[rr]
                )
                out[rr] += V * (1.0 if prismatic else r)
    return out


def _keys(lv) -> set:
    return {(d, j) for d, j, *_ in lv}


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
