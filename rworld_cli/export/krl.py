"""KUKA KRL: a ``.src`` (PTP to E6AXIS joint targets, LIN to E6POS Cartesian targets, $TOOL and
$BASE, $OUT, WAIT SEC) and a ``.dat`` with the declarations; lengths in mm, A, B, C in degrees
(``R = Rz(A) Ry(B) Rx(C)``)."""

from __future__ import annotations

import numpy as np

from . import Signals
from .common import (
    KRL,
    DeviceProgram,
    Load,
    Move,
    Output,
    Record,
    Tool,
    Writer,
    as_written,
    blend_percent,
    kuka_abc,
    kuka_status_turn,
    number,
    principal,
    report_fields,
    walk,
)

note = KRL.comment  # every text from a file goes into a comment through this


def frame(T) -> str:
    a, b, c = kuka_abc(T[:3, :3])
    x, y, z = T[:3, 3] * 1000
    return ", ".join(f"{k} {number(v, 6)}" for k, v in zip("XYZABC", (x, y, z, a, b, c)))


class KRLWriter(Writer):
    language = KRL
    indent = ""

    def __init__(self, program: DeviceProgram, signals: Signals):
        super().__init__(program, signals)
        used = self.used
        self.name = name = KRL.identifier(program.name, used)
        self.tools = program.tool_numbers
        self.body = src = [
            "&ACCESS RVP",
            f"DEF {name}( )",
            f"; {note(program.name)}: device '{note(program.device)}', from {note(program.source)}",
            "; written by 'rworld export program': targets resolved with the cell's current pose "
            "files",
            f"; outputs: gripper $OUT[{signals.gripper}] (TRUE = closed), tool changer "
            f"$OUT[{signals.tool_changer}] (TRUE = locked)",
            *KRL.renamed(name, program.name),
            *(f"; {note(line)}" for line in program.conventions()),
        ]
        if program.user_frame:
            user = frame(program.T_controller_user)
            src.append(f"BASE_DATA[1] = {{{user}}}  ; {note(program.user_frame)}")
            src.append("$BASE = BASE_DATA[1]")
        else:
            src.append("$BASE = BASE_DATA[1]  ; the robot's base frame (identity)")
        if any(m.guard for m in program.moves):
            src.append(f"INTERRUPT DECL 10 WHEN $IN[{signals.sensor}]==TRUE DO BRAKE  ; searches")
        self.dat = dat = ["&ACCESS RVP", f"DEFDAT {name}", f"; targets of {note(program.name)}"]
        self.contact = contact = KRL.identifier("RWC", used)  # RWC_1.. in the .dat: the contacts
        self.count = count = KRL.identifier("RWC_COUNT", used)
        if program.contacts:
            dat.append(f"; contacts: {contact}_k = $POS_INT of the k-th probe, {count} recorded")
            dat.append(f"DECL INT {count}=0")
            src.append(f"{count} = 0  ; contacts recorded (the .dat keeps them)")
        # RWV_1.. in the .dat: the poses of the captures ($POS_ACT, standing still)
        self.capture = capture = KRL.identifier("RWV", used)
        self.captured = captured = KRL.identifier("RWV_COUNT", used)
        if program.captures:
            src.insert(5, f"; camera trigger: $OUT[{signals.camera}] (TRUE = exposing)")
            dat.append(f"; captures: {capture}_k = $POS_ACT at the k-th image, {captured} taken")
            dat.append(f"DECL INT {captured}=0")
            src.append(f"{captured} = 0  ; images taken (the .dat keeps their poses)")
        for tool_name, k in self.tools.items():
            dat.append(f"; TOOL_DATA[{k}] is {note(tool_name)}")
        self.targets = 0

    def load(self, item: Load) -> None:
        total = item.total
        moments, principal_axes = principal(total)
        a, b, c = kuka_abc(principal_axes)
        x, y, z = total.com * 1000
        cm = ", ".join(f"{k} {number(v, 6)}" for k, v in zip("XYZABC", (x, y, z, a, b, c)))
        j = ", ".join(f"{k} {number(v, 6)}" for k, v in zip("XYZ", moments))
        self.body.append(f"; {note(item.describe())}")
        self.body.append(f"LOAD_DATA[1] = {{M {number(total.mass, 4)}, CM {{{cm}}}, J {{{j}}}}}")
        self.body.append("$LOAD = LOAD_DATA[1]")

    def tool(self, item: Tool) -> None:
        k = self.tools[item.name]
        self.body.append(f"TOOL_DATA[{k}] = {{{frame(item.T_flange_tcp)}}}  ; {note(item.name)}")
        self.body.append(f"$TOOL = TOOL_DATA[{k}]")

    def move(self, item: Move) -> None:
        program, src, dat = self.program, self.body, self.dat
        self.targets += 1
        src.append(f"; {note(item.where)}: {note(item.text)}")
        if item.guard:
            src.append(
                f"; a search until {note(item.guard)}: stops when $IN[{self.signals.sensor}] closes"
            )
            src.append("INTERRUPT ON 10")
        label = f"XP{self.targets}"
        if item.motion == "joint":
            q = program.axes(item.q_target)
            axes = ", ".join(f"A{i + 1} {number(np.degrees(v), 9)}" for i, v in enumerate(q))
            dat.append(f"DECL E6AXIS {label} = {{{axes}, E1 0, E2 0, E3 0, E4 0, E5 0, E6 0}}")
            speed = max(1, min(100, round(100 * item.speed_fraction)))
            acceleration = max(1, min(100, round(100 * item.acceleration_fraction)))
            src.append(f"BAS(#VEL_PTP, {speed})  ; % of the axes' speeds")
            src.append(f"BAS(#ACC_PTP, {acceleration})  ; % of the axes' accelerations")
            if item.blend is not None and not item.guard:
                src.append(f"$APO.CPTP = {blend_percent(item.blend)}  ; % of half the PTP contour")
                src.append(f"PTP {label} C_PTP")
            else:
                src.append(f"PTP {label}")
        else:
            position = frame(program.in_user(item.T_target))
            written = as_written(program.axes(item.q_target), 9)  # as E6AXIS values are written
            status, turn = kuka_status_turn(written, item.configuration)
            dat.append(
                f"DECL E6POS {label} = {{{position}, S {status}, T {turn}, E1 0, E2 0, E3 0, "
                "E4 0, E5 0, E6 0}"
            )
            src.append(f"$VEL.CP = {number(item.tool_speed, 4)}  ; m/s")
            src.append(f"$ACC.CP = {number(item.tool_acceleration, 4)}  ; m/s^2")
            src.append(f"LIN {label}")
        if item.guard:
            src.append("INTERRUPT OFF 10")
        dat.append(f"; {label}: {note(item.where)} {note(item.text)}")

    def set_output(self, item: Output) -> list[str]:
        index = self.signals.output(item.signal)
        return [f"$OUT[{index}] = {'TRUE' if item.value else 'FALSE'}"]

    def pause(self, seconds: float) -> list[str]:
        return [f"WAIT SEC {number(seconds, 6)}"]

    def record(self, item: Record) -> None:
        # the contact ($POS_INT: where the search's interrupt latched, in $BASE with $TOOL)
        # kept in the .dat, whose values the controller saves: read back by 'rworld measure
        # --from-log' (docs/export.md: contact reports)
        # a capture's: $POS_ACT, the robot standing still at the trigger
        capture = item.kind == "capture"
        variable = f"{self.capture if capture else self.contact}_{item.number}"
        self.body += self.remark(item.where, item.text)
        self.body.append(f"{variable} = {'$POS_ACT' if capture else '$POS_INT'}")
        self.body.append(f"{self.captured if capture else self.count} = {item.number}")
        self.dat.append(f"; {report_fields(self.program, item, 'mm')}")
        self.dat.append(
            f"DECL E6POS {variable}={{X 0.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0,S 0,T 0,E1 0.0,"
            "E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}"
        )

    def files(self) -> dict[str, str]:
        src, dat = [*self.body, "END", ""], [*self.dat, "ENDDAT", ""]
        return {f"{self.name}.src": "\n".join(src), f"{self.name}.dat": "\n".join(dat)}


def write(program: DeviceProgram, signals: Signals) -> dict[str, str]:
    return walk(KRLWriter(program, signals))
