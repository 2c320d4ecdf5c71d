"""FANUC TP as ASCII (``.ls``, loaded by the controller's ASCII upload or MakeTP): joint moves
``J P[k] n%`` to joint positions (J1..J6 in degrees, through the joint map), linear moves
``L P[k] v mm/sec`` to Cartesian positions (X, Y, Z in mm, W, P, R in degrees:
``R = Rz(R) Ry(P) Rx(W)``) with their configuration string, tool and user frames set through a
position register, the payload schedule, ``DO[]``, ``WAIT``; a search is a ``SKIP CONDITION``
with a skip move."""

from __future__ import annotations

import numpy as np

from . import Signals
from .common import (
    FANUC,
    DeviceProgram,
    Load,
    Move,
    Output,
    Record,
    Tool,
    Writer,
    as_written,
    blend_percent,
    fanuc_config,
    walk,
    xyz_wpr,
)

note = FANUC.comment  # every text from a file goes into a comment through this

SCRATCH_PR = 90  # the position register that carries tool and user frame values
KGF_CM_S2 = 9.80665 * 0.01  # [kg m^2] in one kgf cm s^2 (FANUC's payload inertia unit)


def _f(x: float, digits: int = 6) -> str:
    text = f"{float(x):.{digits}f}"
    return "0." + "0" * digits if float(text) == 0 else text


def _comments(text: str) -> list[str]:
    """``!`` lines of at most 32 characters (the pendant's comment length)."""
    import textwrap

    lines = textwrap.wrap(note(text), 32, break_on_hyphens=False) or [""]
    return [f"!{line}" for line in lines]


def _frame_set(kind: str, number: int, T, lines: list[str]) -> None:
    """UTOOL[n] / UFRAME[n] = the pose T, through the scratch position register."""
    lines.append(f"PR[{SCRATCH_PR}]=LPOS-LPOS")  # a Cartesian register of zeros
    for k, value in enumerate(xyz_wpr(T), start=1):
        lines.append(f"PR[{SCRATCH_PR},{k}]={_f(value)}")
    lines.append(f"{kind}[{number}]=PR[{SCRATCH_PR}]")
    lines.append(f"{kind}_NUM={number}")


class FanucWriter(Writer):
    language = FANUC
    indent = ""

    def __init__(self, program: DeviceProgram, signals: Signals):
        super().__init__(program, signals)
        self.name = name = FANUC.identifier(program.name, self.used)
        self.tools = program.tool_numbers
        body = self.body
        head = [
            f"{program.name}: device '{program.device}', from {program.source}",
            "written by 'rworld export program': targets resolved with the cell's current pose "
            "files",
            f"outputs: gripper DO[{signals.gripper}] (ON = closed), tool changer "
            f"DO[{signals.tool_changer}] (ON = locked), searches skip on DI[{signals.sensor}]",
            *([f"'{name}' is program '{program.name}'"] if name != program.name else []),
            *program.conventions(),
            "CONFIG: F when J5 > 0, U elbow up, T wrist centre in front of J1, then the turns "
            "of J4, J5, J6",
            f"PR[{SCRATCH_PR}] carries tool and user frame values",
        ]
        contacts, captures = program.contacts, program.captures
        if contacts:
            last = signals.contact_register + len(contacts) - 1
            head.append(
                f"contacts: PR[{signals.contact_register}] to PR[{last}], one a probe (cleared "
                "first)"
            )
        if captures:
            last = signals.capture_register + len(captures) - 1
            head.append(
                f"camera trigger DO[{signals.camera}] (ON = exposing); the pose at each image: "
                f"PR[{signals.capture_register}] to PR[{last}] (cleared first)"
            )
        for text in head:
            body += _comments(text)
        # a register the program did not reach reads zero
        for first, group in (
            (signals.contact_register, contacts),
            (signals.capture_register, captures),
        ):
            for k in range(len(group)):
                body.append(f"PR[{first + k}]=LPOS-LPOS")
        self.uframe = 0
        if program.user_frame:
            self.uframe = 1
            body += _comments(f"UFRAME[1] is {program.user_frame}")
            _frame_set("UFRAME", 1, program.T_controller_user, body)
        else:
            body += _comments("UFRAME 0: the world frame (the robot's base)")
            body.append("UFRAME_NUM=0")
        self.positions: list[str] = []
        self.current_tool = 0
        self.label = 0

    def tool(self, item: Tool) -> None:
        self.current_tool = tool = self.tools[item.name]
        self.body += _comments(f"UTOOL[{tool}] is {item.name}")
        _frame_set("UTOOL", tool, item.T_flange_tcp, self.body)

    def load(self, item: Load) -> None:
        body = self.body
        total = item.total
        body += _comments(item.describe())
        inertia = total.inertia / KGF_CM_S2
        if np.abs(inertia - np.diag(np.diag(inertia))).max() > 1e-6 * max(
            1.0, np.abs(inertia).max()
        ):
            body += _comments("products of inertia dropped: FANUC takes IX, IY, IZ only")
        fields = {
            "$PAYLOAD": total.mass,
            "$PAYLOAD_X": total.com[0] * 100,
            "$PAYLOAD_Y": total.com[1] * 100,
            "$PAYLOAD_Z": total.com[2] * 100,
            "$PAYLOAD_IX": inertia[0, 0],
            "$PAYLOAD_IY": inertia[1, 1],
            "$PAYLOAD_IZ": inertia[2, 2],
        }
        body += _comments("kg, cm, kgf cm s^2, flange axes")
        for key, value in fields.items():
            body.append(f"$PLST_GRP1[1].{key}={_f(value)}")
        body.append("PAYLOAD[1]")

    def move(self, item: Move) -> None:
        program, body, sensor = self.program, self.body, self.signals.sensor
        self.label += 1
        label = self.label
        body += _comments(f"{item.where}: {item.text}")
        axes = as_written(program.axes(item.q_target), 6)  # CONFIG as the J values are written
        where = f"\tUF : {self.uframe}, UT : {self.current_tool},"
        if item.motion == "joint":
            values = [f"J{i + 1}={_f(np.degrees(v)):>12} deg" for i, v in enumerate(axes)]
            self.positions += [
                f"P[{label}]{{",
                "   GP1:",
                where,
                "\t" + ",\t".join(values[:3]) + ",",
                "\t" + ",\t".join(values[3:]),
                "};",
            ]
            speed = max(1, min(100, round(100 * item.speed_fraction)))
            ending = (
                f"CNT{blend_percent(item.blend)}"
                if item.blend is not None and not item.guard
                else "FINE"
            )
            motion = f"J P[{label}] {speed}% {ending}"
        else:
            x, y, z, w, p, r = xyz_wpr(program.in_user(item.T_target))
            config = fanuc_config(axes, item.configuration)
            self.positions += [
                f"P[{label}]{{",
                "   GP1:",
                f"{where}\t\tCONFIG : '{config}',",
                f"\tX = {_f(x):>12}  mm,\tY = {_f(y):>12}  mm,\tZ = {_f(z):>12}  mm,",
                f"\tW = {_f(w):>12} deg,\tP = {_f(p):>12} deg,\tR = {_f(r):>12} deg",
                "};",
            ]
            speed = max(1, round(item.tool_speed * 1000))
            motion = f"L P[{label}] {speed}mm/sec FINE"
        if item.guard:
            body += _comments(f"a search until {item.guard}: skips on DI[{sensor}]")
            body.append(f"SKIP CONDITION DI[{sensor}]=ON")
            body.append(f"{motion} Skip,LBL[{label}]")
            body.append(f"LBL[{label}]")
        else:
            body.append(motion)

    def remark(self, where: object, text: object) -> list[str]:
        return _comments(f"{where}: {text}")

    def set_output(self, item: Output) -> list[str]:
        state = "ON" if item.value else "OFF"
        return [f"DO[{self.signals.output(item.signal)}]={state}"]

    def pause(self, seconds: float) -> list[str]:
        return [f"WAIT {seconds:.2f}(sec)"]

    def record(self, item: Record) -> None:
        # where the skip stopped (LPOS: the active UFRAME and UTOOL), one register a contact,
        # read back from POSREG.VA by 'rworld measure --from-log'
        # (a capture's: LPOS standing still at the trigger)
        capture = item.kind == "capture"
        first = self.signals.capture_register if capture else self.signals.contact_register
        register = first + item.number - 1
        self.body += _comments(f"{item.where}: {item.text}")
        self.body += _comments(
            f"{item.kind} {item.number}/{item.total} {item.feature}: PR[{register}]"
        )
        self.body.append(f"PR[{register}]=LPOS")

    def files(self) -> dict[str, str]:
        numbered = []
        for k, line in enumerate(self.body, start=1):
            moves = line[:2] in ("J ", "L ")  # a motion line has its type after the number
            numbered.append(f"{k:4d}:{line[0]} {line[2:]} ;" if moves else f"{k:4d}:  {line} ;")
        lines = [
            f"/PROG  {self.name}",
            "/ATTR",
            "OWNER\t\t= MNEDITOR;",
            'COMMENT\t\t= "rworld";',
            "PROG_SIZE\t= 0;",
            "CREATE\t\t= DATE 00-01-01  TIME 00:00:00;",
            "MODIFIED\t= DATE 00-01-01  TIME 00:00:00;",
            "FILE_NAME\t= ;",
            "VERSION\t\t= 0;",
            f"LINE_COUNT\t= {len(numbered)};",
            "MEMORY_SIZE\t= 0;",
            "PROTECT\t\t= READ_WRITE;",
            "TCD:  STACK_SIZE\t= 0,",
            "      TASK_PRIORITY\t= 50,",
            "      TIME_SLICE\t= 0,",
            "      BUSY_LAMP_OFF\t= 0,",
            "      ABORT_REQUEST\t= 0,",
            "      PAUSE_REQUEST\t= 0;",
            "DEFAULT_GROUP\t= 1,*,*,*,*;",
            "CONTROL_CODE\t= 00000000 00000000;",
            "/MN",
            *numbered,
            "/POS",
            *self.positions,
            "/END",
            "",
        ]
        return {f"{self.name}.ls": "\n".join(lines)}


def write(program: DeviceProgram, signals: Signals) -> dict[str, str]:
    return walk(FanucWriter(program, signals))
