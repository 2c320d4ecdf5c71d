"""Yaskawa INFORM as a job file (``.JBI``, ASCII, the controller's job format: NX100, DX100,
DX200, YRC1000): the positions in ``//POS``, the instructions in ``//INST``.

Joint targets are pulse counts when the cell gives the controller's ``pulses_per_degree`` (and
``zero_pulse``): robot parameters Yaskawa does not publish, read off the controller.  Without
them every target is a Cartesian position in the base frame (``///POSTYPE BASE``) or the user
frame (``///POSTYPE USER``, ``///USER 1``), X, Y, Z in mm, Rx, Ry, Rz in degrees (``R =
Rz(Rz) Ry(Ry) Rx(Rx)``, the angles about the fixed axes), with the manipulator type
(``///RCONF``) of the joint solution the simulation took: a joint move is then ``MOVJ`` to that
position with that type.  Tool and user frame values are given in comments, for the
controller's tool and user frame files (a job cannot set them).  ``MOVJ ... VJ=`` (% of the
joints' top speed), ``MOVL ... V=`` (mm/s), ``DOUT OT#()``, ``TIMER T=``; a guarded move is a
``MOVL ... UNTIL IN#()=ON`` (the move stops where the input closes).

A probe's contact (``probe:``) is kept in a global position variable, contact K in
``P<first + K - 1>`` (``--contact-register``, as FANUC's position registers): ``GETS PX<n>
$PX001`` after the search copies the current position, XYZ type in the base frame, with the
job's tool.  The job clears them first (``SUB PX<n> PX<n>``: a variable the run did not reach
reads zero).  ``rworld measure --from-log --format inform`` reads them back from the controller's
saved variable data (``VAR.DAT``) or a saved job listing them, in the job data format's form
(``///POSTYPE``, ``///TOOL``, ``///RECTAN``, ``P<n>=X,Y,Z,Rx,Ry,Rz``).
"""

from __future__ import annotations

import textwrap

import numpy as np

from . import Signals
from .common import (
    INFORM,
    DeviceProgram,
    Load,
    Move,
    Output,
    Record,
    Tool,
    Writer,
    as_written,
    walk,
    xyz_wpr,
)

note = INFORM.comment  # every text from a file goes into a comment through this
COMMENT_WIDTH = 32  # the pendant's comment length
FIXED_DATE = "2000/01/01 00:00"  # the job's ///DATE


def _f(x: float, digits: int = 4) -> str:
    text = f"{float(x):.{digits}f}"
    return f"{0.0:.{digits}f}" if float(text) == 0 else text


def rconf(axes: np.ndarray, configuration: dict[str, str] | None) -> str:
    """The manipulator type ``///RCONF l,m,n,o,p,q,0,0`` of a joint solution (the controller's
    axis values [rad]): l 0 flip / 1 no flip, m 0 upper arm (elbow up) / 1 lower arm, n 0
    front / 1 rear (the wrist centre against the S axis), o, p, q: the R, T and S axes at
    180 deg or more in magnitude (1) or not (0), as the NX100 manual's job format gives them."""
    c = configuration or {"shoulder": "front", "elbow": "up", "wrist": "noflip"}
    degrees = np.abs(np.degrees(np.asarray(axes, dtype=float)))
    bits = [
        int(c["wrist"] == "noflip"),
        int(c["elbow"] == "down"),
        int(c["shoulder"] == "back"),
        int(degrees[3] >= 180.0),
        int(degrees[5] >= 180.0),
        int(degrees[0] >= 180.0),
    ]
    return ",".join(str(b) for b in bits) + ",0,0"


def _comments(text: str) -> list[str]:
    """``'`` lines of at most 32 characters."""
    lines = textwrap.wrap(note(text), COMMENT_WIDTH, break_on_hyphens=False) or [""]
    return [f"'{line}" for line in lines]


class InformWriter(Writer):
    language = INFORM
    indent = ""

    def __init__(self, program: DeviceProgram, signals: Signals):
        super().__init__(program, signals)
        self.name = name = INFORM.identifier(program.name, self.used)
        tools = program.tool_numbers
        profile = program.controller
        pulses = profile.pulses_per_degree if profile is not None else None
        zero = profile.zero_pulse if profile is not None else None
        head = [
            f"{program.name}: device '{program.device}', from {program.source}",
            "written by 'rworld export program': targets resolved with the cell's current pose "
            "files",
            f"outputs: gripper OT#({signals.gripper}) (ON = closed), tool changer "
            f"OT#({signals.tool_changer}) (ON = locked); searches stop on IN#({signals.sensor})",
            *([f"job '{name}' is program '{program.name}'"] if name != program.name else []),
            *program.conventions(),
            "linear speeds V= in mm/s (the controller's V unit set to mm/s)",
            (
                "joint targets in pulses (controller.pulses_per_degree, zero_pulse)"
                if pulses is not None
                else "joint targets as Cartesian positions with their RCONF (no pulses per degree "
                "given: controller.pulses_per_degree)"
            ),
        ]
        user_line = "///POSTYPE BASE"
        frames: list[tuple[str, int, str, np.ndarray]] = []  # for the tool and user frame files
        if program.user_frame:
            user_line = "///USER 1\n///POSTYPE USER"
            frames.append(("USER", 1, program.user_frame, program.T_controller_user))
        for used_tool in program.tools:
            frames.append(("TOOL", tools[used_tool.name], used_tool.name, used_tool.T_flange_tcp))
        positions: list[str] = []
        body: list[str] = []
        for text in head:
            body += _comments(text)
        for kind, number, frame_name, T in frames:  # one value a line: each within 32 characters
            body += _comments(f"{kind} {number} is {frame_name} (mm, deg):")
            for key, value in zip(("X", "Y", "Z", "Rx", "Ry", "Rz"), xyz_wpr(T)):
                body.append(f"'{kind} {number} {key} {_f(value)}")
        for first, group, what in (
            (signals.contact_register, program.contacts, "contacts"),
            (signals.capture_register, program.captures, "captures"),
        ):
            if not group:
                continue
            if what == "captures":
                body += _comments(f"camera trigger OT#({signals.camera}) ON = exposing")
            body += _comments(
                f"{what}: P{first:03d} to P{first + len(group) - 1:03d}, one a "
                f"{'probe' if what == 'contacts' else 'image'} (cleared first)"
            )
            for k in range(len(group)):  # a variable the run did not reach reads zero
                body.append(f"SUB PX{first + k:03d} PX{first + k:03d}")
        self.tools, self.pulses, self.zero = tools, pulses, zero
        self.user_line, self.positions, self.body = user_line, positions, body
        self.current_tool = 0
        self.kind_now, self.tool_now, self.type_now = "", -1, ""
        self.count = 0

    def tool(self, item: Tool) -> None:
        self.current_tool = self.tools[item.name]
        self.body += _comments(f"TOOL {self.current_tool}: {item.name}")

    def load(self, item: Load) -> None:
        total = item.total
        self.body += _comments(item.describe())
        self.body += _comments(
            f"load for the tool file: {_f(total.mass, 3)} kg at "
            + ", ".join(_f(v * 1000, 3) for v in total.com)
            + " mm (flange axes)"
        )

    def move(self, item: Move) -> None:
        program, body, positions = self.program, self.body, self.positions
        label = f"C{self.count:05d}"
        self.count += 1
        body += _comments(f"{item.where}: {item.text}")
        axes = program.axes(item.q_target)
        joint = item.motion == "joint" and not item.guard
        if joint and self.pulses is not None:
            if self.kind_now != "pulse":
                positions += ["///POSTYPE PULSE", "///PULSE"]
                self.kind_now, self.tool_now, self.type_now = "pulse", -1, ""
            counts = np.rint(
                np.degrees(axes) * np.asarray(self.pulses)
                + np.asarray(self.zero or [0] * len(axes))
            ).astype(int)
            positions.append(f"{label}=" + ",".join(str(int(c)) for c in counts))
        else:
            if self.kind_now != "rectan":
                positions += [*self.user_line.split("\n"), "///RECTAN"]
                self.kind_now, self.type_now = "rectan", ""
            if self.current_tool != self.tool_now:
                positions.append(f"///TOOL {self.current_tool}")
                self.tool_now = self.current_tool
            kind = rconf(as_written(axes, 6), item.configuration)  # RCONF as written
            if kind != self.type_now:
                positions.append(f"///RCONF {kind}")
                self.type_now = kind
            values = xyz_wpr(program.in_user(item.T_target))
            positions.append(f"{label}=" + ",".join(_f(v) for v in values))
        if item.motion == "joint":
            speed = max(0.01, min(100.0, 100.0 * item.speed_fraction))
            body.append(f"MOVJ {label} VJ={speed:.2f}")
        else:
            speed = max(0.1, item.tool_speed * 1000)
            until = f" UNTIL IN#({self.signals.sensor})=ON" if item.guard else ""
            body.append(f"MOVL {label} V={speed:.1f}{until}")

    def remark(self, where: object, text: object) -> list[str]:
        return _comments(f"{where}: {text}")

    def set_output(self, item: Output) -> list[str]:
        index = self.signals.output(item.signal)
        return [f"DOUT OT#({index}) {'ON' if item.value else 'OFF'}"]

    def pause(self, seconds: float) -> list[str]:
        return [f"TIMER T={seconds:.2f}"]

    def record(self, item: Record) -> None:
        # where the search stopped ($PX001: the current position, XYZ type, base frame, the
        # job's tool), one position variable a contact, read back by 'rworld measure --from-log'
        # (a capture's: the robot standing still at the trigger)
        capture = item.kind == "capture"
        first = self.signals.capture_register if capture else self.signals.contact_register
        variable = first + item.number - 1
        self.body += _comments(f"{item.where}: {item.text}")
        self.body += _comments(
            f"{item.kind} {item.number}/{item.total} {item.feature}: P{variable:03d}"
        )
        self.body.append(f"GETS PX{variable:03d} $PX001")

    def files(self) -> dict[str, str]:
        lines = [
            "/JOB",
            f"//NAME {self.name}",
            "//POS",
            f"///NPOS {self.count},0,0,0,0,0",
            *self.positions,
            "//INST",
            f"///DATE {FIXED_DATE}",  # fixed: the same run exports the same bytes
            f"///COMM {note(self.program.name)[:COMMENT_WIDTH]}",
            "///ATTR SC,RW",
            "///GROUP1 RB1",
            "NOP",
            *self.body,
            "END",
            "",
        ]
        return {f"{self.name}.JBI": "\r\n".join(lines)}


def write(program: DeviceProgram, signals: Signals) -> dict[str, str]:
    return walk(InformWriter(program, signals))
