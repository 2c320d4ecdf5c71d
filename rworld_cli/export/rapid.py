"""ABB RAPID: a ``.mod`` with ``tooldata``, ``wobjdata``, ``jointtarget`` and ``robtarget``
(mm, quaternion [q1..q4] = w, x, y, z, ``confdata``); joint moves by ``MoveAbsJ`` to the joint
target the simulation chose (``MoveJ`` to the robtarget could take another solution), linear moves
by ``MoveL``; ``SetDO`` and ``WaitTime``."""

from __future__ import annotations

import numpy as np

from . import Signals
from .common import (
    RAPID,
    DeviceProgram,
    Load,
    Move,
    Output,
    Record,
    Tool,
    Writer,
    abb_confdata,
    abb_quaternion,
    as_written,
    number,
    principal,
    rapid_zone,
    report_fields,
    walk,
)

note = RAPID.comment  # every text from a file goes into a comment through this

EXTAX = "[9E9,9E9,9E9,9E9,9E9,9E9]"


def loaddata(inertial) -> str:
    """RAPID ``loaddata``: mass [kg], centre of gravity [mm] and the principal axes (quaternion)
    and moments [kg m^2] of inertia, in the flange (tool0) frame."""
    moments, axes = principal(inertial)
    cog = ",".join(number(v, 6) for v in inertial.com * 1000)
    aom = ",".join(number(v, 12) for v in abb_quaternion(axes))
    inertia = ",".join(number(v, 6) for v in moments)
    return f"[{number(inertial.mass, 4)},[{cog}],[{aom}],{inertia}]"


def pose(T) -> str:
    xyz = ",".join(number(v, 6) for v in T[:3, 3] * 1000)
    quat = ",".join(number(v, 12) for v in abb_quaternion(T[:3, :3]))
    return f"[{xyz}],[{quat}]"


class RAPIDWriter(Writer):
    language = RAPID
    indent = "    "

    def __init__(self, program: DeviceProgram, signals: Signals):
        super().__init__(program, signals)
        used = self.used
        self.name = name = RAPID.identifier(program.name, used)
        self.tool_names = tool_names = {
            t.name: RAPID.identifier("t_" + t.name, used) for t in program.tools
        }
        self.lines = lines = [
            f"MODULE {name}",
            f"  ! {note(program.name)}: device '{note(program.device)}', from "
            f"{note(program.source)}",
            "  ! written by 'rworld export program': targets resolved with the cell's current "
            "pose files",
            f"  ! outputs: gripper do_{signals.gripper} (1 = closed), tool changer "
            f"do_{signals.tool_changer} (1 = locked); searches stop on di_{signals.sensor}",
            *(
                [
                    f"  ! contacts: one line each in HOME:rworld_{name}.log (rworld measure "
                    "--from-log)"
                ]
                if program.contacts
                else []
            ),
            *(
                [
                    f"  ! camera trigger: do_{signals.camera} (1 = exposing); the pose at each "
                    f"image: one line in HOME:rworld_{name}.log (rworld captures --from-log)"
                ]
                if program.captures
                else []
            ),
            *("  " + line for line in RAPID.renamed(name, program.name)),
            *(f"  ! {note(line)}" for line in program.conventions()),
        ]
        self.wobj = "wobj_base"
        uframe = "[0,0,0],[1,0,0,0]"
        if program.user_frame:
            self.wobj = RAPID.identifier("wobj_" + program.user_frame, used)
            uframe = pose(program.T_controller_user)
            lines.append(f"  ! {self.wobj} is {note(program.user_frame)}")
        lines.append(
            f'  PERS wobjdata {self.wobj} := [FALSE,TRUE,"",[{uframe}],[[0,0,0],[1,0,0,0]]];'
        )
        # each tooldata carries the tool's own load as it is at the tool's first move; what is
        # grasped comes and goes with GripLoad
        first_load: dict[str, Load] = {}
        pending: Load | None = None
        current = None
        for item in program.instructions:
            if isinstance(item, Load):
                pending = item
            elif isinstance(item, Tool):
                current = item.name
            elif isinstance(item, Move) and current is not None and pending is not None:
                first_load.setdefault(current, pending)
        for tool in program.tools:
            lines.append(f"  ! {tool_names[tool.name]} is {note(tool.name)}")
            held = first_load.get(tool.name)
            tload = loaddata(held.tool) if held is not None and held.tool.mass > 0 else None
            if tload is None:
                lines.append(
                    "  ! no tool mass in the cell: RAPID's smallest load (0.001 kg) stands in"
                )
                tload = "[0.001,[0,0,0.001],[1,0,0,0],0,0,0]"
            lines.append(
                f"  PERS tooldata {tool_names[tool.name]} := [TRUE,[{pose(tool.T_flange_tcp)}],"
                f"{tload}];"
            )
        self.log = RAPID.identifier("rworld_log", used)
        self.payloads: list[str] = []
        self.body = ["  PROC main()"]
        self.current_tool = ""
        self.last_hit: str | None = None

    def tool(self, item: Tool) -> None:
        self.current_tool = self.tool_names[item.name]  # the tooldata of the moves that follow

    def load(self, item: Load) -> None:
        self.body.append(f"    ! {note(item.describe())}")
        if item.payload.mass > 0:
            self.payloads.append(loaddata(item.payload))
            n = len(self.payloads)
            self.lines.append(f"  PERS loaddata load{n} := {self.payloads[-1]};")
            self.body.append(f"    GripLoad load{n};")
        else:
            self.body.append("    GripLoad load0;")

    def move(self, item: Move) -> None:
        program, lines, body, k = self.program, self.lines, self.body, self.index
        tool, wobj = self.current_tool, self.wobj
        label = f"p{k + 1}"
        axes = as_written(program.axes(item.q_target), 9)  # confdata from the joints written
        joints = ",".join(number(np.degrees(v), 9) for v in axes)
        cf = ",".join(str(c) for c in abb_confdata(axes, item.configuration))
        lines.append(f"  ! {label}: {note(item.where)} {note(item.text)}")
        lines.append(f"  CONST jointtarget j{k + 1} := [[{joints}],{EXTAX}];")
        target = pose(program.in_user(item.T_target))
        lines.append(f"  CONST robtarget {label} := [{target},[{cf}],{EXTAX}];")
        speed = f"[{number(item.tool_speed * 1000, 3)},500,5000,1000]"
        lines.append(f"  CONST speeddata s{k + 1} := {speed};")
        body.append(f"    ! {note(item.where)}: {note(item.text)}")
        if item.guard:  # a search: SearchL stops where the sensor's input closes
            lines.append(f"  VAR robtarget hit{k + 1};")
            self.last_hit = f"hit{k + 1}"
            body.append(
                f"    SearchL \\Stop, di_{self.signals.sensor}, hit{k + 1}, {label}, s{k + 1}, "
                f"{tool}\\WObj:={wobj};"
            )
        elif item.motion == "joint":
            zone = rapid_zone(item.blend)
            body.append(f"    MoveAbsJ j{k + 1}, s{k + 1}, {zone}, {tool}\\WObj:={wobj};")
        else:
            body.append(f"    MoveL {label}, s{k + 1}, fine, {tool}\\WObj:={wobj};")

    def set_output(self, item: Output) -> list[str]:
        index = self.signals.output(item.signal)
        return [f"SetDO do_{index}, {1 if item.value else 0};"]

    def pause(self, seconds: float) -> list[str]:
        return [f"WaitTime {number(seconds, 6)};"]

    def record(self, item: Record) -> None:
        # SearchL's search point (where the input closed), or a capture's pose (CRobT: the
        # robot standing still), in the work object, one line of the log; a RAPID string holds
        # 80 characters, so the line is written in pieces (docs/export.md: contact reports)
        body, log = self.body, self.log
        if item.kind == "capture":
            self.last_hit = RAPID.identifier(f"shot{item.number}", self.used)
            self.lines.append(f"  VAR robtarget {self.last_hit};")
            body += self.remark(item.where, item.text)
            body.append(
                f"    {self.last_hit} := CRobT(\\Tool:={self.current_tool} \\WObj:={self.wobj});"
            )
        elif self.last_hit is None:
            return
        else:
            body += self.remark(item.where, item.text)
        text = report_fields(self.program, item, "mm") + " "
        for k in range(0, len(text), 80):
            body.append(f'    Write {log}, "{text[k : k + 80]}"\\NoNewLine;')
        t, r = f"{self.last_hit}.trans", f"{self.last_hit}.rot"
        body.append(
            f'    Write {log}, "x=" + NumToStr({t}.x, 4) + " y=" + NumToStr({t}.y, 4) + '
            f'" z=" + NumToStr({t}.z, 4) + " "\\NoNewLine;'
        )
        body.append(
            f'    Write {log}, "q=" + NumToStr({r}.q1, 8) + "," + NumToStr({r}.q2, 8) + '
            f'"," + NumToStr({r}.q3, 8) + "," + NumToStr({r}.q4, 8);'
        )

    def files(self) -> dict[str, str]:
        lines, body = list(self.lines), list(self.body)
        if self.program.records:  # the log: a file on the controller, appended to
            lines.append(f"  VAR iodev {self.log};")
            body.insert(
                1, f'    Open "HOME:" \\File:="rworld_{self.name}.log", {self.log} \\Append;'
            )
            body.append(f"    Close {self.log};")
        lines += body + ["  ENDPROC", "ENDMODULE", ""]
        return {f"{self.name}.mod": "\n".join(lines)}


def write(program: DeviceProgram, signals: Signals) -> dict[str, str]:
    return walk(RAPIDWriter(program, signals))
