"""ABB RAPID: a ``.mod`` with ``tooldata``, ``wobjdata``, ``jointtarget`` and ``robtarget``
(mm, quaternion [q1..q4] = w, x, y, z, ``confdata``); joint moves by ``MoveAbsJ`` to the joint
target the simulation chose (``MoveJ`` to the robtarget could take another solution), linear moves
by ``MoveL``; ``SetDO`` and ``WaitTime``."""

from __future__ import annotations

import numpy as np

from . import Signals
from .common import (
    RAPID,
    Comment,
    DeviceProgram,
    Load,
    Move,
    Output,
    Record,
    Tool,
    Wait,
    abb_confdata,
    abb_quaternion,
    contact_fields,
    number,
    principal,
    rapid_zone,
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


def write(program: DeviceProgram, signals: Signals) -> dict[str, str]:
    used: set[str] = set()
    name = RAPID.identifier(program.name, used)
    tool_names = {t.name: RAPID.identifier("t_" + t.name, used) for t in program.tools}
    lines = [
        f"MODULE {name}",
        f"  ! {note(program.name)}: device '{note(program.device)}', from {note(program.source)}",
        "  ! written by 'rworld export program': targets resolved with the cell's current pose "
        "files",
        f"  ! outputs: gripper do_{signals.gripper} (1 = closed), tool changer "
        f"do_{signals.tool_changer} (1 = locked); searches stop on di_{signals.sensor}",
        *(
            [f"  ! contacts: one line each in HOME:rworld_{name}.log (rworld measure --from-log)"]
            if program.records
            else []
        ),
        *("  " + line for line in RAPID.renamed(name, program.name)),
        *(f"  ! {note(line)}" for line in program.conventions()),
    ]
    wobj = "wobj_base"
    uframe = "[0,0,0],[1,0,0,0]"
    if program.user_frame:
        wobj = RAPID.identifier("wobj_" + program.user_frame, used)
        uframe = pose(program.T_controller_user)
        lines.append(f"  ! {wobj} is {note(program.user_frame)}")
    lines.append(f'  PERS wobjdata {wobj} := [FALSE,TRUE,"",[{uframe}],[[0,0,0],[1,0,0,0]]];')
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
            lines.append("  ! no tool mass in the cell: RAPID's smallest load (0.001 kg) stands in")
            tload = "[0.001,[0,0,0.001],[1,0,0,0],0,0,0]"
        lines.append(
            f"  PERS tooldata {tool_names[tool.name]} := [TRUE,[{pose(tool.T_flange_tcp)}],"
            f"{tload}];"
        )
    log = RAPID.identifier("rworld_log", used)
    log_file = f"rworld_{name}.log"
    payloads: list[str] = []
    body = ["  PROC main()"]
    current_tool = ""
    last_hit = None
    for k, item in enumerate(program.instructions):
        if isinstance(item, Tool):
            current_tool = tool_names[item.name]  # the tooldata of the moves that follow
        elif isinstance(item, Load):
            body.append(f"    ! {note(item.describe())}")
            if item.payload.mass > 0:
                payloads.append(loaddata(item.payload))
                lines.append(f"  PERS loaddata load{len(payloads)} := {payloads[-1]};")
                body.append(f"    GripLoad load{len(payloads)};")
            else:
                body.append("    GripLoad load0;")
        elif isinstance(item, Move):
            label = f"p{k + 1}"
            axes = program.axes(item.q_target)
            joints = ",".join(number(np.degrees(v), 9) for v in axes)
            cf = ",".join(str(c) for c in abb_confdata(axes, item.configuration))
            lines.append(f"  ! {label}: {note(item.where)} {note(item.text)}")
            lines.append(f"  CONST jointtarget j{k + 1} := [[{joints}],{EXTAX}];")
            T = item.T_target
            target = pose(program.in_user(T))
            lines.append(f"  CONST robtarget {label} := [{target},[{cf}],{EXTAX}];")
            speed = f"[{number(item.tool_speed * 1000, 3)},500,5000,1000]"
            lines.append(f"  CONST speeddata s{k + 1} := {speed};")
            body.append(f"    ! {note(item.where)}: {note(item.text)}")
            if item.guard:  # a search: SearchL stops where the sensor's input closes
                lines.append(f"  VAR robtarget hit{k + 1};")
                last_hit = f"hit{k + 1}"
                body.append(
                    f"    SearchL \\Stop, di_{signals.sensor}, hit{k + 1}, {label}, s{k + 1}, "
                    f"{current_tool}\\WObj:={wobj};"
                )
            elif item.motion == "joint":
                zone = rapid_zone(item.blend)
                body.append(
                    f"    MoveAbsJ j{k + 1}, s{k + 1}, {zone}, {current_tool}\\WObj:={wobj};"
                )
            else:
                body.append(f"    MoveL {label}, s{k + 1}, fine, {current_tool}\\WObj:={wobj};")
        elif isinstance(item, Output):
            index = signals.output(item.signal)
            body.append(f"    ! {note(item.where)}: {note(item.text)}")
            body.append(f"    SetDO do_{index}, {1 if item.value else 0};")
        elif isinstance(item, Wait):
            body.append(f"    ! {note(item.where)}: {note(item.text)}")
            body.append(f"    WaitTime {number(item.seconds, 6)};")
        elif isinstance(item, Comment):
            body.append(f"    ! {note(item.where)}: {note(item.text)}")
        elif isinstance(item, Record) and last_hit is not None:
            # SearchL's search point (where the input closed), in the work object, one line of
            # the contact log; a RAPID string holds 80 characters, so the line is written in
            # pieces (docs/export.md: contact reports)
            body.append(f"    ! {note(item.where)}: {note(item.text)}")
            text = contact_fields(program, item, "mm") + " "
            for k in range(0, len(text), 80):
                body.append(f'    Write {log}, "{text[k : k + 80]}"\\NoNewLine;')
            t, r = f"{last_hit}.trans", f"{last_hit}.rot"
            body.append(
                f'    Write {log}, "x=" + NumToStr({t}.x, 4) + " y=" + NumToStr({t}.y, 4) + '
                f'" z=" + NumToStr({t}.z, 4) + " "\\NoNewLine;'
            )
            body.append(
                f'    Write {log}, "q=" + NumToStr({r}.q1, 8) + "," + NumToStr({r}.q2, 8) + '
                f'"," + NumToStr({r}.q3, 8) + "," + NumToStr({r}.q4, 8);'
            )
    if program.records:  # the contact log: a file on the controller, appended to
        lines.append(f"  VAR iodev {log};")
        body.insert(1, f'    Open "HOME:" \\File:="{log_file}", {log} \\Append;')
        body.append(f"    Close {log};")
    lines += body + ["  ENDPROC", "ENDMODULE", ""]
    return {f"{name}.mod": "\n".join(lines)}
