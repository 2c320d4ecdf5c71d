"""Staubli VAL3 as an application folder: the project (``.pjx``), the data (``.dtx``: the
joint targets ``jointRx``, the Cartesian targets ``pointRx`` with their configuration, the tools
``tool`` on ``flange``, the user frame ``frame`` on ``world``, the motion descriptors ``mdesc``,
the outputs ``dio``) and the programs (``start.pgx``, ``stop.pgx``).

Lengths in mm, angles in degrees; a pose's ``rx, ry, rz`` turn about x, then the new y, then
the new z (``R = Rx(rx) Ry(ry) Rz(rz)``).  ``movej`` to joint targets, ``movel`` to points,
``waitEndMove()`` before every output and wait; a guarded move is a ``movel`` watched by
``watch(dSensor == true, ...)`` and stopped (``stopMove()``, ``resetMotion()``); a blended via
point of a planned path has its ``mdesc`` blended (``blend="joint"``, ``leave`` and ``reach``
the TCP's distance from it where rworld's blend starts).
"""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

import numpy as np

from . import Signals
from .common import (
    VAL3,
    DeviceProgram,
    Load,
    Move,
    Output,
    Record,
    Tool,
    Writer,
    as_written,
    report_fields,
    report_lines,
    walk,
)

note = VAL3.comment  # every text from a file goes into a comment through this
SEARCH_TIMEOUT = 60.0  # [s] a search's watch gives up after this
STRING_BYTES = 128  # a VAL3 string's limit (the VAL3 reference manual's string type)


def _f(x: float, digits: int = 6) -> str:
    text = f"{float(x):.{digits}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def xyz_rxyz(T) -> tuple[float, ...]:
    """x, y, z [mm], rx, ry, rz [deg] of a pose: ``R = Rx(rx) Ry(ry) Rz(rz)`` (intrinsic x,
    y', z'')."""
    R = np.asarray(T, dtype=float)[:3, :3]
    ry = np.arcsin(np.clip(R[0, 2], -1.0, 1.0))
    if abs(R[0, 2]) < 1.0 - 1e-12:
        rx = np.arctan2(-R[1, 2], R[2, 2])
        rz = np.arctan2(-R[0, 1], R[0, 0])
    else:  # gimbal lock: rz = 0, rx takes the turn
        rx = np.arctan2(R[2, 1], R[1, 1])
        rz = 0.0
    x, y, z = np.asarray(T, dtype=float)[:3, 3] * 1000
    return (x, y, z, float(np.degrees(rx)), float(np.degrees(ry)), float(np.degrees(rz)))


def config(axes: np.ndarray, configuration: dict[str, str] | None) -> dict[str, str]:
    """A 6-axis solution's VAL3 configuration (the controller's axis values [rad]): shoulder
    righty with the wrist centre in front of axis 1 (rworld's shoulder 'front'), lefty
    behind; elbow epositive when axis 3 is positive or zero; wrist wpositive when axis 5 is."""
    front = configuration is None or configuration["shoulder"] == "front"
    return {
        "shoulder": "righty" if front else "lefty",
        "elbow": "epositive" if axes[2] >= 0 else "enegative",
        "wrist": "wpositive" if axes[4] >= 0 else "wnegative",
    }


def _pose_attributes(T) -> str:
    return " ".join(f'{k}="{_f(v)}"' for k, v in zip(("x", "y", "z", "rx", "ry", "rz"), T))


class VAL3Writer(Writer):
    language = VAL3
    indent = "  "

    def __init__(self, program: DeviceProgram, signals: Signals):
        super().__init__(program, signals)
        self.app = app = VAL3.identifier(program.name, self.used)
        self.tools = {t.name: k for k, t in enumerate(program.tools)}
        self.joints: list[str] = []  # Value elements of jTarget
        self.points: list[str] = []  # of pTarget
        self.speeds: list[str] = []  # of mSpeed
        head = [
            f"{program.name}: device '{program.device}', from {program.source}",
            "written by 'rworld export program': targets resolved with the cell's current pose "
            "files",
            f"outputs: dGripper (true = closed) and dToolChanger (true = locked): link them to "
            f"outputs {signals.gripper} and {signals.tool_changer}; dSensor (searches) to input "
            f"{signals.sensor}",
            *(
                [
                    "dCamera (true = exposing: the camera's trigger): link it to output "
                    f"{signals.camera}"
                ]
                if program.captures
                else []
            ),
            *([f"application '{app}' is program '{program.name}'"] if app != program.name else []),
            *program.conventions(),
            "rx, ry, rz: about x, then the new y, then the new z (R = Rx Ry Rz), degrees; mm",
        ]
        self.body = [f"  // {note(line)}" for line in head]
        self.father = "fUser[0]" if program.user_frame else "world[0]"
        self.current_tool = 0
        self.reports = False  # a contact report: the point it reads is data (pContact)

    def tool(self, item: Tool) -> None:
        self.current_tool = self.tools[item.name]
        self.body.append(f"  // tTool[{self.current_tool}] is {note(item.name)}")

    def load(self, item: Load) -> None:
        self.body.append(f"  // {note(item.describe())} (the tool's and arm's load: the cell)")

    def move(self, item: Move) -> None:
        program, code, tool = self.program, self.body, self.current_tool
        code.append(f"  // {note(item.where)}: {note(item.text)}")
        axes = as_written(program.axes(item.q_target), 6)  # config as joint values are written
        speed = len(self.speeds)
        percent = max(0.01, min(100.0, 100.0 * item.speed_fraction))
        acceleration = max(0.01, min(100.0, 100.0 * item.acceleration_fraction))
        tvel = max(0.1, item.tool_speed * 1000)
        blend = 'blend="off" leave="50" reach="50"'
        if item.blend is not None and not item.guard:  # leave and reach: the TCP's mm
            mm = _f(np.floor(item.blend.tcp * 1e4) / 10, 1)  # rounded down to 0.1 mm
            blend = f'blend="joint" leave="{mm}" reach="{mm}"'
        self.speeds.append(
            f'<Value key="{speed}" accel="{_f(acceleration, 2)}" vel="{_f(percent, 2)}" '
            f'decel="{_f(acceleration, 2)}" tmax="{_f(tvel, 1)}" rmax="99999" {blend} />'
        )
        if item.motion == "joint" and not item.guard:
            k = len(self.joints)
            values = " ".join(f'j{i + 1}="{_f(np.degrees(a))}"' for i, a in enumerate(axes))
            self.joints.append(f'<Value key="{k}" {values} />')
            code.append(f"  movej(jTarget[{k}], tTool[{tool}], mSpeed[{speed}])")
            return
        k = len(self.points)
        shape = config(axes, item.configuration)
        pose = _pose_attributes(xyz_rxyz(program.in_user(item.T_target)))
        self.points.append(
            f'<Value key="{k}" {pose} shoulder="{shape["shoulder"]}" '
            f'elbow="{shape["elbow"]}" wrist="{shape["wrist"]}" fatherId="{self.father}" />'
        )
        code.append(f"  movel(pTarget[{k}], tTool[{tool}], mSpeed[{speed}])")
        if item.guard:
            code += [
                f"  // a search until {note(item.guard)}: stops where dSensor closes",
                f"  if watch(dSensor == true, {_f(SEARCH_TIMEOUT)})",
                "    stopMove()",
                "  endIf",
                "  resetMotion()",
            ]

    def set_output(self, item: Output) -> list[str]:
        name = {"gripper": "dGripper", "tool_changer": "dToolChanger"}.get(item.signal, "dCamera")
        return [
            "waitEndMove()",
            f"{name} = {'true' if item.value else 'false'}",
        ]

    def pause(self, seconds: float) -> list[str]:
        return ["waitEndMove()", f"delay({_f(seconds)})"]

    def record(self, item: Record) -> None:
        # where the search stopped: the TCP in the points' frame as the controller gives it
        # (here: x, y, z mm, rx, ry, rz deg), in the controller's log by logMsg; a VAL3 string
        # holds 128 characters, so the report's fields take lines of their own, each beginning
        # with its 'rworld contact K/N', the point on the last (docs/export.md)
        self.body.append(f"  // {note(item.where)}: {note(item.text)}")
        fields = report_fields(self.program, item, "mm")
        head = f"{item.mark} {item.number}/{item.total}"
        frame = "fUser[0]" if self.program.user_frame else "world[0]"
        self.body.append(f"  pContact[0] = here(tTool[{self.current_tool}], {frame})")
        for line in report_lines(fields, head, STRING_BYTES, "a VAL3 string"):
            self.body.append(f'  logMsg("{line}")')
        # 9 decimals (VAL3's num is a double): the report's own rounding stays far below the
        # controller's; the line stays under 128 characters for positions under 100 m
        values = ' + "," + '.join(
            f'toString(".9", pContact[0].trsf.{c})' for c in ("x", "y", "z", "rx", "ry", "rz")
        )
        self.body.append(f'  logMsg("{head} point=" + {values})')
        self.reports = True

    def files(self) -> dict[str, str]:
        program, app = self.program, self.app
        code = [*self.body, "  waitEndMove()"]
        tool_values = [
            f'<Value key="{k}" {_pose_attributes(xyz_rxyz(t.T_flange_tcp))} fatherId="flange[0]" '
            'ioLink="valve1" open="0" close="0" />'
            for k, t in enumerate(program.tools)
        ] or ['<Value key="0" x="0" y="0" z="0" rx="0" ry="0" rz="0" fatherId="flange[0]" />']
        datas = [
            _array("jTarget", "jointRx", self.joints),
            _array("pTarget", "pointRx", self.points),
            _array("tTool", "tool", tool_values),
            _array("mSpeed", "mdesc", self.speeds),
            _array("dGripper", "dio", ['<Value key="0" link="" />']),
            _array("dToolChanger", "dio", ['<Value key="0" link="" />']),
            _array("dSensor", "dio", ['<Value key="0" link="" />']),
        ]
        if program.captures:  # the camera's trigger
            datas.append(_array("dCamera", "dio", ['<Value key="0" link="" />']))
        if self.reports:  # here() of each contact, logged as it is read
            datas.append(_array("pContact", "pointRx", [EMPTY["pointRx"]]))
        if program.user_frame:
            user = _pose_attributes(xyz_rxyz(program.T_controller_user))
            datas.append(
                _array("fUser", "frame", [f'<Value key="0" {user} fatherId="world[0]" />'])
            )
        dtx = "\n".join(
            [
                '<?xml version="1.0" encoding="utf-8"?>',
                '<Database xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" '
                'xmlns="http://www.staubli.com/robotics/VAL3/Data/2">',
                "  <Datas>",
                *datas,
                "  </Datas>",
                "</Database>",
                "",
            ]
        )
        start = _program_file("start", ["begin", *code, "end"])
        stop = _program_file("stop", ["begin", "end"])
        pjx = "\n".join(
            [
                '<?xml version="1.0" encoding="utf-8"?>',
                '<Project xmlns="http://www.staubli.com/robotics/VAL3/Project/3">',
                '  <Parameters version="s7.3" stackSize="5000" millimeterUnit="true" />',
                "  <Programs>",
                '    <Program file="start.pgx" />',
                '    <Program file="stop.pgx" />',
                "  </Programs>",
                "  <Database>",
                f"    <Data file={quoteattr(app + '.dtx')} />",
                "  </Database>",
                "  <Libraries />",
                "</Project>",
                "",
            ]
        )
        return {
            f"{app}/{app}.pjx": pjx,
            f"{app}/{app}.dtx": dtx,
            f"{app}/start.pgx": start,
            f"{app}/stop.pgx": stop,
        }


def write(program: DeviceProgram, signals: Signals) -> dict[str, str]:
    return walk(VAL3Writer(program, signals))


EMPTY = {  # an array the program does not use still holds one value
    "jointRx": '<Value key="0" j1="0" j2="0" j3="0" j4="0" j5="0" j6="0" />',
    "pointRx": '<Value key="0" x="0" y="0" z="0" rx="0" ry="0" rz="0" shoulder="righty" '
    'elbow="epositive" wrist="wpositive" fatherId="world[0]" />',
    "mdesc": '<Value key="0" accel="100" vel="100" decel="100" tmax="99999" rmax="99999" '
    'blend="off" leave="50" reach="50" />',
}


def _array(name: str, kind: str, values: list[str]) -> str:
    """One ``Data`` element: an array of ``values`` (``Value`` elements)."""
    values = values or [EMPTY[kind]]
    inner = "\n".join(f"      {v}" for v in values)
    return (
        f'    <Data name="{name}" access="private" xsi:type="array" type="{kind}" '
        f'size="{len(values)}">\n{inner}\n    </Data>'
    )


def _program_file(name: str, lines: list[str]) -> str:
    """A ``.pgx`` with one program, its code in CDATA (no line can end it early)."""
    return "\n".join(
        [
            '<?xml version="1.0" encoding="utf-8"?>',
            '<Programs xmlns="http://www.staubli.com/robotics/VAL3/Program/2">',
            f'  <Program name="{name}" access="private">',
            "    <Code><![CDATA[" + "\n".join(lines).replace("]]>", "]] >") + "]]></Code>",
            "  </Program>",
            "</Programs>",
            "",
        ]
    )
