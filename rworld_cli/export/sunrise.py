"""KUKA Sunrise for the 7-axis LBR iiwa and LBR Med: a Java application class
(``RoboticsAPIApplication``).  Joint moves ``ptp(new JointPosition(...))`` (rad), linear moves
``lin(frame)`` to ``Frame``s (mm; A, B, C in rad: ``R = Rz(A) Ry(B) Rx(C)``) on the robot's root
frame or a user frame, each with its redundancy - ``LBRE1Redundancy(E1, status, turn)``, E1 the
value of axis A3 (the LBR's redundancy angle) - so that the controller takes the joint solution
the simulation took; speeds ``setJointVelocityRel`` / ``setCartVelocity``; the tool as a
``Tool`` whose default motion frame is the TCP in the flange; a blended via point of a planned
path is a ``moveAsync`` with ``setBlendingCart`` (mm: the TCP's distance from it where rworld's
blend starts; Sunrise blends asynchronous motions only).

A Sunrise project's I/O groups are classes its own I/O configuration generates, which rworld
cannot name: a program with outputs or searches is written ``abstract``, with one method per
signal (``setGripper(boolean)``, ``setToolChanger(boolean)``, ``searchCondition()``) for a
subclass in the project to implement with its I/O group.
"""

from __future__ import annotations

import numpy as np

from . import Signals
from .common import (
    SUNRISE,
    DeviceProgram,
    Load,
    Move,
    Output,
    Record,
    Tool,
    Writer,
    as_written,
    kuka_abc,
    number,
    report_fields,
    walk,
)

note = SUNRISE.comment  # every text from a file goes into a comment through this


def lbr_status_turn(axes: np.ndarray, configuration: dict[str, str] | None) -> tuple[int, int]:
    """The LBR's Status and Turn of a joint solution (the controller's axis values [rad]):
    Status bit 0 the wrist behind axis A1 (overhead), bit 1 A4 < 0, bit 2 A6 <= 0; Turn bit i
    set when axis i+1 is negative."""
    axes = np.asarray(axes, dtype=float)
    status = int(configuration is not None and configuration.get("shoulder") == "back")
    status |= 2 * int(axes[3] < 0) | 4 * int(axes[5] <= 0)
    turn = sum(1 << i for i, value in enumerate(axes[:7]) if value < 0)
    return status, int(turn)


def frame_args(T) -> str:
    """x, y, z [mm], A, B, C [rad] of a pose (``R = Rz(A) Ry(B) Rx(C)``)."""
    a, b, c = np.radians(kuka_abc(np.asarray(T)[:3, :3]))
    x, y, z = np.asarray(T)[:3, 3] * 1000
    return ", ".join(number(v, 9) for v in (x, y, z, a, b, c))


class SunriseWriter(Writer):
    language = SUNRISE
    indent = "        "

    def __init__(self, program: DeviceProgram, signals: Signals):
        super().__init__(program, signals)
        used = self.used
        self.name = name = SUNRISE.identifier(program.name[:1].upper() + program.name[1:], used)
        self.tools = tools = {
            t.name: SUNRISE.identifier(f"tool_{t.name}", used) for t in program.tools
        }
        self.outputs = {i.signal for i in program.instructions if isinstance(i, Output)}
        self.searches = any(m.guard for m in program.moves)
        self.abstract = bool(self.outputs) or self.searches
        self.head = head = [
            f"{program.name}: device '{program.device}', from {program.source}",
            "written by 'rworld export program': targets resolved with the cell's current pose "
            "files",
            *([f"class '{name}' is program '{program.name}'"] if name != program.name else []),
            *program.conventions(),
            "frames: mm and A, B, C in rad (R = Rz(A) Ry(B) Rx(C)); joint positions in rad; "
            "each frame carries E1 (axis A3), Status and Turn of the simulation's solution",
        ]
        if self.abstract:
            head.append(
                "abstract: implement the I/O methods below in a subclass with the project's I/O "
                f"group (gripper output {signals.gripper}, tool changer output "
                f"{signals.tool_changer}, search input {signals.sensor})"
            )
        self.members: list[str] = []
        self.base = "robot.getRootFrame()"
        if program.user_frame:
            self.members.append(f"    private Frame userFrame; // {note(program.user_frame)}")
            self.body.append(
                f"        userFrame = new Frame(robot.getRootFrame(), "
                f"{frame_args(program.T_controller_user)});"
            )
            self.base = "userFrame"
        for tool in program.tools:
            field = tools[tool.name]
            self.members.append(f"    private Tool {field}; // {note(tool.name)}")
            self.body += [
                f'        {field} = new Tool("{field}");',
                f'        {field}.setDefaultMotionFrame({field}.addChildFrame("tcp", '
                f"Transformation.ofRad({frame_args(tool.T_flange_tcp)})));",
                f"        {field}.attachTo(robot.getFlange());",
            ]
        self.current: str | None = None

    def tool(self, item: Tool) -> None:
        self.current = self.tools[item.name]
        self.body.append(f"        // {note(item.name)}")

    def load(self, item: Load) -> None:
        self.body.append(f"        // {note(item.describe())} (the tool's load data: the project)")

    def move(self, item: Move) -> None:
        program, body = self.program, self.body
        body.append(f"        // {note(item.where)}: {note(item.text)}")
        mover = self.current or "robot"
        axes = as_written(program.axes(item.q_target), 9, "rad")  # Status, Turn as written
        if item.motion == "joint" and not item.guard:
            relative = max(0.01, min(1.0, item.speed_fraction))
            blend = (  # a planned path's blended via point: the TCP's mm from it
                f".setBlendingCart({number(np.floor(item.blend.tcp * 1e4) / 10, 1)})"
                if item.blend is not None
                else ""
            )
            call = "moveAsync" if blend else "move"  # Sunrise blends asynchronous motions
            body.append(
                f"        {mover}.{call}(ptp(new JointPosition("
                + ", ".join(number(v, 9) for v in axes)
                + f")).setJointVelocityRel({number(relative, 4)}){blend});"
            )
            return
        status, turn = lbr_status_turn(axes, item.configuration)
        target = program.in_user(item.T_target)
        body += [
            "        {",
            f"            Frame target = new Frame({self.base}, {frame_args(target)});",
            "            target.setRedundancyInformation(robot, new LBRE1Redundancy("
            f"{number(axes[2], 9)}, {status}, {turn}));",
            f"            {mover}.move(lin(target).setCartVelocity("
            f"{number(max(item.tool_speed * 1000, 0.1), 3)})"
            + (".breakWhen(searchCondition())" if item.guard else "")
            + ");",
            "        }",
        ]

    def set_output(self, item: Output) -> list[str]:
        method = {"gripper": "setGripper", "tool_changer": "setToolChanger"}.get(
            item.signal, "setCameraTrigger"
        )
        return [f"{method}({'true' if item.value else 'false'});"]

    def pause(self, seconds: float) -> list[str]:
        return [f"ThreadUtil.milliSleep({int(round(seconds * 1000))});"]

    def record(self, item: Record) -> None:
        # where the search stopped (or where the robot stands at a capture): the TCP (the
        # tool's default motion frame) in the frame the targets are on, as the controller
        # gives it (getCurrentCartesianPosition: x, y, z mm, A, B, C rad), one line on the
        # application's log with the report's fields (docs/export.md: contact reports); Java
        # prints each double to its last digit
        fields = report_fields(self.program, item, "mm")
        frame = f"{self.current}.getDefaultMotionFrame()" if self.current else "robot.getFlange()"
        self.body += [
            f"        // {note(item.where)}: {note(item.text)}",
            "        {",
            f"            Frame contact = robot.getCurrentCartesianPosition({frame}, {self.base});",
            f'            getLogger().info("{fields} pose=" + contact.getX() + "," + contact.getY()'
            ' + "," + contact.getZ() + "," + contact.getAlphaRad() + "," + contact.getBetaRad()'
            ' + "," + contact.getGammaRad());',
            "        }",
        ]

    def files(self) -> dict[str, str]:
        signals, name = self.signals, self.name
        io_methods: list[str] = []
        if "gripper" in self.outputs:
            io_methods.append(
                f"    /** Output {signals.gripper}: the gripper, true = closed. */\n"
                "    protected abstract void setGripper(boolean closed);"
            )
        if "tool_changer" in self.outputs:
            io_methods.append(
                f"    /** Output {signals.tool_changer}: the tool changer, true = locked. */\n"
                "    protected abstract void setToolChanger(boolean locked);"
            )
        if "camera" in self.outputs:
            io_methods.append(
                f"    /** Output {signals.camera}: the camera's trigger, true = exposing. */\n"
                "    protected abstract void setCameraTrigger(boolean on);"
            )
        if self.searches:
            io_methods.append(
                f"    /** Input {signals.sensor} closed: where a search stops. */\n"
                "    protected abstract ICondition searchCondition();"
            )
        lines = [
            "package application;",
            "",
            *(f"// {note(line)}" for line in self.head),
            "",
            "import javax.inject.Inject;",
            "",
            "import com.kuka.common.ThreadUtil;",
            "import com.kuka.roboticsAPI.applicationModel.RoboticsAPIApplication;",
            "import com.kuka.roboticsAPI.conditionModel.ICondition;",
            "import com.kuka.roboticsAPI.deviceModel.JointPosition;",
            "import com.kuka.roboticsAPI.deviceModel.LBR;",
            "import com.kuka.roboticsAPI.deviceModel.LBRE1Redundancy;",
            "import com.kuka.roboticsAPI.geometricModel.Frame;",
            "import com.kuka.roboticsAPI.geometricModel.Tool;",
            "import com.kuka.roboticsAPI.geometricModel.math.Transformation;",
            "",
            "import static com.kuka.roboticsAPI.motionModel.BasicMotions.*;",
            "",
            f"public {'abstract ' if self.abstract else ''}class {name} extends "
            "RoboticsAPIApplication {",
            "    @Inject",
            "    private LBR robot;",
            *self.members,
            "",
            *io_methods,
            *([""] if io_methods else []),
            "    @Override",
            "    public void run() {",
            *self.body,
            "    }",
            "}",
            "",
        ]
        return {f"{name}.java": "\n".join(lines)}


def write(program: DeviceProgram, signals: Signals) -> dict[str, str]:
    return walk(SunriseWriter(program, signals))
