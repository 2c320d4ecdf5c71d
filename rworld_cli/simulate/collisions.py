"""Collision and clearance checks of a scheduled run (docs/collision.md).

The scheduler's affixment snapshots split the run into stretches of one tree; the sweep of
:mod:`rworld_cli.collision.sweep` checks each with the devices' own motions (sampled exactly
between clock instants where it refines), and every contact is tied back to the devices, steps
and program lines that were running.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..collision.bodies import collision_model
from ..collision.handling import grasp_gap, rest
from ..collision.sweep import Contact, Interval, sweep
from ..model.cell import WORLD
from ..motion.trajectory import sample_track

REPORT_WITHIN = 0.05  # m: the clearance columns show distances below this (empty above)


@dataclass
class StepRef:
    """A device's program step at an instant."""

    device: str
    step: int  # 0-based
    text: str
    where: str  # file:line

    def as_dict(self) -> dict:
        return {
            "device": self.device,
            "step": self.step + 1,  # 1-based, as in text
            "text": self.text,
            "where": self.where,
        }


@dataclass
class RunContact:
    """A contact (or clearance violation) with the steps that were running when it began."""

    contact: Contact
    steps: list[StepRef]

    def as_dict(self) -> dict:
        return self.contact.as_dict() | {"steps": [s.as_dict() for s in self.steps]}

    def describe(self) -> str:
        c = self.contact
        span = (
            f"at t = {c.t_start:.3f} s"
            if c.t_end - c.t_start < 1e-9
            else f"from t = {c.t_start:.3f} s to {c.t_end:.3f} s"
        )
        mm = lambda p: "(" + ", ".join(f"{1000 * x:.1f}" for x in p) + ") mm"  # noqa: E731
        if c.collision:
            what = (
                f"collision: {c.a} with {c.b} {span}, "
                + (
                    f"buried at least {1000 * c.depth:.1f} mm deep"
                    if c.buried
                    else f"depth {1000 * c.depth:.1f} mm"
                )
                + f" at {mm(c.point_a)}"
            )
        else:
            what = (
                f"clearance: {c.a} and {c.b} {span}, {1000 * c.distance:.1f} mm apart "
                f"(points {mm(c.point_a)} and {mm(c.point_b)})"
            )
        if c.between_samples:
            what += ", between clock samples"
        where = "; ".join(
            f"{s.device} step {s.step + 1} ({s.text}) at {s.where}" for s in self.steps
        )
        return what + (f"; {where}" if where else "")


@dataclass
class HandlingProblem:
    """A grasp of an object that is not at the TCP, or an object set on a support it does not
    rest on (inside it, or floating above it); ``step`` is None for the cell's own initial
    ``rests_on`` affixments."""

    kind: str  # grasp | place | detach_tool | rests_on
    object: str
    t: float
    problem: str  # what is wrong, e.g. "is 20.0 mm deep inside table"
    gap: float  # [m]
    depth: float  # [m]
    step: StepRef | None

    def describe(self) -> str:
        where = (
            f"; {self.step.device} step {self.step.step + 1} ({self.step.text}) at "
            f"{self.step.where}"
            if self.step
            else " (the cell's affixments)"
        )
        return f"{self.kind}: {self.object} {self.problem} at t = {self.t:.3f} s{where}"

    def as_dict(self) -> dict:
        return {
            "kind": self.kind,
            "object": self.object,
            "t": self.t,
            "problem": self.problem,
            "gap": self.gap,
            "depth": self.depth,
            "steps": [self.step.as_dict()] if self.step else [],
        }


@dataclass
class CollisionReport:
    """What the collision check of a run found.

    Attributes
    ----------
    contacts : list of RunContact
        Collisions deeper than ``tolerance`` and clearance violations, in time order.
    clearance : dict
        Device -> (K,) least distance from the device and what it carries to any body they may
        not touch, at the clock's samples [m] (inf: nothing within ``report_within``).
    nearest_steps : list of dict
        Per device step: every pair (of the device's bodies and what it carries with a body
        they may not touch) within ``report_within``, nearest first, each with its least
        distance, instant and closest points.
    unchecked : list of str
        Bodies without geometry (not checked).
    open_meshes : list of str
        Meshes that are not closed solids (their insides are not checked).
    static_overlaps : list of Contact
        Pairs of objects that overlap (or keep less than the clearance) where nothing in the
        run moves either of them nor one against the other (a can set into a shelf's board):
        the cell's geometry, not the run's - one entry a pair, the deepest, never a collision
        of the run (the planner does not count them either).
    """

    tolerance: float
    required_clearance: float
    report_within: float
    contacts: list[RunContact]
    clearance: dict[str, np.ndarray]
    nearest_steps: list[dict]
    unchecked: list[str]
    open_meshes: list[str]
    queries: int = 0
    refinements: int = 0
    first_state: dict | None = None  # the first contact's worst instant: t, snap, joints
    handling: list[HandlingProblem] = field(default_factory=list)
    static_overlaps: list[Contact] = field(default_factory=list)

    @property
    def failed(self) -> bool:
        """A collision, a clearance violation or an impossible grasp or placement."""
        return bool(self.contacts or self.handling)

    @property
    def collisions(self) -> list[RunContact]:
        return [c for c in self.contacts if c.contact.collision]

    @property
    def clearance_violations(self) -> list[RunContact]:
        return [c for c in self.contacts if not c.contact.collision]

    def as_dict(self) -> dict:
        return {
            "tolerance": self.tolerance,
            "required_clearance": self.required_clearance,
            "collisions": [c.as_dict() for c in self.collisions],
            "clearance_violations": [c.as_dict() for c in self.clearance_violations],
            "nearest_per_step": self.nearest_steps,
            "not_checked": self.unchecked,
            "open_meshes": self.open_meshes,
            "handling": [h.as_dict() for h in self.handling],
            "static_overlaps": [c.as_dict() for c in self.static_overlaps],
            "queries": self.queries,
            "refinements": self.refinements,
        }


def check_run(run, sched, times: np.ndarray, report_within: float = REPORT_WITHIN, sampled=None):
    """Collisions and clearance of a scheduled run on its clock ``times`` (K,).

    Parameters
    ----------
    run : Run
        Its ``clearance`` and ``collision_tolerance`` apply.
    sched : the engine's scheduler, after ``run_all`` (tracks, snapshots, world).
    sampled : dict, optional
        Device -> (q, qd, qdd), each (K, n): the states at ``times`` already sampled (the
        engine's timelines), used where the sweep asks for a stretch of the clock.
    """
    cell = run.cell
    model = collision_model(cell)
    end = float(times[-1])

    def states(t, devices=None):
        t = np.asarray(t, dtype=float)
        if sampled is not None and len(t):  # a stretch of the clock: sampled already
            k = int(np.searchsorted(times, t[0]))
            if k + len(t) <= len(times) and np.array_equal(times[k : k + len(t)], t):
                return {
                    d: tuple(x[k : k + len(t)] for x in sampled[d])
                    for d in (cell.devices if devices is None else devices)
                }
        out = {}
        for d in cell.devices if devices is None else devices:
            dev = cell.devices[d]
            if d in sched.tracks:
                tr = sched.tracks[d]
                out[d] = sample_track(tr.segments, tr.q_init, t)
            else:
                n = dev.dof
                out[d] = (
                    np.tile(dev.home, (len(t), 1)),
                    np.zeros((len(t), n)),
                    np.zeros((len(t), n)),
                )
        return out

    snaps = sched.snapshots
    intervals = [
        Interval(t, min(snaps[k + 1][0], end) if k + 1 < len(snaps) else end, snap)
        for k, (t, snap) in enumerate(snaps)
        if t <= end
    ]
    spans = _step_spans(sched, end)
    touches = [
        (
            t0,
            t1,
            d,
            {
                name: run.collision_tolerance if depth is None else max(depth, 0.0)
                for name, depth in step.touch.items()
            },
        )
        for d, t0, t1, step in spans
        if step.kind == "move" and step.touch
    ]
    watch = max(report_within, run.clearance)
    result = sweep(
        sched.world,
        model,
        intervals,
        states,
        times,
        run.collision_tolerance,
        run.clearance,
        touches,
        report_within=watch,
    )
    static = _still_pairs(sched, model, {(c.a, c.b) for c in result.contacts})
    overlaps: dict[tuple[str, str], Contact] = {}
    for c in result.contacts:
        if (c.a, c.b) in static and (
            (c.a, c.b) not in overlaps or c.depth > overlaps[c.a, c.b].depth
        ):
            overlaps[c.a, c.b] = c
    contacts = [
        RunContact(c, _steps_at(sched, spans, c))
        for c in result.contacts
        if (c.a, c.b) not in static
    ]
    clearance, nearest_steps = _clearance_columns(sched, model, result, times, spans)
    first = None
    if contacts:
        c = min(contacts, key=lambda rc: (rc.contact.t_start, not rc.contact.collision)).contact
        snap = [s for ts, s in snaps if ts <= c.t_worst + 1e-12][-1]
        q = {d: v[0][0] for d, v in states([c.t_worst]).items()}
        first = {"t": c.t_worst, "snap": snap, "joints": q, "pair": (c.a, c.b)}
    return CollisionReport(
        run.collision_tolerance,
        run.clearance,
        watch,
        contacts,
        clearance,
        nearest_steps,
        model.unchecked,
        model.open_meshes,
        result.queries,
        result.refinements,
        first,
        _handling(run, sched, model, states),
        sorted(overlaps.values(), key=lambda c: (c.a, c.b)),
    )


def _still_pairs(sched, model, pairs: set[tuple[str, str]]) -> set[tuple[str, str]]:
    """Of ``pairs`` (body labels), those of two objects that hold still against each other the
    whole run: in every affixment state of the run (the scheduler's snapshots) neither hangs
    from a device (a link, a TCP, a held or tool-carried part) and their relative pose is the
    same."""
    bodies = {b.label: b for b in model.bodies}
    world = sched.world
    cell = world.cell
    candidates = {
        (a, b)
        for a, b in pairs
        if bodies[a].owner in cell.objects and bodies[b].owner in cell.objects
    }
    if not candidates:
        return set()
    now = world.snapshot()
    relative: dict[tuple[str, str], np.ndarray] = {}
    moved: set[tuple[str, str]] = set()
    try:
        for _, snap in sched.snapshots:
            world.restore(snap)
            for a, b in candidates - moved:
                fa, fb = bodies[a].frame, bodies[b].frame
                if _on_a_device(world, fa) or _on_a_device(world, fb):
                    moved.add((a, b))
                    continue
                T = np.linalg.solve(world.T_world(fa), world.T_world(fb))
                if (a, b) in relative and not np.allclose(relative[a, b], T, atol=1e-12):
                    moved.add((a, b))
                relative.setdefault((a, b), T)
    finally:
        world.restore(now)
    return candidates - moved


def _on_a_device(world, frame: str) -> bool:
    """Whether ``frame`` hangs, through its parents, from a device (it moves with one)."""
    cell = world.cell
    return any(f in cell.devices or cell.frames[f].kind == "link" for f in world.ancestors(frame))


def _handling(run, sched, model, states) -> list[HandlingProblem]:
    """Every grasp, placement and tool set down checked at its instant (module
    :mod:`rworld_cli.collision.handling`), and the cell's own resting objects at the start."""
    world = sched.world
    tolerance = run.collision_tolerance
    out: list[HandlingProblem] = []
    steps = {d: tr.program.steps for d, tr in sched.tracks.items()}

    def at(t: float, snap: dict) -> None:
        world.restore(snap)
        for d, v in states([t]).items():
            world.set_joints(d, v[0][0])

    at(0.0, sched.snapshots[0][1])
    for aff in world.affixments:
        if aff.type == "non_rigid":
            r = rest(world, model, aff.child, aff.parent)
            problem = r.problem(tolerance) if r else None
            if problem:
                out.append(
                    HandlingProblem("rests_on", aff.child, 0.0, problem, r.gap, r.depth, None)
                )
    changes = [e for e in sched.events if e.tree is not None]
    for event, (_, snap) in zip(changes, sched.snapshots[1:]):
        tree = event.tree
        if event.kind not in ("grasp", "place", "detach_tool") or tree["parent"] is None:
            continue
        at(event.t, snap)
        step = steps[event.device][event.step]
        ref = StepRef(event.device, step.index, step.describe(), step.where)
        child = tree["child"]
        if event.kind == "grasp":
            gap = grasp_gap(world, model, child, tree["parent"])
            if gap > tolerance:
                problem = (
                    f"is {1000 * gap:.1f} mm from the TCP {tree['parent']} (a grasp takes an "
                    f"object within {1000 * tolerance:g} mm of the TCP, the collision tolerance)"
                )
                out.append(HandlingProblem("grasp", child, event.t, problem, gap, 0.0, ref))
            continue
        r = rest(world, model, child, tree["parent"])
        problem = r.problem(tolerance) if r else None
        if problem:
            problem += (
                f" (it must rest on the surface within {1000 * tolerance:g} mm, the collision "
                "tolerance)"
            )
            out.append(HandlingProblem(event.kind, child, event.t, problem, r.gap, r.depth, ref))
    world.restore(sched.snapshots[-1][1])
    return out


def _step_spans(sched, end: float) -> list[tuple]:
    """(device, t0, t1, step) for every step that ran."""
    out = []
    for d, tr in sched.tracks.items():
        starts = tr.step_starts
        for k, (t0, idx) in enumerate(starts):
            if idx < 0:
                continue
            t1 = starts[k + 1][0] if k + 1 < len(starts) else end
            out.append((d, t0, t1, tr.program.steps[idx]))
    return out


def _steps_at(sched, spans, contact: Contact) -> list[StepRef]:
    """The step each device that carries either body was running when the contact began."""
    t = contact.t_start
    world = sched.world
    world.restore([s for ts, s in sched.snapshots if ts <= t + 1e-12][-1])
    owners = [d for d in sched.tracks if {contact.a, contact.b} & set(world.subtree(d))]
    world.restore(sched.snapshots[-1][1])
    running: dict[str, StepRef] = {}
    for d, t0, t1, step in sorted(spans, key=lambda s: s[1]):
        if d in owners and t0 - 1e-12 <= t <= t1 + 1e-12:
            running[d] = StepRef(d, step.index, step.describe(), step.where)  # the latest start
    return [running[d] for d in owners if d in running]


def _clearance_columns(sched, model, result, times, spans):
    """Per device: the least distance from its bodies and what it carries to any body they may
    not touch, per sample; and per device step, every such pair that came within the report
    distance, with its least distance, instant and closest points."""
    world = sched.world
    bodies = model.bodies
    close = result.close
    K = len(times)
    snaps = sched.snapshots
    starts = [int(np.searchsorted(times, t, side="left")) for t, _ in snaps] + [K]
    devices = list(sched.tracks)
    if not devices:
        return {}, []
    index = {d: n for n, d in enumerate(devices)}
    B, D = len(bodies), len(devices)
    # which devices carry each body, per stretch between snapshots (the tree changes there):
    # the devices among the body frame's ancestors, as (stretch, body, device) rows
    rows: list[tuple[int, int, int]] = []
    for k, ((_, snap), a, b) in enumerate(zip(snaps, starts[:-1], starts[1:])):
        if b <= a:
            continue
        world.restore(snap)
        above: dict[str, tuple[int, ...]] = {}

        def carriers(frame: str) -> tuple[int, ...]:
            path = []  # up to a frame already known (iterative: trees may be deep)
            node: str | None = frame
            while node is not None and node != WORLD and node not in above:
                path.append(node)
                node = world.parent(node)
            up = above[node] if node is not None and node in above else ()
            for node in reversed(path):
                up = up + ((index[node],) if node in index else ())
                above[node] = up
            return above[frame]

        rows += [(k, i, n) for i, body in enumerate(bodies) for n in carriers(body.frame)]
    world.restore(snaps[-1][1])
    stretch = np.searchsorted(np.array(starts[1:]), close["sample"], side="right")
    carried = np.array(rows, dtype=np.int64).reshape(-1, 3)
    slot = carried[:, 0] * B + carried[:, 1]  # sorted: stretches, then bodies in order
    first_row = np.searchsorted(slot, np.arange(len(snaps) * B + 1))

    def carried_by(body: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(record, device index) for each device carrying the record's ``body``."""
        at = stretch * B + body
        counts = first_row[at + 1] - first_row[at]
        record = np.repeat(np.arange(len(at)), counts)
        offset = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        return record, carried[np.repeat(first_row[at], counts) + offset, 2]

    # (record, device) for every record of a body the device carries, each pair once
    ra, da = carried_by(close["a"])
    rb, db = carried_by(close["b"])
    code = np.sort(np.concatenate([ra, rb]) * D + np.concatenate([da, db]))
    repeated = np.zeros(len(code), dtype=bool)  # each once (np.unique hashes: 4x slower here)
    repeated[1:] = code[1:] == code[:-1]
    code = code[~repeated]
    r_of, d_of = code // D, code % D
    table = np.full((len(devices), K), np.inf)
    np.minimum.at(table, (d_of, close["sample"][r_of]), close["distance"][r_of])
    columns = dict(zip(devices, table))
    steps = []
    t = times[close["sample"]]
    # each device's records nearest first (ties in record order): the first of each pair is
    # its least distance
    order = np.lexsort((r_of, close["distance"][r_of], d_of))
    bounds = np.searchsorted(d_of[order], np.arange(len(devices) + 1))
    ranked = {d: r_of[order[bounds[k] : bounds[k + 1]]] for k, d in enumerate(devices)}
    for d, t0, t1, step in spans:
        mine = ranked[d]
        sel = mine[(t[mine] >= t0 - 1e-12) & (t[mine] <= t1 + 1e-12)]
        if not len(sel):
            continue
        # each pair once, at its first (least) record: pairs as one integer each
        _, first = np.unique(close["a"][sel] * len(bodies) + close["b"][sel], return_index=True)
        pairs = sel[np.sort(first)]
        steps.append(
            {
                "device": d,
                "step": step.index + 1,
                "text": step.describe(),
                "where": step.where,
                "pairs": [
                    {
                        "a": bodies[close["a"][k]].label,
                        "b": bodies[close["b"][k]].label,
                        "distance": float(close["distance"][k]),
                        "t": float(times[close["sample"][k]]),
                        "point_a": close["point_a"][k].tolist(),
                        "point_b": close["point_b"][k].tolist(),
                    }
                    for k in pairs
                ],
            }
        )
    return columns, steps
