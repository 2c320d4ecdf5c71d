"""Robot programs out: a run's (or a program's) resolved targets written in robot languages,
and what a calibration changed in them."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import CheckFailed, UserError, did_you_mean
from ..export import FORMATS, VENDOR_FORMATS, VENDOR_WITHOUT_FORMAT, Signals
from ..units import ARCSEC

if TYPE_CHECKING:
    from ..export.common import DeviceProgram, Record
    from ..model.program import Run
    from ..schema.contactlog import LoggedContact
    from ..simulate.timeline import Event, SimulationResult
    from ..world.tree import World

# the languages that drive arms (Sunrise: 7-axis, the others 6-axis); csv streams any device
ARM_FORMATS = {
    "urscript": "URScript",
    "krl": "KUKA KRL",
    "rapid": "ABB RAPID",
    "fanuc": "FANUC TP",
    "inform": "Yaskawa INFORM",
    "val3": "Staubli VAL3",
    "drl": "Doosan DRL",
    "sunrise": "KUKA Sunrise",
}


@dataclass
class TargetChange:
    """A move whose target the calibrated poses moved, against the nominal ones."""

    device: str
    where: str
    step: str
    target: str
    translation: float  # [m]
    rotation: float  # [rad]
    joints: float  # largest joint change [rad or m]
    frames: list[str]  # calibrated frames on the way from world to the target or the TCP
    cause: str = ""  # what moved it, in words (:func:`change_cause`)

    def as_dict(self) -> dict:
        return {
            "device": self.device,
            "where": self.where,
            "step": self.step,
            "target": self.target,
            "translation_mm": self.translation * 1000,
            "rotation_arcsec": self.rotation / ARCSEC,
            "joints_max": self.joints,
            "frames": self.frames,
            "cause": self.cause,
        }


def change_cause(frames: list[str], replanned: bool, joints: float, translation: float) -> str:
    """What moved a target, in words: the calibrated frames on its way; else a free path the
    planner found anew in the calibrated cell (its via points are no frame); else a joint
    solution on another branch (joints turned more than 0.05 rad for under a millimetre);
    else the move's start (a move before it ended elsewhere)."""
    if frames:
        return f"calibrated frame{'s' if len(frames) > 1 else ''} {', '.join(frames)}"
    if replanned:
        return "a re-planned free path (no calibrated frame on the way)"
    if joints > 0.05 and translation < 1e-3:
        return "another joint solution (no calibrated frame on the way)"
    return "where the move before it ended (no calibrated frame on the way)"


@dataclass
class ProgramExport:
    """What ``rworld export program`` wrote."""

    output: str
    format: str
    files: list[str]
    devices: list[str]
    moves: int
    changes: list[TargetChange] | None = None
    notes: list[str] = field(default_factory=list)
    compensated: list[dict] | None = None  # --compensate: how far each Cartesian target moved
    samples: int | None = None  # csv: rows per device
    period: float | None = None  # csv: [s]

    def as_dict(self) -> dict:
        return {
            "output": self.output,
            "format": self.format,
            "files": self.files,
            "devices": self.devices,
            "moves": self.moves,
            "changes": None if self.changes is None else [c.as_dict() for c in self.changes],
            "compensated": self.compensated,
            "notes": self.notes,
            "samples": self.samples,
            "period_s": self.period,
        }


def _simulate(cell: str, run: str, dt: float | None, pose_files: list[str] | None):
    from ..schema.programs import load_run
    from ..simulate.engine import SimulationError, simulate
    from .simulation import run_path

    loaded = load_run(cell, run_path(cell, run), dt, pose_files)
    try:
        return loaded, simulate(loaded, collisions=False)
    except SimulationError as exc:  # an unreachable target: the program cannot be exported
        raise CheckFailed(f"cannot export: {exc.message}") from None


def export_program(
    cell: str,
    run: str,
    fmt: str | None,
    output: str,
    device: str | None = None,
    period: str | float | None = None,
    against: list[str] | None = None,
    signals: Signals = Signals(),
    frame: str | None = None,
    compensate: bool = False,
) -> ProgramExport:
    """Write the programs of RUN (or one PROGRAM file) in a robot language.

    Every target is resolved by simulating the run with the cell's current pose files (a
    calibrated overlay included): joint targets are the IK solutions the simulation chose,
    Cartesian targets the TCP there in the robot's base frame, with the tool data of the TCP.

    Parameters
    ----------
    fmt : {"urscript", "krl", "rapid", "fanuc", "inform", "val3", "drl", "sunrise", "csv"} or None
        None: the language of the devices' controller vendor (``controller.vendor``).
    output : str
        The folder to write; its files appear together or not at all.
    device : str, optional
        Export this device's program only (default: every program of the run).
    period : str or float, optional
        CSV: the controller period ('8ms'; default 8 ms).
    against : list of str, optional
        Nominal pose files: list every target the current poses move, by how much and which
        calibrated frame moved it.
    frame : str, optional
        A cell frame to give Cartesian targets in (a user frame: KRL ``BASE_DATA``, RAPID
        ``wobjdata``, URScript ``pose_trans``), placed where it is at the run's start; default
        the robot's base.
    compensate : bool
        For a controller that keeps the nominal kinematics while the cell's pose files hold the
        robot's calibration (``calibrate-robot``): joint targets stay the calibrated model's IK
        solutions, and each Cartesian target is the nominal forward kinematics at them, so the
        controller's own IK takes the robot to the true pose.  ``compensated`` lists how far
        each target moved.

    Raises
    ------
    CheckFailed
        A target the robot cannot reach (exit 1), naming the program file:line and why.
    UserError
        Unknown format or device, a device the format cannot drive (exit 2).
    """
    from ..export import (
        csv_trajectory,
        drl,
        fanuc,
        inform,
        krl,
        rapid,
        sunrise,
        urscript,
        val3,
    )
    from ..kinematics.configuration import is_arm
    from ..kinematics.redundancy import is_seven_axis_arm
    from .planning import parse_period

    loaded_format = fmt is None
    if fmt is None:
        fmt = _vendor_format(cell, run, device)
    if fmt not in FORMATS:
        raise UserError(
            f"unknown format '{fmt}'{did_you_mean(fmt, FORMATS)}; choose one of "
            f"{', '.join(FORMATS)}"
        )
    dt = None
    if fmt == "csv":
        dt = parse_period(period) if isinstance(period, str) else float(period or 0.008)
    elif period is not None:
        raise UserError("--period is for --format csv (a timed trajectory)")
    loaded, result = _simulate(cell, run, dt, None)
    devices = [p.device for p in loaded.programs]
    if device is not None:
        if device not in devices:
            raise UserError(
                f"'{device}' has no program in {run}{did_you_mean(device, devices)}; the run "
                f"drives {', '.join(devices)}"
            )
        devices = [device]
    programs = {p.device: p for p in loaded.programs}
    from ..world.tree import World

    world = World(loaded.cell)  # the run's start: user frames and the controllers' frames
    if frame is not None:
        if frame not in loaded.cell.frames:
            raise UserError(
                f"--frame: unknown frame '{frame}'{did_you_mean(frame, loaded.cell.frames)}"
            )
    files: dict[str, str] = {}
    notes = []
    moves = 0
    compensated: list[dict] = []
    if compensate and fmt == "csv":
        from ..dynamics.compliance import compliances

        if not any(compliances(loaded.cell.devices[d]).any() for d in devices):
            raise UserError(
                "--compensate with --format csv: the joint values stream as they are, unless "
                "a joint's compliance (calibrate-robot --model compliance) asks for commands "
                "that differ; no device here has one"
            )
    for name in devices:
        dev = loaded.cell.devices[name]
        stem = Path(programs[name].file).stem
        if fmt == "csv":
            assert dt is not None
            # the clock's last instant is the run's end, off the period grid: the device is at
            # rest there, so it holds that state on the next tick
            times = dt * np.arange(len(result.times))
            q_stream = result.devices[name].q
            if compensate:  # the commands that put the compliant arm on the simulated joints
                q_stream = _commanded_stream(World(loaded.cell), result, name)
            files.update(
                csv_trajectory.write(
                    stem if len(devices) == 1 else f"{stem}_{name}",
                    [j.name for j in dev.joints],
                    times,
                    q_stream,
                )
            )
            continue
        drivable = is_seven_axis_arm if fmt == "sunrise" else is_arm
        if not drivable(dev):
            kinds = "".join("R" if j.kind == "revolute" else "P" for j in dev.joints)
            arms = [d for d in devices if d != name and drivable(loaded.cell.devices[d])]
            size = "7" if fmt == "sunrise" else "6"
            raise UserError(
                f"{ARM_FORMATS[fmt]} drives {size}-axis arms; '{name}' has {dev.dof} joint(s) "
                f"({kinds}): export it with --format csv"
                + (" or --format sunrise (a 7-axis KUKA LBR)" if is_seven_axis_arm(dev) else "")
                + (f", or choose the arm with --device {' or '.join(arms)}" if arms else "")
            )
        profile = dev.controller
        vendor = profile.vendor if profile is not None else None
        if not loaded_format and vendor in VENDOR_FORMATS and VENDOR_FORMATS[vendor] != fmt:
            notes.append(
                f"'{name}' has a {vendor} controller (controller.vendor), whose language is "
                f"{ARM_FORMATS[VENDOR_FORMATS[vendor]]}; written in {ARM_FORMATS[fmt]} as asked"
            )
        program = _device_program(loaded, result, name, world, frame)
        if compensate:
            holding = _holding_at(World(loaded.cell), result, name)
            moved = _compensate(cell, loaded.cell, name, program, fmt, holding)
            compensated.extend(moved)
        moves += len(program.moves)
        writer = {
            "urscript": urscript,
            "krl": krl,
            "rapid": rapid,
            "fanuc": fanuc,
            "inform": inform,
            "val3": val3,
            "drl": drl,
            "sunrise": sunrise,
        }[fmt]
        for file_name, text in writer.write(program, signals).items():
            if file_name in files:
                file_name = f"{name}_{file_name}"
            files[file_name] = text
    if result.violations:
        notes.append(
            f"the simulation breaks {len(result.violations)} limit(s); 'rworld check' shows them"
        )
    notes.append("collisions are not checked here: gate the run with 'rworld check' first")
    changes = None
    if against is not None:
        changes = _changes(cell, run, dt, against, loaded, result, devices)
    _write_together(output, files)
    return ProgramExport(
        output,
        fmt,
        sorted(files),
        devices,
        moves,
        changes,
        notes,
        compensated if compensate else None,
        len(result.times) if fmt == "csv" else None,
        dt if fmt == "csv" else None,
    )


def _device_program(loaded, result, name: str, world, frame: str | None):
    """One device's program for a writer (:class:`~rworld_cli.export.common.DeviceProgram`),
    named after its program file: its instructions from the simulated run, its controller's
    flange and base, and the user frame ``frame`` placed where it is at the run's start
    (``world``)."""
    from ..export.common import instructions
    from ..world.tree import World

    dev = loaded.cell.devices[name]
    profile = dev.controller
    file = next(p.file for p in loaded.programs if p.device == name)
    flange = [r.move for r in result.resolved[name] if r.move and r.move.link != dev.dof]
    if flange:
        m = flange[0]
        raise UserError(
            f"{m.tcp} sits on link {m.link} of '{name}', not on its flange (link {dev.dof}): "
            "a robot language's tool data is given in the flange frame"
        )
    T_link_flange = None
    if profile is not None and profile.flange is not None:
        T_link_flange = world.mount_of(name, profile.flange)[1]
    program = instructions(
        dev,
        result.resolved[name],
        result.times,
        result.devices[name],
        Path(file).stem,
        file,
        T_link_flange,
        _flange_loads(World(loaded.cell), result, name, T_link_flange),
    )
    program.controller = profile
    if profile is not None and profile.base is not None:
        program.T_base_controller = world.T(name, profile.base)
    if frame is not None:
        program.user_frame = frame
        program.T_base_user = np.linalg.solve(world.T_world(name), world.T_world(frame))
    return program


def _compensate(cell_path: str, cell, device: str, program, fmt: str, holding) -> list[dict]:
    """Replace the targets of ``program`` by what a controller with the nominal kinematics must
    be given to put the calibrated robot on them; the moves' shifts.

    Joint targets: the commands that put the arm's joints there (the same values for a stiff
    arm; ``q - c g(q)`` solved for a compliant one, :func:`rworld_cli.dynamics.compliance.
    commanded`, with what the arm carries at that move: ``holding(t)``).  Cartesian targets:
    the nominal forward kinematics at those commands (the tool as calibrated: the controller's
    tool data).  The nominal kinematics is the cell's device without the pose files that set
    its joints (``joints:``, ``corrections:``, ``compliance:``: what ``calibrate-robot``
    writes).  Listed: the targets whose written values changed in ``fmt``."""
    import dataclasses

    from .. import spatial
    from ..dynamics.compliance import commanded, compliances
    from ..kinematics.forward import link_poses
    from ..schema.loader import load_cell, robot_pose_files

    robot_files = robot_pose_files(cell, device)
    if not robot_files:
        raise UserError(
            f"--compensate: no pose file of the cell sets '{device}''s joints (joints: or "
            "corrections:, as 'rworld calibrate-robot' writes): there is nothing to compensate"
        )
    keep = [str(p) for p in cell.pose_files if p not in robot_files]
    nominal = load_cell(cell_path, pose_files=keep).cell.devices[device]
    calibrated = cell.devices[device]
    compliant = compliances(calibrated).any()
    out = []
    for item in program.moves:
        r = item.resolved
        before, q_before = item.T_target, item.q_target
        new = {}
        for key, qkey in (("T_base_tcp", "q_goal"), ("T_base_planned", "q_planned")):
            q = getattr(r, qkey)
            if q is None or getattr(r, key) is None:
                continue
            if compliant:
                q = commanded(calibrated, q, holding(r.t0))
            new[qkey] = q
            new[key] = link_poses(nominal, q)[r.link - 1] @ r.T_link_tcp
        item.resolved = dataclasses.replace(r, **new)
        after = item.T_target
        shift = float(np.linalg.norm(after[:3, 3] - before[:3, 3]))
        turn = float(np.linalg.norm(spatial.rotation_vector(before[:3, :3].T @ after[:3, :3])))
        joints = float(np.abs(item.q_target - q_before).max(initial=0.0))
        # only what the program writes: a joint move's target is its joint values (RAPID's
        # search alone goes to a robtarget, whatever the move's motion; an INFORM job without
        # the controller's pulses per degree gives every target as a Cartesian position)
        cartesian_joints = fmt == "inform" and (
            calibrated.controller is None or calibrated.controller.pulses_per_degree is None
        )
        if item.motion == "joint" and not (item.guard and fmt == "rapid") and not cartesian_joints:
            shift = turn = 0.0
        elif item.motion == "joint" and cartesian_joints:
            joints = 0.0
        if max(shift, turn, joints) <= 1e-12:
            continue
        out.append(
            {
                "device": device,
                "where": item.where,
                "step": item.text,
                "moved_mm": shift * 1000,
                "turned_deg": float(np.degrees(turn)),
                "joints_deg": float(np.degrees(joints)),
            }
        )
    return out


def _commanded_stream(world, result, device: str) -> np.ndarray:
    """The commanded joint values (K, n) that put ``device``'s arm on its simulated ones, with
    what it carries at each sample (a stiff arm: the simulated values)."""
    from ..dynamics.compliance import commanded

    dev = world.cell.devices[device]
    q = result.devices[device].q
    holding = _holding_at(world, result, device)
    starts = np.array([ts for ts, _ in result.snapshots])
    state = np.searchsorted(starts, result.times + 1e-12, side="right")  # affixment state
    out = q.copy()
    for s in np.unique(state):
        rows = np.flatnonzero(state == s)
        out[rows] = commanded(dev, q[rows], holding(float(result.times[rows[0]])))
    return out


def _holding_at(world, result, device: str):
    """``holding(t)``: the torques that hold ``device`` still as a function of its joint values
    (as :func:`rworld_cli.dynamics.compliance.holding_torques`), with what it carries at instant
    ``t`` of the run; ``world`` is moved through the run."""
    from ..dynamics.core import DeviceDynamics

    dev = world.cell.devices[device]
    built: dict[int, DeviceDynamics] = {}  # per affixment state: what it carries changes there

    def holding(t: float):
        _world_at(world, result, t)
        state = sum(ts <= t + 1e-12 for ts, _ in result.snapshots)
        if state not in built:
            built[state] = DeviceDynamics(dev, link_loads=world.carried_loads(device))
        dynamics = built[state]
        g_base = world.T_world(device)[:3, :3].T @ world.cell.gravity
        return lambda q: dynamics.gravity_torques(q, g_base)

    return holding


def _world_at(world, result, t: float) -> None:
    """Put ``world`` in the run's state at instant ``t``: its affixments and every device's
    joints."""
    world.restore([s for ts, s in result.snapshots if ts <= t + 1e-12][-1])
    k = int(np.searchsorted(result.times, t - 1e-12))
    for d, tl in result.devices.items():
        world.set_joints(d, tl.q[min(k, len(tl.q) - 1)])


def _vendor_format(cell: str, run: str, device: str | None) -> str:
    """The language of the run's devices' controllers, when no format is given."""
    from ..schema.programs import load_run
    from .simulation import run_path

    loaded = load_run(cell, run_path(cell, run))
    names = [p.device for p in loaded.programs if device is None or p.device == device]
    vendors = {}
    for name in names:
        profile = loaded.cell.devices[name].controller
        vendors[name] = profile.vendor if profile is not None else None
    for name, vendor in vendors.items():
        if vendor in VENDOR_WITHOUT_FORMAT:
            raise UserError(
                f"'{name}' has a {vendor} controller (controller.vendor): "
                f"{VENDOR_WITHOUT_FORMAT[vendor]}"
            )
    languages = {VENDOR_FORMATS.get(v or "") for v in vendors.values()}
    if len(languages) == 1 and None not in languages:
        return languages.pop()  # type: ignore[return-value]
    said = ", ".join(f"'{n}' {v or 'no vendor'}" for n, v in vendors.items())
    raise UserError(
        f"give --format ({', '.join(FORMATS)}): the controllers do not name one language "
        f"({said}; set controller.vendor in the cell to export without --format)"
    )


def _flange_loads(world, result, device: str, T_link_flange):
    """``loads(t)``: what the device's flange carries at instant ``t`` of the run, tool and
    payload apart (:class:`rworld_cli.export.common.Load`), from the run's affixment tree.
    ``world`` is moved through the run: give one of its own (user frames are taken from the
    run's start)."""
    from ..export.common import Load
    from ..model.cell import Inertial

    n = world.cell.devices[device].dof
    flange = np.eye(4) if T_link_flange is None else T_link_flange

    def loads(t: float) -> Load:
        _world_at(world, result, t)
        parts: dict[str, list] = {"tool": [], "payload": []}
        names: dict[str, list[str]] = {"tool": [], "payload": []}
        for name, link, bodies in world.carried(device):
            if link != n:
                continue
            aff = world.affixment(name)
            kind = "payload" if aff is not None and aff.kind == "grasp" else "tool"
            names[kind].append(name)
            parts[kind] += [(inertial, np.linalg.solve(flange, T)) for inertial, T in bodies]
        tool = Inertial.combine(parts["tool"]) if parts["tool"] else Inertial.zero()
        payload = Inertial.combine(parts["payload"]) if parts["payload"] else Inertial.zero()
        return Load(tool, payload, names["tool"], names["payload"])

    return loads


def _changes(cell, run, dt, against, loaded, result, devices) -> list[TargetChange]:
    """Targets the current pose files move against the nominal ones (``against``)."""
    from .. import spatial
    from ..world.tree import World

    nominal_run, nominal = _simulate(cell, run, dt, against)
    moved = {
        name
        for name, T in loaded.cell.poses.items()
        if name not in nominal_run.cell.poses
        or not np.allclose(T, nominal_run.cell.poses[name], rtol=0.0, atol=1e-12)
    }
    world = World(loaded.cell)
    ancestors = world.ancestors

    changes = []
    for name in devices:
        for now, then in zip(result.resolved[name], nominal.resolved[name]):
            if now.move is None or then.move is None:
                continue
            a, b = now.move.T_base_tcp, then.move.T_base_tcp
            dp = float(np.linalg.norm(a[:3, 3] - b[:3, 3]))
            dr = float(np.linalg.norm(spatial.rotation_vector(b[:3, :3].T @ a[:3, :3])))
            if dp <= 1e-9 and dr <= 1e-9:
                continue
            target = now.move.target
            feature = loaded.cell.features.get(target)
            if feature is not None:  # a target on a feature moves with the feature's owner
                target = feature.owner
            path = ancestors(target) if target in loaded.cell.frames else []
            path += ancestors(now.move.tcp) + ancestors(name)
            frames = [f for f in dict.fromkeys(path) if f in moved]
            replanned = getattr(now.step.spec, "path", None) == "free" or (
                now.move.target not in loaded.cell.frames and feature is None
            )
            joints = float(np.abs(now.move.q_goal - then.move.q_goal).max())
            changes.append(
                TargetChange(
                    name,
                    now.step.where,
                    now.step.describe(),
                    now.move.target,
                    dp,
                    dr,
                    joints,
                    frames,
                    change_cause(frames, replanned, joints, dp),
                )
            )
    return changes


def _write_together(output: str, files: dict[str, str]) -> None:
    """Write ``files`` as the folder ``output``, replacing an older export whole: after a kill at
    any instant the folder is the complete old export or the complete new one
    (``fileio.output_set``)."""
    from ..fileio import atomic_write_text, output_set

    with output_set(output):
        for name, text in files.items():
            atomic_write_text(Path(output) / name, text)


# --------------------------------------------------------------------------- the way back

CONTACT_TOLERANCE = 0.002  # [m]: how far a contact may lie off its search's line


def _nominal_device(cell_path: str, cell, device: str):
    """The device as its controller knows it: the cell without the pose files that set its
    joints (``joints:``, ``corrections:``, what ``calibrate-robot`` writes); None when the cell
    has none (the controller's model is the cell's)."""
    from ..schema.loader import load_cell, robot_pose_files

    robot_files = robot_pose_files(cell, device)
    if not robot_files:
        return None
    keep = [str(p) for p in cell.pose_files if p not in robot_files]
    return load_cell(cell_path, pose_files=keep).cell.devices[device]


def _logged_joints(
    nominal, T_base_tcp, mount, search, contact, noun: str = "contact"
) -> np.ndarray:
    """The joint values (n,) at which a controller with the ``nominal`` kinematics logged
    ``T_base_tcp``: its inverse kinematics from the move's planned end, to 1e-12 m and rad -
    the controller's, its encoders'.

    Raises
    ------
    UserError
        No joint solution puts the nominal robot on the logged pose (at the log's line)."""
    from ..kinematics.inverse import solve_ik

    found = solve_ik(
        nominal,
        T_base_tcp,
        mount,
        seed=search.q_planned,
        position_tolerance=1e-12,
        rotation_tolerance=1e-12,
    )
    if not found.success:
        raise UserError(
            f"{contact.where}: {noun} {contact.number}: no joint values put the controller's "
            "nominal robot on the logged pose (the log is another robot's, or its frame or "
            "units are not the export's)"
        )
    return np.asarray(found.q, dtype=float)


def _through_calibration(calibrated, q, mount, holding=None) -> np.ndarray:
    """The calibrated robot's TCP pose (4, 4) at the controller's joint values ``q``
    (:func:`_logged_joints`): for a compliant arm (``holding``: its holding torques as a
    function of joint values, with what it carries then) at the arm's ``q + c g(q)``."""
    from ..kinematics.jacobian import tool_pose

    if holding is not None:
        from ..dynamics.compliance import arm_values

        q = arm_values(calibrated, q, holding)
    return tool_pose(calibrated, q, mount)


def _inform_frame(contact, record, program) -> np.ndarray:
    """``T_base_frame`` [m] of an INFORM position variable: the controller's base frame (BASE or
    ROBOT: one frame without a travel axis) or the job's user frame 1; its tool number must be
    the job's for the search's TCP."""
    expected = program.tool_numbers.get(record.tool.name)
    stated = contact.fields.get("tool_number")
    if stated is not None and expected is not None and int(stated) != expected:
        raise UserError(
            f"{contact.where}: {record.kind} {contact.number} was kept with TOOL {stated}, but "
            f"the job {'searched' if record.kind == 'contact' else 'stood'} with TOOL "
            f"{expected} ({record.tool.name}, {record.where})"
        )
    if contact.fields["postype"] != "USER":
        return program.T_base_controller
    if not program.user_frame or contact.fields.get("user") != "1":
        raise UserError(
            f"{contact.where}: {record.kind} {contact.number} is a USER "
            f"{contact.fields.get('user')} position, but the job "
            + (
                f"has user frame 1 ({program.user_frame})"
                if program.user_frame
                else "was given no user frame (--frame: the frame it was exported with)"
            )
        )
    return program.T_base_user


@dataclass
class LoggedReports:
    """A controller's reports of one device's exported program, checked against the program
    and mapped into the device's frame (:func:`logged_reports`).

    Attributes
    ----------
    logged : list of LoggedContact
        The reports as the log holds them, in the program's order.
    records : list of Record
        The program's reports of the kind, one for each.
    events : list of Event
        The simulated run's event of each (its instant, its reading).
    T_base_tcp : list of ndarray, shape (4, 4)
        Each report's TCP pose in the device's natural frame [m], through the robot's
        calibration when the cell has one (the controller logs its nominal kinematics).
    joints : list of ndarray, shape (n,)
        The controller's joint values at each report (its nominal inverse kinematics of the
        logged pose, from the move's planned end), where asked (``joints=True``) or where the
        cell has a robot calibration; else empty.
    """

    loaded: Run
    result: SimulationResult
    device: str
    fmt: str
    world: World
    program: DeviceProgram
    logged: list[LoggedContact]
    records: list[Record]
    events: list[Event]
    T_base_tcp: list[np.ndarray]
    notes: list[str]
    joints: list[np.ndarray]


def logged_reports(
    cell: str,
    run: str,
    log: str,
    kind,
    fmt: str | None = None,
    device: str | None = None,
    frame: str | None = None,
    register: int = 101,
    joints: bool = False,
) -> LoggedReports:
    """Read the reports (``kind``: ``contactlog.CONTACT`` or ``CAPTURE``) a controller logged
    while it ran RUN as ``export program`` wrote it, check them against the program (count,
    order, each report's fields, the frame) and map each logged TCP pose into the device's
    natural frame: through the controller's base frame or the user frame, and - where the cell
    carries a robot calibration - through the nominal robot's joints at the pose into the
    calibrated robot's (:func:`_through_calibration`).

    Raises
    ------
    UserError
        A malformed log (at its line), a count or a field that does not match the program's
        reports, no device with such reports (or several: ``device``)."""
    from ..export.common import field_value
    from ..schema.contactlog import LANGUAGES, read_contact_log
    from ..world.tree import World

    noun = kind.noun
    step_word = {"contact": "probe", "capture": "capture"}[noun]
    loaded, result = _simulate(cell, run, None, None)
    reporting = [
        p.device
        for p in loaded.programs
        if any(r.kind == step_word for r in result.resolved[p.device])
    ]
    if device is None:
        if len(reporting) != 1:
            raise UserError(
                f"{run}: "
                + (
                    f"no program records a {noun} (no '{step_word}:' step)"
                    if not reporting
                    else f"{len(reporting)} devices record {noun}s ({', '.join(reporting)}): "
                    "choose one with --device"
                )
            )
        device = reporting[0]
    elif device not in reporting:
        raise UserError(
            f"--device {device}: its program in {run} records no {noun}"
            + did_you_mean(device, reporting)
        )
    if fmt is None:
        profile = loaded.cell.devices[device].controller
        vendor = profile.vendor if profile is not None else None
        if vendor not in VENDOR_FORMATS or VENDOR_FORMATS[vendor] not in LANGUAGES:
            raise UserError(
                f"give --format ({', '.join(LANGUAGES)}): '{device}' names no controller vendor "
                "(controller.vendor) whose log rworld reads"
            )
        fmt = VENDOR_FORMATS[vendor]
    if fmt not in LANGUAGES:
        raise UserError(f"--format {fmt}: {noun} logs are read for {', '.join(LANGUAGES)}")
    expected_count = sum(r.kind == step_word for r in result.resolved[device])
    logged = read_contact_log(log, fmt, register, expected_count, kind)
    stated = {c.fields["frame"] for c in logged.contacts if "frame" in c.fields} - {"base"}
    if fmt != "urscript" and stated:
        if len(stated) > 1:
            raise UserError(f"{log}: {noun}s in several frames ({', '.join(sorted(stated))})")
        named = stated.pop()
        if frame is None:
            frame = next((f for f in loaded.cell.frames if field_value(f) == named), None)
            if frame is None:
                raise UserError(f"{log}: frame={named} is no frame of the cell")
        elif field_value(frame) != named:
            raise UserError(f"--frame {frame}, but the log's {noun}s are in frame={named}")
    if frame is not None and frame not in loaded.cell.frames:
        raise UserError(
            f"--frame: unknown frame '{frame}'{did_you_mean(frame, loaded.cell.frames)}"
        )
    world = World(loaded.cell)
    program = _device_program(loaded, result, device, world, frame)
    records = program.contacts if noun == "contact" else program.captures
    contacts = logged.contacts
    if len(contacts) != len(records):
        if len(contacts) > len(records):
            extra = contacts[len(records)]
            raise UserError(
                f"{extra.where}: {noun} {extra.number}: the program records "
                f"{len(records)} {noun}(s), the log {len(contacts)}"
            )
        gone = records[len(contacts)]
        last = contacts[-1].where if contacts else log
        raise UserError(
            f"{last}: the log holds {len(contacts)} of the program's {len(records)} {noun}s: "
            f"{noun} {gone.number} ({gone.feature}, step {gone.step}, {gone.where}) and after "
            "it are missing (the program stopped, or its log was cut)"
        )
    if logged.count is not None and logged.count != len(records):
        variable = f"{kind.krl}_COUNT"
        raise UserError(
            f"{log}: {variable} = {logged.count}: the program recorded {logged.count} of its "
            f"{len(records)} {noun}s (the values after it are an earlier run's)"
        )
    events = [e for e in result.events if e.device == device and e.kind == step_word]
    dev = loaded.cell.devices[device]
    nominal = _nominal_device(cell, loaded.cell, device)  # None: no robot calibration
    from ..dynamics.compliance import compliances
    from ..kinematics.jacobian import ToolMount

    # a compliant arm yields under what holds it: the holding torques at each report's instant
    holding_at = _holding_at(World(loaded.cell), result, device) if compliances(dev).any() else None
    poses, logged_q = [], []
    for contact, record, event in zip(contacts, records, events, strict=True):
        expected = {
            "program": field_value(program.name),
            "step": str(record.step),
            "feature" if noun == "contact" else "camera": field_value(record.feature),
            "tcp": field_value(record.tool.name),
            "frame": "base" if fmt == "urscript" else field_value(program.user_frame or "base"),
        }
        if contact.number != record.number:
            raise UserError(
                f"{contact.where}: {noun} {contact.number} where {noun} {record.number} "
                "was expected (the reports run 1, 2, ... in the program's order)"
            )
        if contact.total and contact.total != len(records):
            raise UserError(
                f"{contact.where}: {noun} {contact.number}/{contact.total}: this program "
                f"records {len(records)} {noun}s: the log is another program's"
            )
        for key, value in expected.items():
            if key in contact.fields and contact.fields[key] != value:
                raise UserError(
                    f"{contact.where}: {noun} {contact.number}: {key}={contact.fields[key]}, "
                    f"but the program's {noun} {record.number} has {key}={value} "
                    f"({record.where})"
                )
        if fmt == "inform":  # each position variable says its own frame and tool
            T_base_frame = _inform_frame(contact, record, program)
        else:
            user = program.T_base_user if fmt != "urscript" and program.user_frame else None
            T_base_frame = user if user is not None else program.T_base_controller
        T_base_tcp = T_base_frame @ contact.T_frame_tcp
        if nominal is not None or joints:  # the controller's joints: its nominal IK
            assert record.search is not None and record.tool is not None
            move = record.search.resolved
            mount = ToolMount(move.link, move.T_link_tcp)
            q = _logged_joints(
                nominal if nominal is not None else dev, T_base_tcp, mount, move, contact, noun
            )
            logged_q.append(q)
            if nominal is not None:  # the controller's nominal view undone: its joints, ours
                holding = holding_at(event.t) if holding_at is not None else None
                T_base_tcp = _through_calibration(dev, q, mount, holding)
        poses.append(T_base_tcp)
    return LoggedReports(
        loaded,
        result,
        device,
        fmt,
        world,
        program,
        contacts,
        records,
        events,
        poses,
        logged.notes,
        logged_q,
    )


def measure_from_log(
    cell: str,
    run: str,
    log: str,
    output: str,
    fmt: str | None = None,
    device: str | None = None,
    frame: str | None = None,
    sigma: float | None = None,
    contact_register: int = 101,
    tolerance: float = CONTACT_TOLERANCE,
) -> dict:
    """Read the contacts a controller logged while it ran an exported probe program, and write
    them as a measurement file (``rworld measure --from-log``): the report's steps 5-6 on a
    real cell.

    The run is simulated on the cell as it is now (the pose files the program was exported
    with), which gives each ``probe:`` its search: the guarded move, its TCP and sensor, and the
    controller's frames.  Each logged TCP pose is mapped through the controller's base frame
    (or the user frame the program used) into the device's frame, the sensor's offset on the
    TCP applied, and placed in the world; the measurement file holds those points as
    ``measure --simulate --program`` writes them (planes' and circles' outside points, lines
    in probing order).

    A controller keeps its nominal kinematics: where the cell carries a robot calibration
    (pose files with ``joints:`` or ``corrections:``, as ``calibrate-robot`` writes them), the
    pose a controller logs is its nominal forward kinematics at the joints it stood at.  Those
    joints are found again (the nominal inverse kinematics of the logged pose, from the
    search's planned end), and the TCP is the calibrated robot's at them - for a compliant arm
    (``compliance:``) at the arm's joints, ``q + c g(q)`` with what it carries at the contact.

    Parameters
    ----------
    fmt : {"urscript", "rapid", "krl", "fanuc", "inform", "drl", "val3", "sunrise"} or None
        The log's language; None: the device's ``controller.vendor``'s.
    frame : str, optional
        The user frame the program was exported with (``export program --frame``); the
        reports' own ``frame=`` is taken when it names one.
    sigma : float, optional
        The probing's 1-sigma noise [m], written in the file for ``calibrate``.
    contact_register : int
        FANUC: the position register, INFORM: the position variable of contact 1.
    tolerance : float
        How far a contact may lie off its search's line, or outside its ends [m].

    Raises
    ------
    UserError
        A malformed log (at its line), a count or a field that does not match the program's
        searches, a contact off its search's line (at its line); nothing written.
    """
    from ..calibration.probe_run import ProbedPoint, measurement_features
    from ..kinematics.jacobian import ToolMount, tool_pose
    from ..schema.contactlog import CONTACT
    from ..schema.measurements import today, write_measurements

    if not (tolerance > 0 and np.isfinite(tolerance)):
        raise UserError(f"--tolerance must be a finite length > 0, got {tolerance}")
    if sigma is not None and not (sigma > 0 and np.isfinite(sigma)):
        raise UserError(f"--sigma must be a finite length > 0, got {sigma}")
    got = logged_reports(cell, run, log, CONTACT, fmt, device, frame, contact_register)
    loaded, device, fmt, world = got.loaded, got.device, got.fmt, got.world
    program, records, contacts = got.program, got.records, got.logged
    dev = loaded.cell.devices[device]
    T_world_base = world.T_world(device)
    probed, report = [], []
    for contact, record, event, T_base_tcp in zip(
        contacts, records, got.events, got.T_base_tcp, strict=True
    ):
        assert record.search is not None and event.reading is not None  # a contact has both
        search = record.search.resolved
        sensor = search.guard
        assert sensor is not None  # a probe's search is guarded
        T_tcp_sensor = world.T(search.tcp, sensor)
        mount = ToolMount(search.link, search.T_link_tcp)
        # the search's line: the sensor's origin from the move's start to its planned end
        ends = tool_pose(dev, np.array([search.q_start, search.q_planned]), mount) @ T_tcp_sensor
        start, end = ends[0, :3, 3], ends[1, :3, 3]
        at = (T_base_tcp @ T_tcp_sensor)[:3, 3]
        line = end - start
        length = float(np.linalg.norm(line))
        along = float((at - start) @ line / length)
        off = float(np.linalg.norm(at - start - along * line / length))
        # written so that a NaN anywhere is outside (every comparison with NaN is False)
        if not (off <= tolerance and -tolerance <= along <= length + tolerance):
            raise UserError(
                f"{contact.where}: contact {contact.number} ({record.feature}, step "
                f"{record.step}) lies {off * 1000:.3f} mm off its search's line and "
                f"{along * 1000:.3f} mm along its {length * 1000:.3f} mm (at most "
                f"{tolerance * 1000:g} mm off, within its ends): not this search's contact, or "
                "the log's frame or units are not the export's"
            )
        point = (T_world_base @ np.append(at, 1.0))[:3]
        probed.append(
            ProbedPoint(
                record.feature,
                record.step,
                record.where,
                np.array(event.reading["point"]),
                None,
                reported=point,
            )
        )
        report.append(
            {
                "contact": contact.number,
                "feature": record.feature,
                "step": record.step,
                "where": record.where,
                "log": contact.where,
                "point_mm": (point * 1000).tolist(),
                "from_simulated_mm": float(
                    np.linalg.norm(point - np.array(event.reading["point"])) * 1000
                ),
            }
        )
    features = measurement_features(loaded.cell, probed, 0.0, 0)
    guards = [r.search.resolved.guard for r in records if r.search is not None]
    radii = {float(loaded.cell.sensors[g].ball or 0.0) for g in guards if g is not None}
    write_measurements(
        output,
        features,
        loaded.cell.name,
        [
            f"Contacts logged by {device}'s controller ({ARM_FORMATS[fmt]}), read by rworld "
            "measure --from-log",
            f"log: {log}, run: {run}, frame: {program.user_frame or 'base'}",
        ],
        sigma=sigma,
        probe_radius=radii.pop() if len(radii) == 1 else 0.0,
        instrument=f"{device} probing ({ARM_FORMATS[fmt]} contact log)",
        date=today(),
    )
    return {
        "written": output,
        "device": device,
        "format": fmt,
        "contacts": report,
        "features": sorted(features),
        "points": {k: len(v.points) for k, v in features.items()},
        "notes": got.notes,
    }
