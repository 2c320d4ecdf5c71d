"""Planning tasks: path files, limits, time-optimal timing, payload, trajectories for
controllers.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..planning.impulse import ImpulseResult
    from ..planning.payload import Capacity
    from ..planning.topp import Samples, Timing

from ..errors import Issue, UserError
from .paths import (  # noqa: F401  (path files: below planning and cells; exported here too)
    joint_path,
    load_joint_path,
    path_file_issues,
    path_range_issues,
    write_path_with_knots,
)
from .physics import DeviceContext, carried_loads, device_dynamics

# --------------------------------------------------------------------------- planning


def planning_limits(device, torque: bool = True, acceleration: bool = True):
    """The device's limits for planning.  A joint with no limit of a kind is unlimited in that kind,
    alone (``inf``); the other joints keep theirs.  ``torque=False`` / ``acceleration=False`` leave
    the kind out for every joint."""
    from ..planning.topp import Limits

    v, a, e = (
        device.limit_array("velocity"),
        device.limit_array("acceleration"),
        device.limit_array("effort"),
    )
    return Limits(
        v,
        a if acceleration and np.any(np.isfinite(a)) else None,
        e if torque and np.any(np.isfinite(e)) else None,
    )


def unlimited_joints(device, limits) -> dict[str, list[str]]:
    """Per kind, the joints a plan with ``limits`` runs unlimited in: those the cell gives no limit
    of it (position, velocity, acceleration; torque when the plan checks torque at all)."""
    out = device.unlimited()
    if limits.effort is None:  # torque left out of the plan (--no-torque): not a missing limit
        out.pop("torque", None)
    return out


def plan_time_optimal(
    ctx: DeviceContext,
    path,
    payload=None,
    gridpoints: int = 1000,
    torque: bool = True,
    friction: bool = False,
    exclude=(),
):
    """Time-optimal timing of ``path`` for the context's device; (timing, info, dynamics, limits).

    The torques include what the cell's state puts on the device's links, except ``exclude``.
    """
    from ..planning.topp import InfeasiblePath, time_optimal

    limits = planning_limits(ctx.device, torque)
    dyn = (
        device_dynamics(ctx, payload, armature=True, friction=friction, exclude=exclude)
        if limits.effort is not None
        else None
    )
    try:
        timing, info = time_optimal(path, limits, dyn, ctx.gravity_base, gridpoints)
    except InfeasiblePath as exc:
        raise UserError(f"no timing of the path stays within the limits: {exc}") from None
    return timing, info, dyn, limits


def parse_period(text: str) -> float:
    """'8ms', '0.004s' or a bare number of seconds -> seconds (0.1 ms to 1 s)."""
    from ..units import parse_duration

    try:
        period = parse_duration(text, "--period")
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if not 1e-4 <= period <= 1.0:  # a controller's period, as a run's clock step
        raise UserError(f"--period '{text}' is outside 0.1 ms to 1 s")
    return period


def sample_timed_path(
    path,
    timing,
    samples: int | None = None,
    period: float | None = None,
    grid_instants: bool = False,
):
    """The rows a plan writes: ``samples`` equally spaced instants or every ``period`` seconds,
    plus both sides of every grid instant (where sddot jumps) with ``grid_instants``."""
    from ..planning.topp import sample_instants, sample_path

    return sample_path(
        path, timing, sample_instants(timing, samples, period), switches=grid_instants
    )


def trajectory_table(samples, dynamics=None, gravity=None) -> tuple[list[str], np.ndarray]:
    """(columns, rows) of a trajectory CSV: t, s, sd, sdd, q1..qn, qd1..qdn, qdd1..qddn[,
    tau1..taun] (SI).
    """
    n = samples.q.shape[1]
    cols = ["t", "s", "sd", "sdd"] + [
        f"{g}{i}" for g in ("q", "qd", "qdd") for i in range(1, n + 1)
    ]
    blocks = [
        samples.t[:, None],
        samples.s[:, None],
        samples.sd[:, None],
        samples.sdd[:, None],
        samples.q,
        samples.qd,
        samples.qdd,
    ]
    if dynamics is not None:
        cols += [f"tau{i}" for i in range(1, n + 1)]
        blocks.append(dynamics.inverse(samples.q, samples.qd, samples.qdd, gravity))
    return cols, np.hstack(blocks)


@dataclass
class TimedTrajectory:
    """A trajectory timed elsewhere, read from CSV (SI)."""

    t: np.ndarray  # (K,)
    q: np.ndarray  # (K, n)
    qd: np.ndarray
    qdd: np.ndarray
    source: str

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])


def read_trajectory(csv_path: str, device) -> TimedTrajectory:
    """A trajectory CSV (columns t, q1..qn, qd1..qdn, qdd1..qddn in SI; others ignored), checked.

    Raises
    ------
    UserError
        Missing columns, bad values, time that goes back, or joint values outside their
        position limits - located as ``file:line:col``; nothing is evaluated.
    """
    from ..schema.tables import read_states

    data = read_states(csv_path, device.dof, ["q", "qd", "qdd"], scalars=("t",))
    t, lines, tcol = data["t"], data["_line"], data["_column"]["t"]
    issues = []
    back = np.flatnonzero(
        np.diff(t) < 0
    )  # a repeated instant is allowed: both sides of a switch in the acceleration
    for k in back[:10]:
        issues.append(
            Issue(
                csv_path,
                int(lines[k + 1]),
                int(tcol[k + 1]),
                "column 't'",
                f"time {float(t[k + 1])!r} comes before the row above ({float(t[k])!r}): a "
                "trajectory's time must not go back",
            )
        )
    lo, hi = device.limit_array("lower"), device.limit_array("upper")
    for k, j in np.argwhere((data["q"] < lo - 1e-9) | (data["q"] > hi + 1e-9))[:10]:
        issues.append(
            Issue(
                csv_path,
                int(lines[k]),
                0,
                f"column 'q{j + 1}'",
                f"{data['q'][k, j]:.6g} is outside the position limits of {device.joints[j].name} "
                f"[{lo[j]:.6g}, {hi[j]:.6g}]",
            )
        )
    if issues:
        raise UserError(f"{csv_path}: {len(issues)} error(s)", issues)
    if not t[-1] > t[0]:
        raise UserError(
            f"{csv_path}: a trajectory needs rows at two instants at least",
            [Issue(csv_path, int(lines[0]), 1, "(rows)", "every row is at the same instant")],
        )
    return TimedTrajectory(t, data["q"], data["qd"], data["qdd"], csv_path)


@dataclass
class PayloadResult:
    capacity: Capacity
    duration: float  # [s]
    binding_time: float  # [s] from the start of the motion
    instants: int  # instants checked


def plan_payload(
    ctx: DeviceContext,
    path_file: str | None,
    trajectory_file: str | None,
    timing: str = "time-optimal",
    duration: float | None = None,
    com=(0.0, 0.0, 0.0),
    payload_object: str | None = None,
    gridpoints: int = 1000,
    samples: int = 20001,
) -> PayloadResult:
    """The exact payload capacity of a motion: a path timed here (time-optimal or quintic) or a
    trajectory CSV.

    The torques include what the cell's state puts on the device's links (except
    ``payload_object``).
    """
    from ..dynamics import Payload
    from ..planning.payload import payload_capacity, quintic_timing

    if not np.isfinite(ctx.device.limit_array("effort")).any():
        raise UserError(
            f"no joint of '{ctx.device.name}' has a torque (effort) limit, so nothing bounds its "
            "payload: give the joints' effort limits in the cell (ROS-Industrial URDFs carry "
            'effort="0", which rworld reads as none)'
        )
    if trajectory_file is not None:
        tr = read_trajectory(trajectory_file, ctx.device)
        t, q, qd, qdd, T = tr.t - tr.t[0], tr.q, tr.qd, tr.qdd, tr.duration
    else:
        if path_file is None:
            raise UserError("give the motion as --path FILE or --trajectory CSV")
        path = load_joint_path(path_file, ctx.device)
        if timing == "quintic":
            if duration is None or not duration > 0:
                raise UserError("--timing quintic needs --duration SECONDS > 0")
            t, s, sd, sdd = quintic_timing(duration, samples)
            q, dq, ddq = path.evaluate(s)
            qd, qdd = dq * sd[:, None], ddq * (sd**2)[:, None] + dq * sdd[:, None]
            T = duration
        else:
            tm, _, _, _ = plan_time_optimal(ctx, path, None, gridpoints, torque=False)
            # the acceleration jumps at grid instants: both one-sided limits count, not only the
            # samples
            rows = sample_timed_path(path, tm, samples, grid_instants=True)
            t, q, qd, qdd, T = rows.t, rows.q, rows.qd, rows.qdd, tm.duration
    unit = None
    if payload_object:
        obj = ctx.world.cell.objects.get(payload_object)
        if obj is None or obj.inertial.mass <= 0:
            raise UserError(f"'{payload_object}' is not an object with mass in the cell")
        held = payload_object in ctx.world.subtree(ctx.tcp)
        body = Payload.rigid_body(
            obj.inertial, ctx.world.T(ctx.tcp, payload_object) if held else None
        )
        unit = Payload(1.0, body.com, body.inertia / body.mass)
    exclude = [payload_object] if payload_object else ()
    cap = payload_capacity(
        ctx.device,
        q,
        qd,
        qdd,
        ctx.gravity_base,
        com,
        ctx.mount,
        armature=True,
        friction=False,
        unit_payload=unit,
        link_loads=carried_loads(ctx, exclude),
    )
    return PayloadResult(cap, float(T), float(t[cap.sample]), len(t))


# --------------------------------------------------------------------------- the plan commands


@dataclass
class TimeOptimalPlan:
    """What ``rworld plan time-optimal`` reports (SI)."""

    timing: Timing
    info: dict  # time_optimal's info
    rows: Samples  # the instants written / checked
    peak_ratio: dict  # kind -> the largest |value| / limit over the rows
    binding: dict  # constraint -> share of the grid intervals it binds
    unlimited: dict  # kind -> joints without a limit of it
    carried: list  # what the cell's state puts on the links
    written: list  # files written
    loads_counted: bool = True  # the torque limits (and so the loads) took part
    notes: list = field(default_factory=list)  # what loads the torques include, one line each

    def as_dict(self) -> dict:
        return {
            "duration": self.timing.duration,
            "binding": self.binding,
            "dense_ratio": self.info["dense_ratio"],
            "repaired_gridpoints": self.info["repaired"],
            "rounds": self.info["rounds"],
            "slowdown": self.timing.scale,
            "peak_ratio": self.peak_ratio,
            "unlimited": self.unlimited,
            "carried": self.carried,
            "loads_counted": self.loads_counted,
            "notes": self.notes,
            "rows": len(self.rows.t),
        }


def binding_shares(binding: list[str]) -> dict[str, float]:
    """Constraint -> the share of grid intervals it binds, most first."""
    counts: dict[str, int] = {}
    for b in binding:
        counts[b] = counts.get(b, 0) + 1
    return {k: v / len(binding) for k, v in sorted(counts.items(), key=lambda kv: -kv[1])}


def time_optimal_plan(
    ctx: DeviceContext,
    path_file: str,
    gridpoints: int = 1000,
    torque: bool = True,
    payload_object: str | None = None,
    payload_mass: float | None = None,
    payload_com=None,
    samples: int | None = 20001,
    period: float | None = None,
    grid_instants: bool = False,
    output: str | None = None,
    plot: str | None = None,
) -> TimeOptimalPlan:
    """``rworld plan time-optimal``: the fastest timing of a path file, sampled, checked and
    written (CSV, PNG).
    """
    from ..planning.topp import limit_ratios
    from ..schema.tables import write_csv
    from .physics import carried_summary, load_notes, resolve_payload

    path = load_joint_path(path_file, ctx.device)
    payload = resolve_payload(ctx, payload_object, payload_mass, payload_com)
    exclude = (
        [payload_object] if payload_object else ()
    )  # an object given as the payload is not also carried
    timing, info, dyn, limits = plan_time_optimal(
        ctx, path, payload, gridpoints, torque, exclude=exclude
    )
    rows = sample_timed_path(path, timing, samples, period, grid_instants)
    ratios = limit_ratios(rows.q, rows.qd, rows.qdd, limits, dyn, ctx.gravity_base)
    written = []
    if plot:
        from ..planning.pictures import write_timing_plot

        write_timing_plot(path_file, timing, info, rows.t, ratios, plot)
        written.append(plot)
    if output:
        write_csv(output, *trajectory_table(rows, dyn, ctx.gravity_base))
        written.append(output)
    # a kind no joint limits has no peak ratio (None in JSON, n/a in text), never 0
    peaks = {
        k: float(np.max(v[np.isfinite(v)])) if np.isfinite(v).any() else float("nan")
        for k, v in ratios.items()
    }
    return TimeOptimalPlan(
        timing,
        info,
        rows,
        peaks,
        binding_shares(info["binding"]),
        unlimited_joints(ctx.device, limits),
        carried_summary(ctx, exclude),
        written,
        dyn is not None,
        load_notes(ctx, payload, payload_object, exclude) if dyn is not None else [],
    )


def load_optimal_plan(
    ctx: DeviceContext,
    path_file: str,
    duration: float,
    com=(0.0, 0.0, 0.0),
    gridpoints: int = 400,
    tolerance: float = 1e-4,
    shape: bool = False,
    evaluations: int = 80,
    shape_output: str | None = None,
    samples: int | None = 20001,
    period: float | None = None,
    grid_instants: bool = False,
    output: str | None = None,
    progress=None,
):
    """``rworld plan load-optimal``: (LoadOptimal, unlimited joints).

    The heaviest payload within ``duration``, its timing (and with ``shape`` its knots); writes the
    reshaped path file and the CSV when asked.
    """
    from ..planning.payload import load_optimal
    from ..planning.topp import InfeasiblePath
    from ..schema.tables import write_csv

    if not duration > 0:
        raise UserError("--duration must be > 0")
    if shape_output and not shape:
        raise UserError("--shape-output needs --shape")
    path = load_joint_path(path_file, ctx.device)
    limits = planning_limits(ctx.device, torque=True)
    try:
        r = load_optimal(
            ctx.device,
            path,
            limits,
            ctx.gravity_base,
            com,
            duration,
            ctx.mount,
            gridpoints,
            tolerance,
            shape=shape,
            evaluations=evaluations,
            progress=progress,
            link_loads=carried_loads(ctx),
        )
    except InfeasiblePath as exc:
        raise UserError(str(exc)) from None
    if shape_output:
        write_path_with_knots(
            path_file,
            r.path.knots,
            shape_output,
            f"they carry {r.mass:.4f} kg in {duration} s at {ctx.tcp}",
        )
    if output:
        write_csv(
            output,
            *trajectory_table(sample_timed_path(r.path, r.timing, samples, period, grid_instants)),
        )
    return r, unlimited_joints(ctx.device, limits)


@dataclass
class ImpulsePlan:
    result: ImpulseResult
    direction_world: np.ndarray  # unit
    end_velocity_world: np.ndarray
    q_start: np.ndarray
    q_end: np.ndarray
    unlimited: dict


def impulse_plan(
    ctx: DeviceContext,
    target: str,
    direction_world,
    payload_mass: float = 0.0,
    com=(0.0, 0.0, 0.0),
    q_start=None,
    gridpoints: int = 300,
) -> ImpulsePlan:
    """``rworld plan impulse``: the motion from rest to ``target`` with the most momentum along
    ``direction_world``.
    """
    from ..errors import did_you_mean
    from ..planning.impulse import max_impulse
    from ..planning.topp import InfeasiblePath
    from .physics import inverse_kinematics, resolve_payload

    if target not in ctx.world.cell.frames:
        raise UserError(f"unknown frame '{target}'{did_you_mean(target, ctx.world.cell.frames)}")
    d_world = np.asarray(direction_world, dtype=float)
    if np.linalg.norm(d_world) < 1e-12:
        raise UserError("--direction must not be zero")
    q_start = (
        ctx.world.joints(ctx.device.name) if q_start is None else np.asarray(q_start, dtype=float)
    )
    q_end = inverse_kinematics(ctx, ctx.world.T_world(target), target, q_start).q
    payload = resolve_payload(ctx, None, payload_mass, com) if payload_mass > 0 else None
    dyn = device_dynamics(ctx, payload, armature=True, friction=False)
    d_base = ctx.T_world_base[:3, :3].T @ d_world
    limits = planning_limits(ctx.device)
    try:
        r = max_impulse(
            ctx.device,
            q_start,
            q_end,
            d_base,
            payload_mass,
            com,
            limits,
            dyn,
            ctx.gravity_base,
            ctx.mount,
            gridpoints,
        )
    except InfeasiblePath as exc:
        raise UserError(str(exc)) from None
    return ImpulsePlan(
        r,
        d_world / np.linalg.norm(d_world),
        ctx.T_world_base[:3, :3] @ r.end_velocity,
        np.asarray(q_start),
        q_end,
        unlimited_joints(ctx.device, limits),
    )
