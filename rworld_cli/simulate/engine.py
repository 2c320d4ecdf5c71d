"""Run programs of several devices on one clock (the report's section 5).

Two phases:

1. **Scheduling** - the *device checker*.  Every device with a program is
   running, waiting (at a sync or for another device) or done.  The checker
   always advances the running device whose clock is earliest, so steps
   happen in time order across devices: a move is planned from the world
   as it is at its start (where carriers and tools are then), an affixment
   change (grasp, release, place, tool change) takes effect at its time.
   Syncs are barriers: the k-th ``sync: name`` of every program that has
   one meets the others; all leave at the latest arrival.  ``wait: {for: X}``
   is a serial dependency.  Devices that finish leave parallel operation.
2. **The time-step controller** - every device is sampled on one uniform
   clock ``t = 0, dt, 2 dt, ...`` (vectorised per device).  Per interval of
   constant affixment tree: world poses of bases and TCPs, the loads each
   link carries (grasped objects, aggregated devices), gravity plus the
   base's own acceleration (a robot on a conveyor), and the joint torques by
   batched Newton-Euler.  Then the limits are checked.
"""

from __future__ import annotations

import numpy as np

from ..errors import UserError
from ..model.program import ResolvedStep, Run, Step
from ..world.tree import World
from .affixment_steps import AffixmentSteps
from .contact_steps import ContactSteps
from .coordination_steps import CoordinationSteps
from .errors import SimulationError, UnreachableTarget
from .feature_steps import FeatureSteps
from .motion_steps import MotionSteps
from .sampling import _sample
from .timeline import DeviceTimeline, Event, SimulationResult, Track, Violation

__all__ = [
    "DeviceTimeline",
    "Event",
    "SimulationError",
    "SimulationResult",
    "Violation",
    "simulate",
]


class _Scheduler(MotionSteps, ContactSteps, AffixmentSteps, CoordinationSteps, FeatureSteps):
    def __init__(self, run: Run):
        self.run = run
        self.world = World(run.cell)
        self.order = [p.device for p in run.programs]
        self.rank = {d: n for n, d in enumerate(self.order)}  # ties go to the run file's order
        self.tracks = {p.device: Track(p, q_init=self.world.joints(p.device)) for p in run.programs}
        self.events: list[Event] = []
        self.resolved: dict[str, list[ResolvedStep]] = {d: [] for d in self.order}
        self._actions: list[ResolvedStep] = []  # what the running step did, in order
        self._latched: dict[str, dict | None] = {}  # per device: the last guarded contact
        self._collisions = None  # the collision model, built by the first 'path: free' move
        self._in_free_path = False  # recording a free path's via moves
        self._transit = False  # a feature step's transit: planned around what is in the way
        self._transit_near = None  # its goal's joints, as the step planned them
        self._free_leg = ""  # the leg recorded (for its event)
        self.snapshots: list[tuple[float, dict]] = [(0.0, self.world.snapshot())]
        self.barriers: dict[tuple[str, int], dict[str, float]] = {}
        self.sync_totals = {d: {} for d in self.order}
        for prog in run.programs:
            for st in prog.steps:
                if st.kind == "sync":
                    self.sync_totals[prog.device][st.spec] = (
                        self.sync_totals[prog.device].get(st.spec, 0) + 1
                    )

    # ------------------------------------------------------------ world at a time
    def q_at(self, device: str, t: float) -> np.ndarray:
        track = self.tracks[device]
        for seg in reversed(track.segments):  # time-ordered; the asked time is usually late
            if t >= seg.t1:
                return seg.q_end
            if t >= seg.t0:
                return seg.sample(np.array([t]))[0][0]
        return track.q_init

    def q_over(self, device: str, times: np.ndarray) -> np.ndarray:
        """:meth:`q_at` at N instants ``times`` (N,): the joints (N, n), by segment."""
        track = self.tracks[device]
        out = np.tile(np.asarray(track.q_init, dtype=float), (len(times), 1))
        for seg in track.segments:  # time-ordered: later segments overwrite what follows
            out[times >= seg.t1] = seg.q_end
            during = np.flatnonzero((times >= seg.t0) & (times < seg.t1))
            if len(during):
                out[during] = seg.sample(times[during])[0]
        return out

    def set_time(self, t: float) -> None:
        """Every device at instant ``t``: each device's joints are sampled when first needed
        (a step of one robot in a line of many reads one or two devices, not all)."""
        self.world.defer_joints(list(self.tracks), lambda device: self.q_at(device, t))

    def fail(self, device: str, step: Step, message: str):
        raise SimulationError(
            f"{step.where}: {device} step {step.index + 1} ({step.describe()}): {message}"
        )

    def warn(self, device: str, tr, step: Step, message: str) -> None:
        """A warning event at the step: what the step found questionable, said when it runs."""
        self.events.append(Event(tr.t, device, step.index, "warning", message))

    def _too_long(self, device: str, step: Step, detail: str, speed) -> None:
        """Work beyond the documented bound (``units.MAX_SAMPLES``): exit 2, naming the
        numbers that caused it."""
        raise UserError(
            f"{step.where}: {device} step {step.index + 1} ({step.describe()}): at speed "
            f"{speed:g} {detail} (docs/simulation.md): raise the speed or the clock step (dt)"
        )

    def unreachable(self, device: str, step: Step, message: str):
        """A target the device cannot reach: the check fails (exit 1), with the step."""
        raise UnreachableTarget(
            f"{step.where}: {device} step {step.index + 1} ({step.describe()}): {message}"
        )

    # ------------------------------------------------------------ the device checker
    def run_all(self) -> None:
        while True:
            running = [d for d in self.order if self.tracks[d].status == "running"]
            if not running:
                waiting = [d for d in self.order if self.tracks[d].status == "waiting"]
                if not waiting:
                    return
                lines = []
                for d in waiting:
                    tr = self.tracks[d]
                    st = tr.program.steps[tr.pc]
                    lines.append(
                        f"{d} at step {st.index + 1} ({st.describe()}, {st.where}) since t = "
                        f"{tr.t:.3f} s"
                    )
                raise SimulationError(
                    "deadlock: the programs wait for each other: " + "; ".join(lines)
                )
            device = min(running, key=lambda d: (self.tracks[d].t, self.rank[d]))
            self.advance(device)

    def advance(self, device: str) -> None:
        tr = self.tracks[device]
        if tr.pc >= len(tr.program.steps):
            self.finish(device)
            return
        step = tr.program.steps[tr.pc]
        self.set_time(tr.t)
        tr.step_starts.append((tr.t, step.index))
        t0, self._actions = tr.t, []
        done = STEP_METHODS[step.kind](self, device, tr, step)
        # a step that recorded no action of its own (a wait, a sync) is one entry; a feature
        # step may move, let go and record several times
        self.resolved[device] += self._actions or [ResolvedStep(step, t0, None)]
        if done:  # the step completed, go on
            tr.pc += 1
            if tr.pc >= len(tr.program.steps):
                self.finish(device)

    def finish(self, device: str) -> None:
        tr = self.tracks[device]
        tr.status, tr.end = "done", tr.t
        tr.step_starts.append((tr.t, -1))
        self.events.append(Event(tr.t, device, None, "done", f"{device} finished its program"))
        for other in self.order:  # serial dependencies on this device
            o = self.tracks[other]
            if o.status == "waiting" and o.waiting_on == ("device", device):
                o.t = max(o.t, tr.t)
                o.status, o.waiting_on = "running", None
                o.pc += 1
                if o.pc >= len(o.program.steps):
                    self.finish(other)

    # ------------------------------------------------------------ steps
    def _resolve_tcp(self, device: str, name: str | None) -> str:
        tcp = name or self.world.active_tcp(device)
        if tcp not in self.run.cell.frames and f"{device}.{tcp}" in self.run.cell.frames:
            tcp = f"{device}.{tcp}"
        return tcp


# every step kind and the method that runs it, one module per family of steps (each a mixin of
# the scheduler): a new step kind is its method in one of them, or a new module, and a line here
STEP_METHODS = {
    "move": MotionSteps._move,
    "probe": ContactSteps._probe,
    "sense": ContactSteps._sense,
    "capture": ContactSteps._capture,
    "grasp": AffixmentSteps._grasp,
    "release": AffixmentSteps._release,
    "place": AffixmentSteps._place,
    "attach_tool": AffixmentSteps._attach_tool,
    "detach_tool": AffixmentSteps._detach_tool,
    "insert": FeatureSteps._insert,
    "follow": FeatureSteps._follow,
    "wait": CoordinationSteps._wait,
    "sync": CoordinationSteps._sync,
}


def simulate(
    run: Run, progress=None, collisions: bool = True, payload: bool = False, report: bool = True
) -> SimulationResult:
    """Schedule and sample a run; see the module docstring.

    Parameters
    ----------
    run : Run
        From :func:`rworld_cli.schema.programs.load_run`.
    progress : callable, optional
        ``progress(done, total, what)`` for long runs (the CLI draws a bar).
    collisions : bool
        Check collisions and clearance along the run (``run.clearance``,
        ``run.collision_tolerance``; docs/collision.md).
    payload : bool
        Also find each device's payload capacity along the run
        (:meth:`SimulationResult.payload_capacity`): one more Newton-Euler pass.
    report : bool
        Also measure every pair within :data:`~rworld_cli.simulate.collisions.REPORT_WITHIN`
        at every sample: the clearance columns and the nearest pairs per step of simulate's
        outputs and the viewer.  False: only what decides the check (its contacts, the same
        with the same guarantee; a check, which prints none of the distances, asks only that).

    Raises
    ------
    SimulationError
        Unreachable targets, singular or infeasible linear moves, impossible
        grasps or releases, deadlocks - naming device, step and cause (exit 2).
    """
    sched = _Scheduler(run)
    sched.run_all()
    result, sampled = _sample(run, sched, progress, payload)
    if collisions:
        from .collisions import check_run

        if progress:
            progress(0, None, "collisions")
        from .collisions import REPORT_WITHIN

        within = REPORT_WITHIN if report else 0.0
        result.collisions = check_run(run, sched, result.times, within, sampled=sampled)
    return result
