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

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..dynamics import DeviceDynamics, Payload
from ..errors import UserError
from ..kinematics.configuration import arm_configurations, is_arm, vendor_words
from ..kinematics.inverse import solve_ik, solve_ik_soonest
from ..kinematics.jacobian import ToolMount, tool_pose
from ..model.program import BlendZone, MoveTarget, Program, ResolvedStep, Run, Step
from ..motion.linear import PathError, linear_move
from ..motion.trajectory import StoppedMove, UntimedMove, joint_move, sample_track
from ..units import MAX_SAMPLES
from ..world.tree import AffixmentError, World
from .errors import NoFreePath, SimulationError, UnreachableTarget
from .feature_steps import FeatureSteps

IK_STARTS = 24  # seeded IK starts for a target's other joint solutions (a blocked move)
PATH_START_TOLERANCE = 1e-6  # [rad or m] a path file's first waypoint against the joints
FREE_PATH_TIMEOUT = 10.0  # [s] a 'path: free' move's search gives up after this
LATCH_TIME = 1e-9  # [s]: a guarded move's contact instant is found to this (a probe's latch)


@dataclass
class Event:
    t: float
    device: str
    step: int | None
    kind: str
    detail: str
    tree: dict | None = None  # affixment change: child, parent (None when detached), type, kind
    reading: dict | None = None  # sense steps and guarded moves: the sensor reading

    def as_dict(self) -> dict:
        return {
            "t": self.t,
            "device": self.device,
            "step": None if self.step is None else self.step + 1,  # 1-based, as in text
            "kind": self.kind,
            "detail": self.detail,
            "tree": self.tree,
            "reading": self.reading,
        }


@dataclass
class Violation:
    """A limit exceeded on ``[t_start, t_end]``; ``peak`` is the worst value, ``limit`` the
    bound.
    """

    device: str
    joint: str
    kind: str  # position | velocity | acceleration | torque
    t_start: float
    t_end: float
    peak: float
    limit: float
    step: int | None
    step_text: str

    def as_dict(self) -> dict:
        return {
            k: getattr(self, k)
            for k in (
                "device",
                "joint",
                "kind",
                "t_start",
                "t_end",
                "peak",
                "limit",
                "step_text",
            )
        } | {"step": None if self.step is None else self.step + 1}  # 1-based, as in text

    def describe(self) -> str:
        where = f"step {self.step + 1} ({self.step_text})" if self.step is not None else "at rest"
        return (
            f"{self.device} {self.joint}: {self.kind} {self.peak:.4g} beyond its limit "
            f"{self.limit:.4g} "
            f"from t = {self.t_start:.3f} s to {self.t_end:.3f} s, {where}"
        )


@dataclass
class DeviceTimeline:
    """One device on the uniform clock (SI).

    Attributes
    ----------
    q, qd, qdd, tau : ndarray, shape (K, n)
    tcp : ndarray, shape (K, 4, 4)
        ``T_world_tcp`` of the active TCP.
    step : ndarray of int, shape (K,)
        Index of the program step running at each sample (-1: none).
    ratios : dict
        'velocity' | 'acceleration' | 'torque' -> ndarray (K, n) of |value| / limit (NaN for
        a joint without that limit).
    cycle_time : float
        When the device's program ended [s].
    torque_per_kg : ndarray, shape (K, n), optional
        What 1 kg more at the active TCP's origin adds to ``tau`` [N m / kg] (torque is affine
        in a point mass); computed when :func:`simulate` is asked for payload capacity.
    """

    device: str
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    tcp: np.ndarray
    step: np.ndarray
    ratios: dict
    cycle_time: float
    tcp_names: list = field(default_factory=list)
    torque_per_kg: np.ndarray | None = None
    payload: dict | None = None  # SimulationResult.payload_capacity


@dataclass
class SimulationResult:
    cell: str
    run: str
    dt: float
    times: np.ndarray
    devices: dict[str, DeviceTimeline]
    events: list[Event]
    violations: list[Violation]
    step_texts: dict[str, list[str]]
    unlimited: dict[str, dict[str, list[str]]] = field(
        default_factory=dict
    )  # device -> kind -> joints with no limit
    collisions: Any = None  # simulate.collisions.CollisionReport, or None when not checked
    resolved: dict[str, list[ResolvedStep]] = field(default_factory=dict)  # device -> steps
    step_where: dict[str, list[str]] = field(default_factory=dict)  # device -> 'file:line' per step
    massless: list[str] = field(default_factory=list)  # devices whose links have no mass at all
    # (t, World.snapshot()) at the start and after every affixment change: the tree each stretch
    # of samples ran in (a sample at t belongs to the latest snapshot at or before it)
    snapshots: list[tuple[float, dict]] = field(default_factory=list)

    @property
    def cycle_time(self) -> float:
        """When the last program ended [s]."""
        return max((tl.cycle_time for tl in self.devices.values()), default=0.0)

    @property
    def ok(self) -> bool:
        """No limit violation, no collision, no clearance violation, no impossible handling."""
        return not self.violations and not (self.collisions and self.collisions.failed)

    def peak_ratios(self, device: str) -> dict[str, list[float]]:
        """Per kind, each joint's largest ratio to its limit (NaN: the joint has no limit)."""
        out = {}
        for k, v in self.devices[device].ratios.items():
            if not len(v):
                out[k] = []
                continue
            peak = np.max(np.where(np.isnan(v), -np.inf, v), axis=0)
            out[k] = np.where(np.isfinite(peak), peak, np.nan).tolist()
        return out

    def payload_capacity(self, device: str) -> dict | None:
        """The largest point mass [kg] the device could carry more at its active TCP's origin
        through the whole run with every torque within its limit: ``plan payload`` on the run's
        motion, exact (torque is affine in the mass); what the run carries it carries in any case.

        Returns ``{"mass": kg, "joint": name, "t": s, "side": "upper" | "lower"}`` (the mass is
        negative when the run already overloads a joint a payload loads), or None: simulated
        without ``payload=True``, or no joint with a torque limit feels a payload.
        """
        return self.devices[device].payload


@dataclass
class _Track:
    program: Program
    segments: list = field(default_factory=list)
    q_init: np.ndarray | None = None
    step_starts: list = field(default_factory=list)  # (t, step index)
    t: float = 0.0
    pc: int = 0
    status: str = "running"  # running | waiting | done
    waiting_on: object = None
    sync_counts: dict = field(default_factory=dict)
    end: float | None = None


class _Scheduler(FeatureSteps):
    def __init__(self, run: Run):
        self.run = run
        self.world = World(run.cell)
        self.order = [p.device for p in run.programs]
        self.rank = {d: n for n, d in enumerate(self.order)}  # ties go to the run file's order
        self.tracks = {
            p.device: _Track(p, q_init=self.world.joints(p.device)) for p in run.programs
        }
        self.events: list[Event] = []
        self.resolved: dict[str, list[ResolvedStep]] = {d: [] for d in self.order}
        self._actions: list[ResolvedStep] = []  # what the running step did, in order
        self._latched: dict[str, dict | None] = {}  # per device: the last guarded contact
        self._collisions = None  # the collision model, built by the first 'path: free' move
        self._in_free_path = False  # recording a free path's via moves
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
        handler = getattr(self, f"_{step.kind}")
        t0, self._actions = tr.t, []
        done = handler(device, tr, step)
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

    def _move(self, device: str, tr: _Track, step: Step) -> bool:
        spec = step.spec
        dev = self.run.cell.devices[device]
        q_now = self.world.joints(device)
        if step.waypoints is not None:  # move: {path: FILE}
            way = step.waypoints
            off = np.abs(way[0] - q_now)
            if off.max() > PATH_START_TOLERANCE:
                j = int(np.argmax(off))
                self.fail(
                    device,
                    step,
                    f"the path starts with {dev.joints[j].name} at {way[0][j]:.6g}, and the "
                    f"device is at {q_now[j]:.6g} (SI): a path file is driven from where it "
                    "starts - plan it from the joints this step starts at ('rworld plan path "
                    "--from'), or move there first",
                )
            self._drive_through(
                device,
                tr,
                step,
                np.concatenate([q_now[None], way[1:]]),
                step.spec.path,
                self._resolve_tcp(device, step.spec.tcp),
                None,
                None,
                step.blends,
            )
            return True
        if step.joints is not None:  # move: {joints: [...]}
            seg = self._joint_move(device, tr, step, q_now, step.joints)
            self._record_move(device, tr, step, q_now, seg, seg, "joint values", until=spec.until)
            return True
        if step.goal is None and (spec.to == "home" or spec.to in dev.positions):
            q_goal = dev.home if spec.to == "home" else dev.positions[spec.to]
            seg = self._joint_move(device, tr, step, q_now, q_goal)
            self._record_move(device, tr, step, q_now, seg, seg, spec.to, until=spec.until)
            return True
        tcp = self._resolve_tcp(device, spec.tcp)
        if step.goal is not None:  # a target on a feature: each free spin a candidate
            targets = self._feature_targets(device, step) @ step.T_offset
            name = step.goal.feature
        else:
            targets = (self.world.T_world(spec.to) @ step.T_offset)[None]
            name = spec.to
        self._go(
            device,
            tr,
            step,
            tcp,
            targets,
            spec.motion,
            spec.speed,
            spec.acceleration,
            spec.until,
            name,
        )
        return True

    def _go(
        self,
        device: str,
        tr: _Track,
        step: Step,
        tcp: str,
        T_world_targets: np.ndarray,
        motion: str,
        speed: float,
        acceleration: float,
        until: str | None,
        name: str,
    ):
        """Move ``tcp`` to one of the candidate poses ``T_world_targets`` (S, 4, 4) - the
        first that a joint move reaches nearest in time (or, for a line, the one nearest the
        tool's orientation) - and record it; the segment (None: already there)."""
        dev = self.run.cell.devices[device]
        q_now = self.world.joints(device)
        try:
            mount = ToolMount(*self.world.mount_of(device, tcp))
        except UserError as exc:
            self.fail(device, step, exc.message)
        T_base = np.linalg.inv(self.world.T_world(device)) @ T_world_targets
        position_only = step.spec.position_only if step.kind == "move" else False
        position_only = position_only or dev.dof < 6
        if motion == "joint":
            seg = self._joint_to(
                device,
                tr,
                step,
                dev,
                mount,
                q_now,
                T_base,
                position_only,
                name,
                tcp,
                speed,
                acceleration,
            )
        else:
            if len(T_base) > 1:  # the candidate nearest the tool's orientation now
                R_now = tool_pose(dev, q_now, mount)[:3, :3]
                turn = np.einsum("ij,sij->s", R_now, T_base[:, :3, :3])  # trace(R_now^T R_s)
                T_base = T_base[[int(np.argmax(turn))]]
            try:
                seg = linear_move(
                    dev,
                    mount,
                    tr.t,
                    q_now,
                    T_base[0],
                    self.run.dt,
                    speed,
                    acceleration,
                    position_only,
                )
            except PathError as exc:
                if exc.reason == "samples":  # too slow to simulate: bad input, not a fail
                    self._too_long(device, step, exc.detail, speed)
                self.unreachable(device, step, exc.detail)
            wanted = step.configuration
            if wanted:
                end = seg.q_end if seg is not None else q_now
                have = arm_configurations(dev, end).names()
                if any(have[k] != v for k, v in wanted.items()):
                    self.fail(
                        device,
                        step,
                        f"the line ends with {_said(have)}, not {_said(wanted)}: a straight "
                        "line keeps the configuration it starts in; reach the start with a "
                        "joint move in the configuration wanted",
                    )
        return self._record_move(
            device, tr, step, q_now, seg, seg, name, tcp, until, motion, speed, acceleration
        )

    def _joint_to(
        self,
        device,
        tr,
        step,
        dev,
        mount,
        q_now,
        T_base,
        position_only,
        name,
        tcp,
        speed,
        acceleration,
    ):
        """A joint move to the candidate pose reached soonest (one IK per candidate, the
        step's configuration asked for)."""
        wanted = step.configuration
        accept = None
        if wanted:

            def accept(Q, dev=dev, wanted=wanted):
                return arm_configurations(dev, Q).matches(wanted)

        seed = q_now if step.near is None else step.near
        if step.arm_angle is not None:  # a 7-axis arm's arm angle (config: {arm_angle})
            from ..kinematics.redundancy import solve_ik_arm_angle

            for T in T_base:  # the candidates in their order (a free turn: the first that is)
                held = solve_ik_arm_angle(dev, T, step.arm_angle, mount, seed)
                if held is not None:
                    return self._joint_move(device, tr, step, q_now, held, speed, acceleration)
            self.unreachable(
                device,
                step,
                f"no joint solution within the limits reaches '{name}' with the arm angle "
                f"{np.degrees(step.arm_angle):.6g} deg",
            )
        if len(T_base) == 1:
            result = solve_ik(dev, T_base[0], mount, seed, position_only, accept=accept)
            best = result.q if result.success else None
            if best is not None and step.kind == "move" and not step.touch and step.near is None:
                best = self._clear_solution(
                    device,
                    tr,
                    step,
                    dev,
                    mount,
                    q_now,
                    T_base[0],
                    position_only,
                    best,
                    accept,
                    name,
                )
        else:
            best, result = None, None
            Q, ok, order = solve_ik_soonest(dev, T_base, q_now, mount, position_only, seed, accept)
            if ok.any():
                reached = [int(k) for k in order if ok[k]]
                best = Q[reached[0]]
                if step.goal is not None and not step.touch:  # a free turn: one that is clear
                    best = Q[self._clear_turn(device, tr, step, q_now, Q, reached)]
            else:  # from the joints now no candidate converged: restarts, nearest turn first
                for T in T_base:
                    result = solve_ik(dev, T, mount, seed, position_only, accept=accept)
                    if result.success:
                        best = result.q
                        break
        if best is None:
            if wanted:
                anyhow = solve_ik(dev, T_base[0], mount, seed, position_only)
                if anyhow.success:
                    have = arm_configurations(dev, anyhow.q).names()
                    self.unreachable(
                        device,
                        step,
                        f"no joint solution within the limits reaches '{name}' with "
                        f"{_said(wanted)} (one with {_said(have)} does)",
                    )
            if result is None:
                result = solve_ik(dev, T_base[0], mount, seed, position_only)
            self.unreachable(
                device,
                step,
                result.unreachable(name, tcp, [j.name for j in dev.joints], position_only),
            )
        return self._joint_move(device, tr, step, q_now, best, speed, acceleration)

    def _path_of(self, step) -> str:
        """A step's ``path:``: its own when it gives one (or a path file), else the run's
        default (``paths:``) - never for a linear or guarded move, nor one that may touch
        (``touch:``: contact is its point, and the planner avoids it)."""
        spec = step.spec
        path = getattr(spec, "path", "straight")
        if path not in ("straight", "free") or "path" in getattr(spec, "model_fields_set", ()):
            return path
        if step.kind == "move" and (
            spec.motion == "linear" or spec.until is not None or step.touch
        ):
            return "straight"
        return self.run.paths

    def _checker_at(self, device: str, t: float, q):
        """A ``ConfigurationChecker`` of ``device`` in the world at instant ``t`` (the other
        devices where their programs have them, the affixments of the moment), the device
        at ``q``: collisions by the run's tolerance (what a turn or a route is chosen by; a
        required clearance is the check's to report, not a reason to refuse a step)."""
        from ..collision.configurations import ConfigurationChecker

        return ConfigurationChecker(
            self.world,
            self._world_at(device, t, q),
            device,
            tolerance=self.run.collision_tolerance,
        )

    def _world_at(self, device: str, t: float, q):
        """The world at instant ``t`` with ``device`` at ``q``; returns the collision model
        (built by the first caller)."""
        from ..collision.bodies import collision_model

        if self._collisions is None:
            self._collisions = collision_model(self.run.cell)
        self.set_time(t)
        self.world.set_joints(device, q)
        return self._collisions

    def _clear_solution(
        self, device, tr, step, dev, mount, q_now, T_base, position_only, best, accept, name
    ):
        """The joint solution a move takes: ``best`` (the one IK reached from the seed) when
        its move collides with nothing, else the soonest reached of the target's other
        solutions (other arm configurations, found from :data:`IK_STARTS` seeded starts;
        the configuration asked for, if any) whose move is clear.  None clear: ``best``,
        with a warning naming each solution tried and its first contact (the check then
        reports the collision, and the run can be watched)."""
        from ..kinematics.inverse import distinct_solutions
        from ..planning.motion import sampled_box

        checker = self._checker_at(device, tr.t, q_now)  # the world now, for every solution
        hit = self._joint_line_collision(checker, step, q_now, best)
        if hit is None:
            return best
        rng = np.random.default_rng(step.index)
        lo, hi = (sampled_box(dev.limit_array(side)) for side in ("lower", "upper"))
        starts = np.concatenate(
            [np.asarray(best, dtype=float)[None], rng.uniform(lo, hi, (IK_STARTS, dev.dof))]
        )
        found = distinct_solutions(dev, T_base, starts, mount, position_only, accept)
        found = found[np.abs(found - best).max(axis=1) > 1e-3]  # best is tried already
        v = dev.limit_array("velocity")
        v = np.where(np.isfinite(v) & (v > 0), v, 1.0)
        others = sorted(found, key=lambda q: float(np.max(np.abs(q - q_now) / v)))
        tried = [(np.asarray(best, dtype=float), hit)]
        for q in others:
            hit = self._joint_line_collision(checker, step, q_now, q)
            if hit is None:
                return q
            tried.append((q, hit))
        words = [
            f"{_said(arm_configurations(dev, q).names()) if is_arm(dev) else f'solution {k + 1}'}"
            f": {why}"
            for k, (q, why) in enumerate(tried)
        ]
        self.warn(
            device,
            tr,
            step,
            f"no joint solution for '{name}' is reached without a collision (the "
            f"first is taken, and the check reports it); tried {len(tried)}: " + "; ".join(words),
        )
        return best

    def _clear_turn(self, device, tr, step, q_now, Q, reached: list[int]) -> int:
        """Of the free turns reached (``reached``: indices into Q, soonest first), the first
        whose joint move from ``q_now`` collides with nothing (the continuous segment check;
        for ``path: free`` its end state alone, free and touching nothing: the planner finds
        the way).  None clear: the soonest, with a warning naming each turn tried and its
        collision (the check reports it)."""
        hits = []
        checker = self._checker_at(device, tr.t, q_now)  # the world now, for every turn
        for k in reached:
            hit = self._joint_line_collision(checker, step, q_now, Q[k])
            if hit is None:
                return k
            hits.append(f"{self._turn_words(step.goal, [k])[0]}: {hit}")
        self.warn(
            device,
            tr,
            step,
            f"no turn about {step.goal.feature} is reached without a collision (the soonest is "
            f"taken, and the check reports it); tried {len(hits)}: " + "; ".join(hits),
        )
        return reached[0]

    def _joint_line_collision(self, checker, step, q0, q1) -> str | None:
        """Whether the joint move q0 -> q1 (its end alone, for ``path: free``) collides
        (``checker``: :meth:`_checker_at` the move's start): None, or the collision in words."""
        from ..planning.motion import first_contact_words, nearest_words

        if self._path_of(step) == "free":
            report = checker.check(np.asarray(q1)[None])
            if report.free[0] and report.distance[0] >= 0.0:
                return None
            return nearest_words(checker, report, 0)
        found = checker.check_segment(q0, q1)
        return None if found.free else first_contact_words(checker, found)

    def _record_move(
        self,
        device,
        tr,
        step,
        q_now,
        seg,
        planned,
        name,
        tcp=None,
        until=None,
        motion="joint",
        speed=None,
        acceleration=None,
        via=None,
    ):
        """Guard, resolve and time a move's segment (None: already there); returns it.  A
        joint move with ``path: free`` goes through the via points of a collision-free path
        (:meth:`_free_path`), each recorded as a joint move of its own (``via``: a leg of a
        path timed as one, its via point and blend as :meth:`_timed_legs` gives them)."""
        if (
            seg is not None
            and motion == "joint"
            and step.kind in ("move", "insert", "place", "follow", "probe")  # approach moves
            and self._path_of(step) == "free"
            and not self._in_free_path
        ):
            return self._free_path(device, tr, step, q_now, seg, name, tcp, speed, acceleration)
        if seg is not None and not (seg.t1 - seg.t0) / self.run.dt <= MAX_SAMPLES:
            T = seg.t1 - seg.t0
            self._too_long(
                device,
                step,
                f"the move takes {T:.4g} s: {T / self.run.dt:.3g} clock samples at dt "
                f"{self.run.dt:g} s, above the bound of {MAX_SAMPLES:,}",
                step.spec.speed if speed is None else speed,
            )
        if seg is not None and until is not None:
            seg = self._guard(device, tr, step, seg, until)
        spec = step.spec
        target = self._target(
            device,
            tr,
            step,
            q_now,
            seg,
            planned,
            name,
            tcp or self._resolve_tcp(device, getattr(spec, "tcp", None)),
            motion,
            spec.speed if speed is None else speed,
            spec.acceleration if acceleration is None else acceleration,
            until,
            via,
        )
        self._actions.append(ResolvedStep(step, target.t0, target))
        if seg is None:
            self.events.append(
                Event(tr.t, device, step.index, "move", f"{step.describe()}: already there")
            )
            return None
        tr.segments.append(seg)
        took, words = self._configuration_taken(device, seg.q_end)
        via = f", {self._free_leg}" if self._in_free_path and self._free_leg else ""  # its leg
        self.events.append(
            Event(
                tr.t,
                device,
                step.index,
                "move",
                f"{step.describe()}{via} ({seg.t1 - seg.t0:.3f} s{words})",
                reading={"configuration": took} if took else None,
            )
        )
        tr.t = seg.t1
        return seg

    def _free_path(self, device, tr, step, q_now, seg, name, tcp, speed, acceleration):
        """``move: {..., path: free}``: a collision-free joint path from the joints now to the
        move's end (``planning.motion.plan_in_world``: in the world at this instant - other
        devices where their programs have them, grasps, tools, calibrated poses; the run's
        clearance and collision tolerance; seeded by the step's index; its corners blended
        where the blends are free), driven through its via points without stopping at the
        blended ones (:meth:`_drive_through`).  No path: the target is unreachable (exit 1),
        with the planner's reason."""
        from ..planning.motion import plan_in_world

        plan, _ = plan_in_world(
            self.world,
            self._world_at(device, tr.t, q_now),
            device,
            q_now,
            seg.q_end[None],
            tolerance=self.run.collision_tolerance,
            clearance=self.run.clearance,
            seed=step.index,
            timeout=FREE_PATH_TIMEOUT,
        )
        if not plan.found:
            raise NoFreePath(
                f"{step.where}: {device} step {step.index + 1} ({step.describe()}): no "
                f"collision-free path to '{name}': {plan.reason}",
                str(plan.reason),
            )
        return self._drive_through(
            device, tr, step, plan.waypoints, name, tcp, speed, acceleration, plan.blends
        )

    def _drive_through(self, device, tr, step, way, name, tcp, speed, acceleration, blends=None):
        """Drive through the states ``way`` (W, n) - a planned path's or a path file's - each
        leg (via point to via point) recorded as a move of the step, its event naming the leg;
        returns the last.  One leg: a joint move.  More: the whole path timed as one
        (:meth:`_timed_legs`), through each corner ``blends`` (W,) blends without stopping,
        at rest at the others.  A via point that repeats the one before (a path file driven
        from where the device already is) is dropped with its blend."""
        way = np.asarray(way, dtype=float)
        keep = np.r_[True, np.abs(np.diff(way, axis=0)).max(axis=1) > 1e-12]
        if not keep.all():
            way = way[keep]
            blends = None if blends is None else np.asarray(blends, dtype=float)[keep]
            if blends is not None:
                blends[[0, -1]] = 0.0  # the ends are at rest
            if len(way) == 1:  # already at the path's end
                way = np.stack([way[0], way[0]])
        legs = self._timed_legs(device, step, tr.t, way, blends, speed, acceleration)
        self._in_free_path = True
        try:
            last = None
            for k in range(1, len(way)):
                if legs is None:
                    piece = self._joint_move(
                        device, tr, step, way[k - 1], way[k], speed, acceleration
                    )
                    via = None
                else:
                    piece, via = legs[k - 1]
                leg = f"via point {k} of {len(way) - 2}" if k < len(way) - 1 else "last leg"
                leg = leg if len(way) > 2 else ""  # the straight line was free: one move
                self._free_leg = leg
                label = name if k == len(way) - 1 else f"{name} ({leg})"
                last = self._record_move(
                    device,
                    tr,
                    step,
                    way[k - 1],
                    piece,
                    piece,
                    label,
                    tcp,
                    None,
                    "joint",
                    speed,
                    acceleration,
                    via,
                )
        finally:
            self._in_free_path = False
        return last

    def _timed_legs(self, device, step, t0, way, blends, speed, acceleration):
        """The legs of the path through ``way`` (W > 2 states) timed as one, starting at
        ``t0``: ``planning.topp``'s time-optimal timing of the ``blended`` path (straight
        joint lines, corners cut by ``blends``; all 0 or None: at rest at every via point)
        under the joints' velocity and acceleration limits times the step's speed and
        acceleration fractions, and their torque limits where the cell gives them (what the
        device carries now on its links; no friction: the run's overload check sees it).
        A list of (PathLeg, (via point, blend fraction, the blend's two ends, the fractions of
        the legs before and after it the blend takes)) - the leg ends
        where the path passes its via point's knot (the middle of its blend) - or None for a
        single leg."""
        if len(way) <= 2:
            return None
        from ..motion.trajectory import PathLeg
        from ..planning.path import JointPath, blend_corners, blend_half_widths
        from ..planning.topp import InfeasiblePath, Limits, sample_path, time_optimal

        dev = self.run.cell.devices[device]
        speed = step.spec.speed if speed is None else speed
        acceleration = step.spec.acceleration if acceleration is None else acceleration
        blends = np.zeros(len(way)) if blends is None else np.asarray(blends, dtype=float)
        path = JointPath(way, None, "blended", blends)
        effort = dev.limit_array("effort")
        dynamics = gravity = None
        if np.isfinite(effort).any():
            dynamics = DeviceDynamics(
                dev, friction=False, link_loads=self.world.carried_loads(device)
            )
            gravity = self.world.T_world(device)[:3, :3].T @ self.run.cell.gravity
        limits = Limits(
            dev.limit_array("velocity") * speed,
            dev.limit_array("acceleration") * acceleration,
            effort if dynamics is not None else None,
        )
        if not np.isfinite(limits.acceleration).any():
            names = ", ".join(j.name for j in dev.joints)
            self.fail(
                device,
                step,
                f"nothing times this path: its joints ({names}) have no acceleration limit; "
                "add one to the cell",
            )
        try:
            timing, _ = time_optimal(path, limits, dynamics, gravity)
        except InfeasiblePath as exc:
            self.fail(device, step, f"no timing of the path keeps the joints' limits: {exc}")

        def sampler(times):
            rows = sample_path(path, timing, np.asarray(times, dtype=float) - t0)
            return rows.q, rows.qd, rows.qdd

        # when the path passes each via point's knot (s rises with t: invert by interpolation)
        at = t0 + np.interp(path.knots, timing.s, timing.t)
        at[0], at[-1] = t0, t0 + timing.duration
        controls = blend_corners(path.knots, way, blends)  # (W, 3, n): each blend's ends
        h = np.diff(path.knots)
        tau = blend_half_widths(path.knots, blends)
        before, after = tau[1:] / h, np.r_[tau[1:-1] / h[1:], 0.0]  # of leg k-1, of leg k
        return [
            (
                PathLeg(float(at[k - 1]), float(at[k]), sampler),
                (
                    way[k],
                    float(blends[k]),
                    controls[k, 0],
                    controls[k, 2],
                    float(before[k - 1]),
                    float(after[k - 1]),
                ),
            )
            for k in range(1, len(way))
        ]

    def _configuration_taken(self, device: str, q) -> tuple[dict | None, str]:
        """A 6-axis arm's configuration at ``q``: rworld's words, and the text for the move's
        event - those words and the controller's (KUKA S/T, ABB confdata, FANUC CONFIG)."""
        dev = self.run.cell.devices[device]
        if not is_arm(dev):
            from ..kinematics.redundancy import arm_angle, is_seven_axis_arm

            if is_seven_axis_arm(dev):
                psi = float(np.degrees(arm_angle(dev, np.asarray(q)[None])[0]))
                return {"arm_angle_deg": psi}, f"; arm angle {psi:.2f} deg"
            return None, ""
        names = arm_configurations(dev, q).names()
        profile = dev.controller
        axes = profile.axes(q) if profile is not None else np.asarray(q)
        vendor = vendor_words(profile.vendor if profile is not None else None, axes, names)
        took = {**names, **({"controller": vendor} if vendor else {})}
        words = "; " + ", ".join(f"{k} {v}" for k, v in names.items())
        return took, words + (f"; {vendor}" if vendor else "")

    def _target(
        self,
        device,
        tr,
        step,
        q_now,
        seg,
        planned,
        name,
        tcp,
        motion,
        speed,
        acceleration,
        until,
        via=None,
    ) -> MoveTarget:
        """The resolved move, for exporters: the TCP steered, where the joints ended (a leg
        of a path timed as one: its via point, ``via``), the TCP pose there in the base
        frame; a blended via point's blend (the joint and TCP distances from the via point
        at which its blend leaves and joins the lines, the smaller side)."""
        dev = self.run.cell.devices[device]
        link, T_link_tcp = self.world.mount_of(device, tcp)
        q_goal = np.array(q_now if seg is None else seg.q_end, dtype=float)
        q_planned = np.array(q_now if planned is None else planned.q_end, dtype=float)
        mount = ToolMount(link, T_link_tcp)
        blend = None
        if via is not None:
            q_goal = q_planned = np.array(via[0], dtype=float)
            corner, fraction, p0, p2, before, after = via
            if fraction > 0:
                tcp_at = tool_pose(dev, np.stack([p0, corner, p2]), mount)[..., :3, 3]
                blend = BlendZone(
                    fraction,
                    before,
                    after,
                    float(min(np.abs(corner - p0).max(), np.abs(p2 - corner).max())),
                    float(
                        min(
                            np.linalg.norm(tcp_at[1] - tcp_at[0]),
                            np.linalg.norm(tcp_at[2] - tcp_at[1]),
                        )
                    ),
                )
        T_base_tcp = tool_pose(dev, q_goal, mount)
        return MoveTarget(
            motion,
            name,
            tcp,
            link,
            np.asarray(T_link_tcp, dtype=float),
            np.array(q_now, dtype=float),
            q_goal,
            T_base_tcp,
            tr.t,
            tr.t if seg is None else seg.t1,
            speed,
            acceleration,
            until,
            q_planned,
            tool_pose(dev, q_planned, mount),
            blend,
        )

    def _joint_move(
        self, device: str, tr: _Track, step: Step, q_now, q_goal, speed=None, acceleration=None
    ):
        """A synchronised joint move; a joint with no velocity or acceleration limit is
        unlimited in it, alone.
        """
        dev = self.run.cell.devices[device]
        try:
            return joint_move(
                tr.t,
                q_now,
                q_goal,
                dev.limit_array("velocity"),
                dev.limit_array("acceleration"),
                step.spec.speed if speed is None else speed,
                step.spec.acceleration if acceleration is None else acceleration,
            )
        except UntimedMove as exc:
            names = ", ".join(dev.joints[j].name for j in exc.joints)
            self.fail(
                device,
                step,
                f"nothing times this move: the joints that move ({names}) have no acceleration "
                "limit; "
                "add one to the cell",
            )

    def _guard(self, device: str, tr: _Track, step: Step, seg, sensor: str):
        """Cut a guarded move where its sensor first senses something: the first clock sample
        that senses, then bisection between it and the sample before down to ``LATCH_TIME``, as
        a touch-trigger probe latches the position at contact."""
        from ..sensing.sensors import ball_may_touch, read_sensors

        times = np.append(np.arange(seg.t0, seg.t1, self.run.dt), seg.t1)
        q_move = seg.sample(times)[0]

        def senses(t: float, q=None):
            self.set_time(t)
            self.world.set_joints(device, seg.sample(np.array([t]))[0][0] if q is None else q)
            return read_sensors(self.world, [sensor])[0]

        samples = range(len(times))
        if self.world.cell.sensors[sensor].ball is not None:
            # a ball reads nothing where it reaches no shape's box: only the other samples
            # are read, one state at a time (sensing needs the whole world at each instant)
            joints = {d: self.q_over(d, times) for d in self.tracks if d != device}
            samples = np.flatnonzero(ball_may_touch(self.world, sensor, joints | {device: q_move}))
        self._latched[device] = None
        for k in samples:
            t, q = times[k], q_move[k]
            reading = senses(t, q)
            if not reading.active:
                continue
            lo, hi = (float(times[k - 1]), float(t)) if k else (float(t), float(t))
            while hi - lo > LATCH_TIME:
                mid = 0.5 * (lo + hi)
                if senses(mid).active:
                    hi = mid
                else:
                    lo = mid
            reading = senses(hi)
            q_stop = self.world.joints(device)
            contact = self.world.T_world(sensor)[:3, 3].copy()
            record = reading.as_dict() | {
                "q": q_stop.tolist(),  # where the device stopped
                "point": contact.tolist(),  # the sensor origin (a ball tip's centre) at contact
            }
            self._latched[device] = {
                # the guarded move's place among the device's resolved moves (a feature step
                # makes several moves on one program line)
                "move": len(self.resolved[device]) + len(self._actions),
                "sensor": sensor,
                "point": contact,
                "objects": list(reading.objects),
                "step": step.index,
                "t": hi,
            }
            self.events.append(
                Event(
                    hi, device, step.index, "guard", f"{sensor} triggered: stopped", reading=record
                )
            )
            return StoppedMove(seg, hi)
        self.events.append(
            Event(
                seg.t1,
                device,
                step.index,
                "guard",
                f"{sensor} did not trigger: the move ran to its end",
            )
        )
        return seg

    def _probe(self, device, tr, step):
        """Record where the last guarded move's sensor touched, as a probe point of a feature;
        or, for a probe step on its own, the probing moves of the feature."""
        if step.goal is not None:
            return self._probe_moves(device, tr, step)
        return self._record_probe(device, tr, step, step.spec.feature)

    def _record_probe(self, device, tr, step, feature: str) -> bool:
        latched = self._latched.get(device)
        if latched is None:
            self.fail(
                device,
                step,
                f"nothing to record for {feature}: the guarded move before this step "
                "ended without contact (or there was none)",
            )
        self._latched[device] = None  # one point per contact
        self._actions.append(ResolvedStep(step, tr.t, None, "probe", feature))
        self.events.append(
            Event(
                tr.t,
                device,
                step.index,
                "probe",
                f"probe {feature}: {latched['sensor']} touched {', '.join(latched['objects'])}",
                reading={
                    "feature": feature,
                    "point": latched["point"].tolist(),
                    "sensor": latched["sensor"],
                    "objects": latched["objects"],
                    "guard_step": latched["step"] + 1,
                    "guard_move": latched["move"],
                },
            )
        )
        return True

    def _sense(self, device, tr, step):
        from ..sensing.sensors import read_sensors

        reading = read_sensors(self.world, [step.spec])[0]
        what = ", ".join(reading.objects) if reading.objects else "nothing"
        self.events.append(
            Event(
                tr.t,
                device,
                step.index,
                "sense",
                f"{step.spec}: {'active' if reading.active else 'inactive'} ({what})",
                reading=reading.as_dict(),
            )
        )
        return True

    def _tree_change(
        self, device: str, tr: _Track, step: Step, kind: str, child: str, action
    ) -> bool:
        try:
            aff = action()
        except AffixmentError as exc:
            self.fail(device, step, exc.message)
        tree = {
            "child": child,
            "parent": aff.parent if aff else None,
            "type": aff.type if aff else None,
            "kind": aff.kind if aff else None,
            "T_world_child": self.world.T_world(child).tolist(),
            "T_world_parent": self.world.T_world(aff.parent).tolist() if aff else None,
        }
        self.events.append(Event(tr.t, device, step.index, kind, step.describe(), tree))
        self.snapshots.append((tr.t, self.world.snapshot()))
        self._actions.append(ResolvedStep(step, tr.t, None, kind))
        return True

    def _held_by(self, device: str, child: str) -> bool:
        return child in self.world.subtree(device) and self.world.affixment(child) is not None

    def _grasp(self, device, tr, step):
        spec = step.spec
        tcp = self._resolve_tcp(device, spec.tcp)
        if tcp not in self.world.subtree(device):
            self.fail(device, step, f"'{tcp}' is not carried by {device}")
        aff = self.world.affixment(spec.object)
        if aff is not None and aff.type == "rigid" and aff.kind == "grasp":
            self.fail(
                device,
                step,
                f"'{spec.object}' is already held by '{aff.parent}'; release it there first",
            )
        return self._tree_change(
            device,
            tr,
            step,
            "grasp",
            spec.object,
            lambda: self.world.attach(spec.object, tcp, "rigid", "grasp"),
        )

    def _release(self, device, tr, step):
        obj = step.spec.object
        if not self._held_by(device, obj):
            self.fail(device, step, f"{device} does not hold '{obj}'")

        def act():
            self.world.detach(obj)
            return None

        return self._tree_change(device, tr, step, "release", obj, act)

    def _place(self, device, tr, step):
        spec = step.spec
        if step.goal is not None:  # a face set down on a plane feature
            return self._place_face(device, tr, step)
        if not self._held_by(device, spec.object):
            self.fail(device, step, f"{device} does not hold '{spec.object}'")
        return self._tree_change(
            device,
            tr,
            step,
            "place",
            spec.object,
            lambda: self.world.attach(spec.object, spec.on, "non_rigid", "rests_on"),
        )

    def _attach_tool(self, device, tr, step):
        spec = step.spec
        at = self._resolve_tcp(device, spec.at)
        if at not in self.world.subtree(device):
            self.fail(device, step, f"'{at}' is not carried by {device}")
        return self._tree_change(
            device,
            tr,
            step,
            "attach_tool",
            spec.tool,
            lambda: self.world.attach(spec.tool, at, "rigid", "tool"),
        )

    def _detach_tool(self, device, tr, step):
        spec = step.spec
        if spec.tool not in self.world.subtree(device) or spec.tool == device:
            self.fail(device, step, f"{device} does not carry '{spec.tool}'")
        if spec.on is not None:
            action = lambda: self.world.attach(spec.tool, spec.on, "non_rigid", "rests_on")  # noqa: E731
        else:

            def action():
                self.world.detach(spec.tool)
                return None

        return self._tree_change(device, tr, step, "detach_tool", spec.tool, action)

    def _wait(self, device, tr, step):
        spec = step.spec
        if spec.time is not None:
            self.events.append(Event(tr.t, device, step.index, "wait", step.describe()))
            tr.t += spec.time
            return True
        other = self.tracks[spec.for_]
        if other.status == "done":
            tr.t = max(tr.t, other.end)
            self.events.append(Event(tr.t, device, step.index, "wait", f"{spec.for_} has finished"))
            return True
        tr.status, tr.waiting_on = "waiting", ("device", spec.for_)
        self.events.append(
            Event(tr.t, device, step.index, "wait", f"waiting for {spec.for_} to finish")
        )
        return False

    def _sync(self, device, tr, step):
        name = step.spec
        k = tr.sync_counts.get(name, 0)
        tr.sync_counts[name] = k + 1
        arrivals = self.barriers.setdefault((name, k), {})
        arrivals[device] = tr.t
        participants = [d for d in self.order if self.sync_totals[d].get(name, 0) > k]
        if len(arrivals) < len(participants):
            tr.status, tr.waiting_on = "waiting", ("sync", name, k)
            return False
        t_meet = max(arrivals.values())
        for d in participants:
            o = self.tracks[d]
            o.t = t_meet
            self.events.append(
                Event(
                    t_meet,
                    d,
                    o.program.steps[o.pc].index,
                    "sync",
                    f"sync {name} ({', '.join(participants)})",
                )
            )
            if d != device:
                o.status, o.waiting_on = "running", None
                o.pc += 1
                if o.pc >= len(o.program.steps):
                    self.finish(d)
        return True


def simulate(
    run: Run, progress=None, collisions: bool = True, payload: bool = False
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
        result.collisions = check_run(run, sched, result.times, sampled=sampled)
    return result


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) index ranges where ``mask`` is True."""
    padded = np.concatenate([[False], mask, [False]])
    edges = np.flatnonzero(padded[1:] != padded[:-1])
    return list(zip(edges[::2], edges[1::2]))


def _sample(
    run: Run, sched: _Scheduler, progress, payload: bool = False
) -> tuple[SimulationResult, dict]:
    """The run on its clock, and every device's (q, qd, qdd) at the clock's instants."""
    cell = run.cell
    end = max((tr.end for tr in sched.tracks.values()), default=0.0)
    if not end / run.dt <= MAX_SAMPLES:  # waits may make a run long: bounded before sampling
        raise UserError(
            f"{run.file}: the run lasts {end:.4g} s: {end / run.dt:.3g} clock samples at dt "
            f"{run.dt:g} s, above the bound of {MAX_SAMPLES:,} (docs/simulation.md): shorten "
            "its waits or raise the clock step (dt)"
        )
    times = np.arange(0.0, end, run.dt)
    if len(times) == 0 or end - times[-1] > 1e-9 * max(1.0, end):
        times = np.append(times, end)  # the last sample is the end of the last program
    K = len(times)
    world = sched.world
    devices = list(cell.devices)
    q, qd, qdd = {}, {}, {}
    for d in devices:
        if d in sched.tracks:
            tr = sched.tracks[d]
            q[d], qd[d], qdd[d] = sample_track(tr.segments, tr.q_init, times)
        else:  # devices without a program hold their home values
            n = cell.devices[d].dof
            q[d], qd[d], qdd[d] = (
                np.tile(cell.devices[d].home, (K, 1)),
                np.zeros((K, n)),
                np.zeros((K, n)),
            )
    snaps = sched.snapshots
    bounds = [np.searchsorted(times, t, side="left") for t, _ in snaps[1:]] + [K]
    starts = [0] + bounds[:-1]
    run_devices = sched.order
    T_base = {d: np.empty((K, 4, 4)) for d in run_devices}
    T_tcp = {d: np.empty((K, 4, 4)) for d in run_devices}
    tcp_names = {d: [] for d in run_devices}
    total = len(snaps) * len(run_devices) * 2
    done = 0
    for (t_snap, snap), a, b in zip(snaps, starts, bounds):
        if b <= a:
            continue
        world.restore(snap)
        joints = {d: q[d][a:b] for d in devices}
        for d in run_devices:
            T_base[d][a:b] = world.T_world_batch(d, joints)
            tcp = world.active_tcp(d)
            T_tcp[d][a:b] = world.T_world_batch(tcp, joints)
            tcp_names[d].append((float(times[a]), tcp))
            done += 1
            if progress:
                progress(done, total, "poses")
    gravity = cell.gravity
    # what rides on each device's links, and where its active TCP sits, per stretch between
    # snapshots: the state at the stretch's start fixes the loads' poses (one restore per
    # stretch, not one per device and stretch: a line of robots)
    stretch_loads: list[dict] = []
    for (_, snap), a, b in zip(snaps, starts, bounds):
        stretch_loads.append({})
        if b <= a:
            continue
        world.restore(snap)
        for other in devices:
            world.set_joints(other, q[other][a])
        for d in run_devices:
            mount = ToolMount(*world.mount_of(d, world.active_tcp(d))) if payload else None
            stretch_loads[-1][d] = (world.carried_loads(d), mount)
    timelines = {}
    violations: list[Violation] = []
    step_texts = {d: [st.describe() for st in sched.tracks[d].program.steps] for d in run_devices}
    for d in run_devices:
        dev = cell.devices[d]
        # the base's own acceleration (a conveyor carrying the device) acts like gravity
        p = T_base[d][:, :3, 3]
        a_base = (
            np.gradient(np.gradient(p, times, axis=0), times, axis=0) if K > 2 else np.zeros_like(p)
        )
        g_world = gravity - a_base
        g_base = np.einsum("kji,kj->ki", T_base[d][:, :3, :3], g_world)  # R^T (g - a)
        tau = np.empty_like(q[d])
        per_kg = np.zeros_like(q[d]) if payload else None
        for n, (a, b) in enumerate(zip(starts, bounds)):
            if b <= a:
                continue
            loads, mount = stretch_loads[n][d]
            dyn = DeviceDynamics(dev, link_loads=loads)
            tau[a:b] = dyn.inverse(q[d][a:b], qd[d][a:b], qdd[d][a:b], g_base[a:b])
            if per_kg is not None and mount.link > 0:  # a TCP on the base loads no joint
                one = DeviceDynamics(dev, Payload.point_mass(1.0), mount, link_loads=loads)
                per_kg[a:b] = (
                    one.inverse(q[d][a:b], qd[d][a:b], qdd[d][a:b], g_base[a:b]) - tau[a:b]
                )
            done += 1
            if progress:
                progress(done, total, "dynamics")
        step_index = np.full(K, -1)
        for t0, idx in sched.tracks[d].step_starts:
            step_index[times >= t0 - 1e-12] = idx
        ratios = {  # NaN for a joint without that limit: no ratio, not 0
            kind: np.where(np.isfinite(limit), np.abs(value) / limit, np.nan)
            for kind, value, limit in (
                ("velocity", qd[d], dev.limit_array("velocity")),
                ("acceleration", qdd[d], dev.limit_array("acceleration")),
                ("torque", tau, dev.limit_array("effort")),
            )
        }
        capacity = None
        if per_kg is not None and K:
            from ..planning.payload import affine_capacity

            cap = affine_capacity(tau, per_kg, dev.limit_array("effort"))
            if np.isfinite(cap.mass):
                capacity = {
                    "mass": cap.mass,
                    "joint": dev.joints[cap.joint].name,
                    "t": float(times[cap.sample]),
                    "side": cap.side,
                }
        timelines[d] = DeviceTimeline(
            d,
            q[d],
            qd[d],
            qdd[d],
            tau,
            T_tcp[d],
            step_index,
            ratios,
            float(sched.tracks[d].end),
            tcp_names[d],
            per_kg,
            capacity,
        )
        violations += _violations(
            d, dev, times, q[d], ratios, qd[d], qdd[d], tau, step_index, step_texts[d]
        )
    world.restore(snaps[-1][1])
    violations.sort(key=lambda v: (v.t_start, v.device, v.joint))
    events = sorted(sched.events, key=lambda e: e.t)  # stable: simultaneous events keep their order
    unlimited = {d: cell.devices[d].unlimited() for d in timelines if cell.devices[d].unlimited()}
    result = SimulationResult(
        cell.name,
        run.file,
        run.dt,
        times,
        timelines,
        events,
        violations,
        step_texts,
        unlimited,
        resolved=sched.resolved,
        step_where={d: [st.where for st in sched.tracks[d].program.steps] for d in run_devices},
        snapshots=list(snaps),
        massless=[d for d in timelines if d in run_devices and cell.devices[d].total_mass <= 0.0],
    )
    return result, {d: (q[d], qd[d], qdd[d]) for d in devices}


def _violations(device, dev, times, q, ratios, qd, qdd, tau, step_index, texts) -> list[Violation]:
    out = []
    lower, upper = dev.limit_array("lower"), dev.limit_array("upper")
    checks = {
        "position": (np.maximum(lower - q, q - upper) > 1e-9, q, None),
        "velocity": (ratios["velocity"] > 1 + 1e-6, qd, dev.limit_array("velocity")),
        "acceleration": (ratios["acceleration"] > 1 + 1e-6, qdd, dev.limit_array("acceleration")),
        "torque": (ratios["torque"] > 1 + 1e-9, tau, dev.limit_array("effort")),
    }
    for kind, (bad, values, limits) in checks.items():
        for j in range(dev.dof):
            for a, b in _runs(bad[:, j]):
                seg = values[a:b, j]
                k = a + int(np.argmax(np.abs(seg)))
                if kind == "position":
                    peak = float(values[k, j])
                    limit = float(upper[j] if peak > upper[j] else lower[j])
                else:
                    peak, limit = float(values[k, j]), float(limits[j])
                step = int(step_index[k]) if step_index[k] >= 0 else None
                out.append(
                    Violation(
                        device,
                        dev.joints[j].name,
                        kind,
                        float(times[a]),
                        float(times[b - 1]),
                        peak,
                        limit,
                        step,
                        texts[step] if step is not None else "",
                    )
                )
    return out


def _said(configuration: dict[str, str]) -> str:
    """{'elbow': 'up', 'wrist': 'noflip'} as 'elbow up, wrist noflip'."""
    return ", ".join(f"{k} {v}" for k, v in configuration.items())
