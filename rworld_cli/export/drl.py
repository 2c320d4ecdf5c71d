"""Doosan DRL (the controller's Python-like language, ``.drl``): ``movej(posj(...))`` to joint
targets (deg), ``movel(posx(...), ref=...)`` to Cartesian targets (mm; ``rx, ry, rz`` the ZYZ
Euler angles in degrees: ``R = Rz(rx) Ry(ry) Rz(rz)``), in ``DR_BASE`` or a user frame made by
``set_user_cart_coord``; the tool as ``add_tcp`` / ``set_tcp`` (the TCP in the flange, a posx),
``set_digital_output``, ``wait``; a guarded move is an ``amovel`` watched for the sensor's input
and stopped there (``stop(DR_SSTOP)``).  Linear moves carry the joint solution's solution space
(``sol``) in a comment, for ``movejx`` if the program is edited into one.  A blended via point
of a planned path is a ``movej`` with ``radius=`` (mm: the TCP's distance from it where
rworld's blend starts).
"""

from __future__ import annotations

import numpy as np

from . import Signals
from .common import (
    DRL,
    DeviceProgram,
    Load,
    Move,
    Output,
    Record,
    Tool,
    Writer,
    number,
    report_fields,
    report_lines,
    walk,
)

note = DRL.comment  # every text from a file goes into a comment through this
TP_LOG_BYTES = 256  # a tp_log message's limit (DSR_ROBOT2's documentation)


def posx(T) -> tuple[float, ...]:
    """x, y, z [mm], rx, ry, rz [deg] of a pose: ZYZ Euler angles, ``R = Rz(rx) Ry(ry)
    Rz(rz)``, ry in [0, 180]."""
    R = np.asarray(T, dtype=float)[:3, :3]
    ry = np.arctan2(np.hypot(R[0, 2], R[1, 2]), R[2, 2])
    if np.sin(ry) > 1e-12:
        rx = np.arctan2(R[1, 2], R[0, 2])
        rz = np.arctan2(R[2, 1], -R[2, 0])
    else:  # ry = 0 or 180: only rx + rz (or rx - rz) is fixed; rz = 0
        rx = np.arctan2(R[1, 0], R[0, 0]) if R[2, 2] > 0 else np.arctan2(-R[1, 0], -R[0, 0])
        rz = 0.0
    x, y, z = np.asarray(T, dtype=float)[:3, 3] * 1000
    return (x, y, z, float(np.degrees(rx)), float(np.degrees(ry)), float(np.degrees(rz)))


def solution_space(configuration: dict[str, str] | None) -> int:
    """Doosan's solution space (0..7) of a joint solution: bit 2 the shoulder back, bit 1 the
    elbow down, bit 0 the wrist flipped (rworld's geometric shoulder, elbow and wrist)."""
    c = configuration or {"shoulder": "front", "elbow": "up", "wrist": "noflip"}
    return (
        4 * int(c["shoulder"] == "back") + 2 * int(c["elbow"] == "down") + int(c["wrist"] == "flip")
    )


def _posx(T) -> str:
    return "posx(" + ", ".join(number(v, 6) for v in posx(T)) + ")"


class DRLWriter(Writer):
    language = DRL
    indent = ""

    def __init__(self, program: DeviceProgram, signals: Signals):
        super().__init__(program, signals)
        used = self.used
        self.name = name = DRL.identifier(program.name, used)
        self.tools = tools = {
            t.name: DRL.identifier(f"rworld_{t.name}", used) for t in program.tools
        }
        self.body = lines = [
            *DRL.first_lines,
            f"# {note(program.name)}: device '{note(program.device)}', from {note(program.source)}",
            "# written by 'rworld export program': targets resolved with the cell's current pose "
            "files",
            f"# outputs: gripper {signals.gripper} (ON = closed), tool changer "
            f"{signals.tool_changer} (ON = locked); searches stop on input {signals.sensor}",
            *DRL.renamed(name, program.name),
            *(f"# {note(line)}" for line in program.conventions()),
            "# posx: mm and the ZYZ Euler angles rx, ry, rz (deg); posj: deg",
        ]
        for tool in program.tools:  # the TCPs in the flange, registered once
            lines.append(f'add_tcp("{tools[tool.name]}", {_posx(tool.T_flange_tcp)})')
        self.ref = "DR_BASE"
        if program.user_frame:
            self.ref = DRL.identifier("user_frame", used)
            lines.append(f"# {note(program.user_frame)}")
            lines.append(
                f"{self.ref} = set_user_cart_coord({_posx(program.T_controller_user)}, DR_BASE)"
            )

    def tool(self, item: Tool) -> None:
        self.body.append(f'set_tcp("{self.tools[item.name]}")  # {note(item.name)}')

    def load(self, item: Load) -> None:
        self.body.append(f"# {note(item.describe())} (set the tool weight on the pendant)")

    def move(self, item: Move) -> None:
        program, lines = self.program, self.body
        lines.append(f"# {note(item.where)}: {note(item.text)}")
        if item.motion == "joint" and not item.guard:
            q = np.degrees(program.axes(item.q_target))
            speed = max(np.degrees(item.joint_speed), 0.1)
            acceleration = max(np.degrees(item.joint_acceleration), 0.1)
            radius = (
                f", radius={number(np.floor(item.blend.tcp * 1e4) / 10, 1)}"  # mm
                if item.blend is not None
                else ""
            )
            lines.append(
                "movej(posj(" + ", ".join(number(v, 6) for v in q) + f"), "
                f"vel={number(speed, 3)}, acc={number(acceleration, 3)}{radius})"
            )
            return
        target = _posx(program.in_user(item.T_target))
        speed = max(item.tool_speed * 1000, 0.1)
        acceleration = max(item.tool_acceleration * 1000, 0.1)
        sol = solution_space(item.configuration)
        motion = "amovel" if item.guard else "movel"
        lines.append(
            f"{motion}({target}, vel={number(speed, 3)}, acc={number(acceleration, 3)}, "
            f"ref={self.ref})  # sol {sol}"
        )
        if item.guard:
            lines += [
                f"# a search until {note(item.guard)}: stops where the input closes",
                "while check_motion() != 0:",
                f"    if get_digital_input({self.signals.sensor}) == ON:",
                "        stop(DR_SSTOP)",
                "        break",
            ]

    def set_output(self, item: Output) -> list[str]:
        index = self.signals.output(item.signal)
        return [f"set_digital_output({index}, {'ON' if item.value else 'OFF'})"]

    def pause(self, seconds: float) -> list[str]:
        return [f"wait({number(seconds, 6)})"]

    def record(self, item: Record) -> None:
        # where the search stopped: the TCP in the moves' reference frame as the controller
        # gives it (get_current_posx: x, y, z mm, ZYZ deg), on the teach pendant's log; a
        # tp_log line holds 256 bytes at most, so the report's fields take lines of their own,
        # each beginning with its 'rworld contact K/N' (docs/export.md: contact reports)
        self.body.append(f"# {note(item.where)}: {note(item.text)}")
        fields = report_fields(self.program, item, "mm")
        head = f"{item.mark} {item.number}/{item.total}"
        self.body.append(f"rwc_pos, rwc_sol = get_current_posx(ref={self.ref})")
        for line in report_lines(fields, head, TP_LOG_BYTES, "DRL's tp_log"):
            self.body.append(f"tp_log({line!r})")
        self.body.append(f"tp_log({head + ' posx='!r} + str(list(rwc_pos)))")

    def files(self) -> dict[str, str]:
        return {f"{self.name}.drl": "\n".join(self.body) + "\n"}


def write(program: DeviceProgram, signals: Signals) -> dict[str, str]:
    return walk(DRLWriter(program, signals))
