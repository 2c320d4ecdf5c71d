"""What every robot-language writer shares: the program as instructions, names, rotations.

:func:`instructions` turns one device's resolved steps (what the simulation carried out, with the
cell's current pose files) and its timeline into a neutral list of instructions - tool data,
joint moves with their joint targets, linear moves with their Cartesian targets, outputs, waits
and comments - with speeds and accelerations measured on the simulated motion.  Each writer
renders that list in its language; none resolves a target itself.
"""

from __future__ import annotations

import abc
import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from .. import spatial
from ..errors import UserError
from ..kinematics.configuration import (  # noqa: F401
    abb_confdata,
    as_written,
    fanuc_config,
    kuka_status_turn,
)
from ..model.cell import ControllerProfile, Inertial
from ..model.program import MoveTarget, ResolvedStep

if TYPE_CHECKING:
    from . import Signals


@dataclass
class Tool:
    """Tool data: the TCP in the flange (last link) frame."""

    name: str  # the qualified TCP frame
    T_flange_tcp: np.ndarray


@dataclass
class Move:
    """A move to a target: the simulation's resolved move with the speeds measured on it.

    Attributes
    ----------
    resolved : MoveTarget
        What the simulation did: motion, joint target (the IK solution it chose), TCP pose in
        the base frame, the step's speed fractions, a guard's sensor and planned end.
    tool : Tool
    joint_speed, joint_acceleration : float
        Peak of the leading joint over the simulated move [rad/s, rad/s^2].
    tool_speed, tool_acceleration : float
        Peak TCP speed and acceleration over the simulated move [m/s, m/s^2].
    where, text : str
        The program's ``file:line`` and the step in words.
    """

    resolved: MoveTarget
    tool: Tool
    joint_speed: float
    joint_acceleration: float
    tool_speed: float
    tool_acceleration: float
    where: str
    text: str
    configuration: dict[str, str] | None = None  # shoulder, elbow, wrist at the joint target

    @property
    def motion(self) -> str:
        return self.resolved.motion

    @property
    def guard(self) -> str | None:
        """A guarded move's sensor: the writers make it a search towards the planned end that
        stops when the sensor's input closes."""
        return self.resolved.guard

    @property
    def q(self) -> np.ndarray:
        """Where the simulation ended the move (stopped, for a guarded one) [rad]."""
        return self.resolved.q_goal

    @property
    def speed_fraction(self) -> float:
        return self.resolved.speed

    @property
    def acceleration_fraction(self) -> float:
        return self.resolved.acceleration

    @property
    def q_target(self) -> np.ndarray:
        """The joint target to write: the search's end for a guarded move."""
        r = self.resolved
        return r.q_planned if r.guard and r.q_planned is not None else r.q_goal

    @property
    def blend(self):
        """A via point of a planned path passed without stopping: its
        :class:`~rworld_cli.model.program.BlendZone` (None: the move ends at rest)."""
        return self.resolved.blend

    @property
    def T_target(self) -> np.ndarray:
        """The Cartesian target to write (base frame): the search's end for a guarded move."""
        r = self.resolved
        return r.T_base_planned if r.guard and r.T_base_planned is not None else r.T_base_tcp


@dataclass
class Load:
    """What the flange carries from here on (the cell's state at the next move): the tool
    (hands, tools attached) and the payload (grasped parts), each as mass properties in the
    flange frame.

    Attributes
    ----------
    tool, payload : Inertial
        Mass [kg], centre of mass [m] and inertia about it [kg m^2], flange axes.
    tool_names, payload_names : list of str
    """

    tool: Inertial
    payload: Inertial
    tool_names: list[str]
    payload_names: list[str]

    @property
    def total(self) -> Inertial:
        return Inertial.combine([(self.tool, np.eye(4)), (self.payload, np.eye(4))])

    def describe(self) -> str:
        what = [
            f"{', '.join(names)} {part.mass:g} kg"
            for names, part in ((self.tool_names, self.tool), (self.payload_names, self.payload))
            if names
        ]
        return "load on the flange: " + ("; ".join(what) if what else "none")


def principal(inertial: Inertial) -> tuple[np.ndarray, np.ndarray]:
    """(principal moments (3,) [kg m^2], rotation (3, 3) whose columns are the principal axes in
    the flange frame, a proper rotation)."""
    moments, axes = np.linalg.eigh(inertial.inertia)
    # equal moments (a rod, a sphere) leave any axes in their plane principal, and LAPACK may
    # pick others on every call: take the flange's own axes projected into that plane
    scale = max(float(np.abs(moments).max()), 1e-30)
    k = 0
    while k < 3:
        j = k
        while j + 1 < 3 and abs(moments[j + 1] - moments[k]) <= 1e-9 * scale:
            j += 1
        if j > k:
            P = axes[:, k : j + 1] @ axes[:, k : j + 1].T
            basis: list[np.ndarray] = []
            for e in np.eye(3):
                v = P @ e - sum((b @ (P @ e)) * b for b in basis)
                if np.linalg.norm(v) > 1e-6 and len(basis) < j - k + 1:
                    basis.append(v / np.linalg.norm(v))
            axes[:, k : j + 1] = np.array(basis).T
        k = j + 1
    for c in range(3):  # each axis along the flange axis it is nearest, not against it
        if axes[np.argmax(np.abs(axes[:, c])), c] < 0:
            axes[:, c] *= -1
    if np.linalg.det(axes) < 0:
        axes[:, 2] *= -1
    return np.maximum(moments, 0.0), axes


@dataclass
class Output:
    """A digital output: the gripper (grasp closes, release and place open) or the tool changer
    (attach locks, detach unlocks)."""

    signal: str  # "gripper" | "tool_changer"
    value: bool
    where: str
    text: str


@dataclass
class Wait:
    seconds: float
    where: str
    text: str


@dataclass
class Comment:
    """A step with no instruction of its own (a sync, a wait for another device, a sensor
    reading): kept as a comment with when it happened in the simulation."""

    text: str
    where: str


@dataclass
class Record:
    """A report the controller logs with the TCP's pose: a probe step's contact (where the
    last search stopped, a probe point of a feature) or a capture step's image (where the
    robot stood when it triggered the camera).

    Every language writes the same fields (:func:`report_fields`, ``docs/export.md``): the
    report's number of the program's reports of its kind, the program, the step, its
    ``file:line``, the feature (a contact) or the camera (a capture), the TCP and, for a
    contact, the search's direction; the controller adds where the TCP is.

    Attributes
    ----------
    feature : str
        A contact's feature; a capture's camera.
    kind : {"contact", "capture"}
    number, total : int
        This report's number (1-based) and how many of its kind the program records.
    step : int
        The probe or capture step's number in its program (1-based).
    search : Move
        The guarded move whose contact this records; a capture's: the move that took the
        robot there.
    direction : ndarray, shape (3,)
        The search's direction in the device's natural frame (unit; the TCP's travel).
    tool : Tool or None
        The tool whose TCP the controller reports (a contact: its search's).
    """

    feature: str
    where: str
    text: str
    number: int = 0
    total: int = 0
    step: int = 0
    search: Move | None = None
    direction: np.ndarray = field(default_factory=lambda: np.zeros(3))
    kind: str = "contact"
    tool: Tool | None = None

    @property
    def mark(self) -> str:
        """What the report's line starts with: 'rworld contact' or 'rworld capture'."""
        return CAPTURE_MARK if self.kind == "capture" else CONTACT_MARK


Instruction = Tool | Load | Move | Output | Wait | Comment | Record


@dataclass
class DeviceProgram:
    """One device's program, ready for a writer."""

    device: str
    name: str  # the program's name (file stem)
    source: str  # the program file
    joint_names: list[str]
    instructions: list[Instruction] = field(default_factory=list)
    user_frame: str | None = None  # the cell frame Cartesian targets are given in (else the base)
    T_base_user: np.ndarray | None = None  # the user frame in the device's natural frame
    controller: ControllerProfile | None = None  # flange, base and axes (None: the defaults)
    T_base_controller: np.ndarray = field(default_factory=lambda: np.eye(4))  # its base frame

    def in_user(self, T_base_tcp: np.ndarray) -> np.ndarray:
        """A Cartesian target in the user frame, or in the controller's base frame when there
        is none (``T_base_tcp`` in the device's natural frame)."""
        T = self.T_base_user if self.T_base_user is not None else self.T_base_controller
        return np.linalg.solve(T, T_base_tcp)

    @property
    def T_controller_user(self) -> np.ndarray:
        """The user frame as the controller holds it: in its base frame."""
        user = self.T_base_user if self.T_base_user is not None else self.T_base_controller
        return np.linalg.solve(self.T_base_controller, user)

    def axes(self, q) -> np.ndarray:
        """The controller's axis values of the cell's joint values (the joint map)."""
        return self.controller.axes(q) if self.controller is not None else np.asarray(q)

    def conventions(self) -> list[str]:
        """What the program assumes of the controller, one comment line each."""
        c = self.controller
        flange = c.flange if c and c.flange else "the last link's (no controller flange given)"
        base = c.base if c and c.base else f"'{self.device}' (no controller base given)"
        axes = (
            "the cell's joint values"
            if c is None or c.identity
            else "the cell's joint map (controller.axes)"
        )
        if c is not None and c.coupling is not None and np.any(c.coupling):
            i, j = np.nonzero(c.coupling)
            axes += "; " + ", ".join(
                f"axis {a + 1} counts {c.coupling[a, b]:+g} x joint {b + 1} (a parallel linkage)"
                for a, b in zip(i, j)
            )
        return [
            f"tool data in the flange frame: {flange}",
            f"targets in the base frame: {base}",
            f"axis values: {axes}",
        ]

    def direction_in_user(self, d_base: np.ndarray) -> np.ndarray:
        """A direction of the device's natural frame in the user frame (else the controller's
        base frame)."""
        T = self.T_base_user if self.T_base_user is not None else self.T_base_controller
        return T[:3, :3].T @ d_base

    @property
    def moves(self) -> list[Move]:
        return [i for i in self.instructions if isinstance(i, Move)]

    @property
    def records(self) -> list[Record]:
        """Every report the program logs: contacts and captures."""
        return [i for i in self.instructions if isinstance(i, Record)]

    @property
    def contacts(self) -> list[Record]:
        return [r for r in self.records if r.kind == "contact"]

    @property
    def captures(self) -> list[Record]:
        return [r for r in self.records if r.kind == "capture"]

    @property
    def tools(self) -> list[Tool]:
        """The distinct tools, in order of first use."""
        out: dict[str, Tool] = {}
        for i in self.instructions:
            if isinstance(i, Tool) and i.name not in out:
                out[i.name] = i
        return list(out.values())

    @property
    def tool_numbers(self) -> dict[str, int]:
        """Each tool's number on the controller (1, 2, ... in order of first use): KRL's
        ``TOOL_DATA[k]``, FANUC's ``UTOOL[k]``, INFORM's ``TOOL k``."""
        return {t.name: k + 1 for k, t in enumerate(self.tools)}


MIN_SPEED = 1e-3  # [m/s, rad/s and their /s]: no speed written is lower


def _commanded(device, move: MoveTarget) -> tuple[float, ...]:
    """The speeds a move's step asks for: its fractions of the slowest joint's limits (1 rad/s
    and 1 rad/s^2 where none is given) and of the Cartesian limits.  What a move too short to
    measure is written at: a robot not exactly where the simulation had it still moves there
    at a working speed, not at 1 mm/s."""
    from ..units import LINEAR_ACCELERATION, LINEAR_SPEED

    def slowest(kind: str) -> float:
        limits = device.limit_array(kind)
        finite = limits[np.isfinite(limits)]
        return float(finite.min()) if len(finite) else 1.0

    return (
        move.speed * slowest("velocity"),
        move.acceleration * slowest("acceleration"),
        move.speed * LINEAR_SPEED,
        move.acceleration * LINEAR_ACCELERATION,
    )


def _peaks(device, mount, times, timeline, move: MoveTarget) -> tuple[float, ...]:
    """Peak joint speed and acceleration, peak TCP speed and acceleration over the move's time
    of the simulated motion (each at least ``MIN_SPEED``); the step's commanded speeds for a
    move too short to measure (:func:`_commanded`)."""
    from ..kinematics.jacobian import tool_pose

    t0, t1 = move.t0, move.t1
    inside = np.flatnonzero((times >= t0 - 1e-12) & (times <= t1 + 1e-12))
    if len(inside) < 2:  # already there, or over within a clock step
        return tuple(max(x, MIN_SPEED) for x in _commanded(device, move))
    dt = float(times[1] - times[0])
    p = tool_pose(device, timeline.q[inside], mount)[:, :3, 3]
    v = np.linalg.norm(np.diff(p, axis=0), axis=1) / dt
    a = np.abs(np.diff(v)) / dt if len(v) > 1 else np.zeros(1)
    peaks = (
        np.abs(timeline.qd[inside]).max(),
        np.abs(timeline.qdd[inside]).max(),
        v.max(initial=0.0),
        a.max(initial=0.0),
    )
    return tuple(max(float(x), MIN_SPEED) for x in peaks)


def instructions(
    device,
    resolved: list[ResolvedStep],
    times,
    timeline,
    name: str,
    source: str,
    T_link_flange: np.ndarray | None = None,
    loads=None,
) -> DeviceProgram:
    """The instructions of one device's program.

    Parameters
    ----------
    device : DeviceModel
    resolved : list of ResolvedStep
        From the simulation (``SimulationResult.resolved[device]``).
    times : ndarray, shape (K,)
    timeline : DeviceTimeline
        The device's simulated motion (for speeds and accelerations).
    T_link_flange : ndarray, shape (4, 4), optional
        The controller's flange in the last link's frame: tool data is given in it.
    loads : callable, optional
        ``loads(t) -> Load``: what the flange carries at instant ``t``; a :class:`Load` is
        written before each move whose load differs from the last one written.
    """
    from ..kinematics.configuration import arm_configurations, is_arm
    from ..kinematics.jacobian import ToolMount, tool_pose

    program = DeviceProgram(device.name, name, source, [j.name for j in device.joints])
    tool: Tool | None = None
    load: Load | None = None
    search: Move | None = None  # the last guarded move: what a probe records
    last: Move | None = None  # the last move: where a capture stands
    records: list[Record] = []  # the contacts
    captures: list[Record] = []
    for item in resolved:
        step, move = item.step, item.move
        text = step.describe()
        kind = item.kind
        if move is not None and loads is not None:
            now = loads(move.t0)
            if load is None or now.describe() != load.describe():
                load = now
                program.instructions.append(load)
        if move is not None:
            if tool is None or tool.name != move.tcp:
                flange = np.eye(4) if T_link_flange is None else T_link_flange
                tool = Tool(move.tcp, np.linalg.solve(flange, move.T_link_tcp))
                program.instructions.append(tool)
            mount = ToolMount(move.link, move.T_link_tcp)
            v_joint, a_joint, v_tool, a_tool = _peaks(device, mount, times, timeline, move)
            item_move = Move(move, tool, v_joint, a_joint, v_tool, a_tool, step.where, text)
            if is_arm(device):
                item_move.configuration = arm_configurations(device, item_move.q_target).names()
            program.instructions.append(item_move)
            last = item_move
            if move.guard:
                search = item_move
        elif kind in ("grasp", "release", "place"):
            program.instructions.append(Output("gripper", kind == "grasp", step.where, text))
        elif kind in ("attach_tool", "detach_tool"):
            program.instructions.append(
                Output("tool_changer", kind == "attach_tool", step.where, text)
            )
        elif kind == "probe":
            if search is None:  # the simulation records no contact without a guarded move
                raise ValueError(f"{step.where}: a probe record with no guarded move before it")
            r = search.resolved
            mount = ToolMount(r.link, r.T_link_tcp)
            travel = search.T_target[:3, 3] - tool_pose(device, r.q_start, mount)[:3, 3]
            records.append(
                Record(
                    item.feature or step.spec.feature,
                    step.where,
                    text,
                    len(records) + 1,
                    0,
                    step.index + 1,
                    search,
                    travel / max(float(np.linalg.norm(travel)), 1e-12),
                    tool=search.tool,
                )
            )
            program.instructions.append(records[-1])
        elif kind == "capture":
            # stand still, trigger the camera, log the pose, hold the trigger for the exposure
            spec = step.spec
            if tool is None or last is None:
                raise UserError(
                    f"{step.where}: a capture before the program's first move: the pose the "
                    "controller logs is of the tool a move sets; move first"
                )
            program.instructions.append(Wait(spec.settle, step.where, f"{text}: settle"))
            program.instructions.append(Output("camera", True, step.where, f"{text}: trigger"))
            captures.append(
                Record(
                    spec.camera,
                    step.where,
                    text,
                    len(captures) + 1,
                    0,
                    step.index + 1,
                    last,
                    kind="capture",
                    tool=tool,
                )
            )
            program.instructions.append(captures[-1])
            program.instructions.append(Wait(spec.exposure, step.where, f"{text}: exposure"))
            program.instructions.append(Output("camera", False, step.where, f"{text}: trigger off"))
        elif kind == "wait" and step.spec.time is not None:
            program.instructions.append(Wait(float(step.spec.time), step.where, text))
        else:
            program.instructions.append(
                Comment(f"{text} (at t = {item.t0:.3f} s in the simulation)", step.where)
            )
    for group in (records, captures):
        for record in group:
            record.total = len(group)
    return program


# --------------------------------------------------------------------------- contact reports

CONTACT_MARK = "rworld contact"  # starts every contact report, in every language
CAPTURE_MARK = "rworld capture"  # starts every capture report


def field_value(text: object) -> str:
    """A report field's value: letters, digits and ``_ . : / -`` (anything else ``_``), so it
    sits in any language's string literal and the report splits on spaces."""
    return re.sub(r"[^A-Za-z0-9_.:/-]", "_", str(text)) or "_"


def report_fields(program: DeviceProgram, record: Record, unit: str, user: bool = True) -> str:
    """The fields of a report that the export knows (``docs/export.md``)::

        rworld contact 3/12 program=probe step=5 line=programs/probe.yaml:40
        feature=plate.top tcp=puma.probe frame=base unit=mm dir=0,0,-1

        rworld capture 2/8 program=views step=5 line=programs/views.yaml:21
        camera=wrist_camera tcp=wrist_camera frame=base unit=mm

    ``frame`` is the frame the controller reports the TCP in: ``base`` (its base frame) or the
    cell frame given as the user frame; ``unit`` the length unit of the reported position;
    ``dir`` a search's direction in that frame.  ``user``: the controller reports in the
    program's user frame (else always in its base frame).
    """
    frame = (program.user_frame or "base") if user else "base"
    tcp = record.tool.name if record.tool is not None else "_"
    what = "camera" if record.kind == "capture" else "feature"
    text = (
        f"{record.mark} {record.number}/{record.total} program={field_value(program.name)} "
        f"step={record.step} line={field_value(record.where)} "
        f"{what}={field_value(record.feature)} tcp={field_value(tcp)} "
        f"frame={field_value(frame)} unit={unit}"
    )
    if record.kind == "capture":
        return text
    if user:
        d = program.direction_in_user(record.direction)
    else:
        d = program.T_base_controller[:3, :3].T @ record.direction
    return text + f" dir={','.join(number(x, 6) for x in d)}"


def report_lines(fields: str, head: str, limit: int, holder: str) -> list[str]:
    """A report's fields (``report_fields``) in lines of at most ``limit`` bytes, each
    beginning with ``head`` ('rworld contact K/N', 'rworld capture K/N') and holding whole
    ``key=value`` fields: for a language whose log message (``holder``: "DRL's tp_log") holds
    less than a report.

    Raises
    ------
    UserError
        A field longer than a line can hold (a program path of some 200 characters)."""
    out: list[str] = []
    line = head
    for item in fields[len(head) :].split():
        if len(f"{head} {item}".encode()) > limit:
            raise UserError(
                f"a report's field is longer than {holder} holds ({limit} bytes): "
                f"{item[:60]}...; shorten the program's path or the feature's name"
            )
        if len(f"{line} {item}".encode()) > limit:
            out.append(line)
            line = head
        line += f" {item}"
    out.append(line)
    return out


# --------------------------------------------------------------------------- conventions


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """UR's rotation vector: axis times angle [rad], angle in [0, pi]."""
    return spatial.rotation_vector(R)


def kuka_abc(R: np.ndarray) -> np.ndarray:
    """KUKA's A, B, C [deg]: ``R = Rz(A) Ry(B) Rx(C)`` (Z-Y'-X'' intrinsic)."""
    roll, pitch, yaw = spatial.matrix_to_rpy(R)
    return np.degrees([yaw, pitch, roll])


def xyz_wpr(T) -> tuple[float, ...]:
    """X, Y, Z [mm] and the angles about the fixed x, y, z axes [deg] of a pose (``R = Rz Ry
    Rx``): FANUC's W, P, R and Yaskawa's Rx, Ry, Rz alike."""
    r, p, w = kuka_abc(np.asarray(T)[:3, :3])
    x, y, z = np.asarray(T)[:3, 3] * 1000
    return (x, y, z, w, p, r)


def abb_quaternion(R: np.ndarray) -> np.ndarray:
    """ABB's orientation quaternion ``[q1, q2, q3, q4] = (w, x, y, z)``, ``q1 >= 0``."""
    return spatial.matrix_to_quat(R)


class Writer(abc.ABC):
    """One robot language's formatter over a resolved program: a method per instruction kind
    behind one walk (:func:`walk`) - the shape of the field's post-processors (RoboDK's: a
    class per controller with MoveJ, MoveL, setTool, setDO, ...).

    A language subclasses it, sets ``language`` (its text rules: every name and text from a
    file reaches the program through ``self.language``, :meth:`note`) and ``indent``, starts
    its files in ``__init__`` with its statements in ``body``, and writes every abstract method;
    a kind it leaves out fails at once, never as a silent gap in a program.  Comments, outputs
    and waits are written here: the instruction's place and text as a comment
    (:meth:`remark`), then the language's statements (:meth:`set_output`, :meth:`pause`).

    Attributes
    ----------
    program : DeviceProgram
    signals : Signals
    used : set of str
        The identifiers taken so far (:meth:`Language.identifier`).
    index : int
        The place of the instruction being written in ``program.instructions`` (0-based).
    body : list of str
        The program's statements so far, each line with its indent.
    """

    language: ClassVar[Language]
    indent: ClassVar[str]  # of a statement in the program's body

    def __init__(self, program: DeviceProgram, signals: Signals):
        self.program, self.signals = program, signals
        self.used: set[str] = set()
        self.index = -1
        self.body: list[str] = []

    def note(self, text: object) -> str:
        """``text`` (from a file) as this language's comment text."""
        return self.language.comment(text)

    def remark(self, where: object, text: object) -> list[str]:
        """An instruction's place in its file and its text as comment lines of the body."""
        prefix = self.language.comment_prefix
        return [f"{self.indent}{prefix} {self.note(where)}: {self.note(text)}"]

    def comment(self, item: Comment) -> None:
        self.body += self.remark(item.where, item.text)

    def output(self, item: Output) -> None:
        self.body += self.remark(item.where, item.text)
        self.body += [self.indent + line for line in self.set_output(item)]

    def wait(self, item: Wait) -> None:
        self.body += self.remark(item.where, item.text)
        self.body += [self.indent + line for line in self.pause(item.seconds)]

    @abc.abstractmethod
    def set_output(self, item: Output) -> list[str]:
        """The statements (without the indent) that set a digital output."""

    @abc.abstractmethod
    def pause(self, seconds: float) -> list[str]:
        """The statements (without the indent) that wait ``seconds`` [s]."""

    @abc.abstractmethod
    def tool(self, item: Tool) -> None: ...

    @abc.abstractmethod
    def load(self, item: Load) -> None: ...

    @abc.abstractmethod
    def move(self, item: Move) -> None: ...

    @abc.abstractmethod
    def record(self, item: Record) -> None: ...

    @abc.abstractmethod
    def files(self) -> dict[str, str]:
        """The program's files, ``{file name: text}``, once every instruction is written."""


_METHODS = {Tool: "tool", Load: "load", Move: "move", Output: "output", Wait: "wait",
            Comment: "comment", Record: "record"}  # fmt: skip


def walk(writer: Writer) -> dict[str, str]:
    """The one walk over a program's instructions: each to its writer's method, in order."""
    for writer.index, item in enumerate(writer.program.instructions):
        getattr(writer, _METHODS[type(item)])(item)
    return writer.files()


@dataclass(frozen=True)
class Language:
    """What a robot language lets a name or a comment be.

    Every name and every text that comes from a file (a program's file name, a cell's folder,
    frame names, step descriptions) reaches the program only through :meth:`identifier` or
    :meth:`comment`: no file can put a statement into an exported program.

    Attributes
    ----------
    comment_prefix : str
        Starts a comment that runs to the end of the line.
    limit : int
        The controller's longest name.
    reserved : frozenset of str
        Keywords, built-in instructions and data types (lower case; the three languages compare
        names without case, URScript's built-ins are lower case anyway).
    lower : bool
        Names in lower case (URScript's style).
    """

    name: str
    comment_prefix: str
    limit: int
    reserved: frozenset[str]
    lower: bool = False
    upper: bool = False  # names in upper case (FANUC's)
    escaped: str = ""  # printable characters a comment may not hold either
    # Java translates \uXXXX anywhere in the source before it tokenizes (JLS 3.3), comments too:
    # every backslash of a comment is doubled, so none can begin an escape
    unicode_escapes: bool = False
    # lines every file starts with, fixed text: Python reads a coding cookie (PEP 263) from a
    # comment on line 1 or 2, so nothing from a file may stand there
    first_lines: tuple[str, ...] = ()

    def identifier(self, name: str, used: set[str]) -> str:
        """A name the language holds: letters, digits and '_', starting with a letter, at most
        ``limit`` characters, no keyword or built-in, unique among ``used`` (which it joins)."""
        clean = re.sub(r"[^A-Za-z0-9_]", "_", name)
        if not clean or not clean[0].isalpha():
            clean = "n" + clean
        clean = clean[: self.limit]
        if self.lower:
            clean = clean.lower()
        if self.upper:
            clean = clean.upper()
        if clean.lower() in self.reserved:
            clean = clean[: self.limit - 2] + "_p"
        candidate, k = clean, 2
        taken = {u.lower() for u in used}
        while candidate.lower() in taken or candidate.lower() in self.reserved:
            suffix = f"_{k}"
            candidate, k = clean[: self.limit - len(suffix)] + suffix, k + 1
        used.add(candidate)
        return candidate

    def comment(self, text: object) -> str:
        """``text`` safe inside one comment line: printable ASCII kept, anything else (a
        newline, a carriage return, a tab, a character the controller's code page may lack)
        written as an escape (``\\n``, ``\\u00fc``)."""

        def safe(ch: str) -> str:
            if ch in self.escaped:
                return f"\\x{ord(ch):02x}"
            return ch if " " <= ch <= "~" else ascii(ch)[1:-1]

        written = "".join(safe(ch) for ch in str(text))
        return written.replace("\\", "\\\\") if self.unicode_escapes else written

    def renamed(self, identifier: str, original: str) -> list[str]:
        """The comment line that gives a renamed program's original name (none when equal)."""
        if identifier == original:
            return []
        return [f"{self.comment_prefix} '{identifier}' is program '{self.comment(original)}'"]


_URSCRIPT_WORDS = """def end if elif else while for in return thread run kill join sec true false
and
or not global local halt break continue pass xor movej movel movec movep servoj servoc speedj
speedl stopj stopl set_tcp set_payload set_digital_out set_standard_digital_out
set_tool_digital_out set_configurable_digital_out get_digital_in get_standard_digital_in
get_tool_digital_in get_digital_out set_analog_out get_analog_in sleep sync textmsg popup
pose_trans pose_inv pose_add pose_sub pose_dist get_actual_tcp_pose get_actual_joint_positions
get_target_tcp_pose get_forward_kin get_inverse_kin force_mode end_force_mode teach_mode
end_teach_mode freedrive_mode end_freedrive_mode socket_open socket_send_string
socket_read_ascii_float socket_close write_output_integer_register read_input_integer_register
set_gravity set_tool_voltage is_within_safety_limits rpy2rotvec rotvec2rpy norm point_dist
sqrt sin cos tan asin acos atan atan2 pow log floor ceil d2r r2d abs to_str to_num str_len
random interpreter_mode p struct""".split()
_KRL_WORDS = """def end deffct endfct defdat enddat if then else endif for to step endfor while
endwhile repeat until loop endloop switch case default endswitch goto halt wait sec ptp lin circ
ptp_rel lin_rel circ_rel interrupt decl when do brake brake_f resume global public const signal
int real bool char struct enum frame pos e6pos axis e6axis true false and or not exor b_and b_or
b_not b_exor bas import is continue exit return trigger distance delay prio anin anout digin on
off c_ptp c_dis c_vel c_ori spline endspline spl slin scirc sptp time_block timer_block
on_error_proceed bas_command tool_data base_data load_data main""".split()
_RAPID_WORDS = """module endmodule proc endproc func endfunc trap endtrap if then else elseif endif
for from to step do endfor while endwhile test case default endtest goto return raise retry
trynext exit stop var pers const local task alias record endrecord and or xor not div mod true
false error undo backward inout nostepin noview readonly sysmodule viewonly with main movej movel
moveabsj movec searchl searchc waittime waitdi waituntil setdo reset set tpwrite tooldata
wobjdata robtarget jointtarget speeddata zonedata num dnum bool string pos orient pose confdata
extjoint loaddata fine z0 z1 z5 z10 z50 z100 v5 v10 v50 v100 v200 v500 v1000 tool0 wobj0 load0
crobt cjointt offs reltool""".split()

_FANUC_WORDS = """j l c a p pr r sr ar di do ri ro gi go ai ao ui uo si so wait jmp lbl call
end if then else endif select for endfor to downto skip offset tool_offset utool uframe
utool_num uframe_num payload lpos jpos fine cnt acc on off and or not pulse run pause abort
main""".split()

_INFORM_WORDS = """nop end movj movl movc mows imov refp speed dout din wait timer call jump
label pause hold clear set add sub mul div inc dec and or not xor until ret if then else endif
while endwhile for next""".split()

_DRL_WORDS = """and as assert break class continue def del elif else except false finally for
from global if import in is lambda none nonlocal not or pass raise return true try while with
yield movej movel movejx amovel amovej posj posx set_tcp add_tcp set_tool set_user_cart_coord
set_digital_output get_digital_input wait stop check_motion on off dr_base dr_sstop dr_qstop
tp_log print""".split()

_JAVA_WORDS = """abstract assert boolean break byte case catch char class const continue default
do double else enum extends final finally float for goto if implements import instanceof int
interface long native new package private protected public return short static strictfp super
switch synchronized this throw throws transient try void volatile while true false null var
record yield robot run initialize target userframe frame tool jointposition""".split()

_VAL3_WORDS = """begin end if else endif while endwhile do until for to step endfor switch case
default endswitch return call true false and or not xor movej movel movec waitendmove stopmove
resetmotion restartmove watch delay wait herepoint herejoint tool frame point pointrx jointrx
mdesc dio aio num bool string world flange start stop""".split()

URSCRIPT = Language("URScript", "#", 60, frozenset(_URSCRIPT_WORDS), lower=True)
# program names: 36 characters on R-30iA and later; ';' ends a TP line, so not in comments
FANUC = Language("FANUC TP", "!", 36, frozenset(_FANUC_WORDS), upper=True, escaped=";")
KRL = Language("KRL", ";", 24, frozenset(_KRL_WORDS))
RAPID = Language("RAPID", "!", 32, frozenset(_RAPID_WORDS))
# job names: 32 characters on DX100 and later (8 on the NX100); a comment line starts with '
INFORM = Language("INFORM", "'", 32, frozenset(_INFORM_WORDS), upper=True)
# DRL is Python: its first line fixes the encoding, before any name from a file
DRL = Language("DRL", "#", 31, frozenset(_DRL_WORDS), first_lines=("# -*- coding: utf-8 -*-",))
SUNRISE = Language("Java (KUKA Sunrise)", "//", 64, frozenset(_JAVA_WORDS), unicode_escapes=True)
# application names: 15 characters in the controller's file manager; // starts a comment
VAL3 = Language("VAL3", "//", 15, frozenset(_VAL3_WORDS))


def number(x: float, digits: int = 9) -> str:
    """A number with ``digits`` decimals, trailing zeros dropped (no exponent, no -0)."""
    text = f"{float(x):.{digits}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


RAPID_ZONES = (1, 5, 10, 15, 20, 30, 40, 50, 60, 80, 100, 150, 200)  # ABB's predefined zXX [mm]


def blend_percent(blend) -> int:
    """A blend as the share of the moves around it a KUKA C_PTP or FANUC CNT takes: 100 at
    half of the shorter (the largest rworld blends), rounded down, at least 1."""
    return max(1, min(100, int(200 * min(blend.before, blend.after) + 1e-9)))


def rapid_zone(blend) -> str:
    """The largest of ABB's predefined zones within the blend's TCP distance ('fine' below
    z1): the controller's corner path stays nearer the via point than rworld's blend."""
    mm = blend.tcp * 1000.0 if blend is not None else 0.0
    fitting = [z for z in RAPID_ZONES if z <= mm + 1e-9]
    return f"z{fitting[-1]}" if fitting else "fine"
