"""Universal Robots URScript: ``movej`` with joint targets, ``movel`` with poses
``p[x, y, z, rx, ry, rz]`` (m, rotation vector), ``set_tcp``, ``set_digital_out``, ``sleep``."""

from __future__ import annotations

from . import Signals
from .common import (
    URSCRIPT,
    DeviceProgram,
    Load,
    Move,
    Output,
    Record,
    Tool,
    Writer,
    number,
    report_fields,
    rotation_vector,
    walk,
)

note = URSCRIPT.comment  # every text from a file goes into a comment through this


def pose(T) -> str:
    rv = rotation_vector(T[:3, :3])
    return "p[" + ", ".join(number(x) for x in (*T[:3, 3], *rv)) + "]"


class URScriptWriter(Writer):
    language = URSCRIPT
    indent = "  "

    def __init__(self, program: DeviceProgram, signals: Signals):
        super().__init__(program, signals)
        self.name = name = URSCRIPT.identifier(program.name, self.used)
        self.body = lines = [
            f"# {note(program.name)}: device '{note(program.device)}', from {note(program.source)}",
            "# written by 'rworld export program': targets resolved with the cell's current pose "
            "files",
            f"# digital outputs: gripper {signals.gripper} (True = closed), tool changer "
            f"{signals.tool_changer} (True = locked); searches stop on digital input "
            f"{signals.sensor}",
            f"def {name}():",
        ]
        if program.captures:
            lines.insert(-1, f"# camera trigger: digital output {signals.camera} (True = exposing)")
        lines[1:1] = URSCRIPT.renamed(name, program.name)
        lines[-1:-1] = [f"# {note(line)}" for line in program.conventions()]
        if program.user_frame:
            lines.append(f"  # user frame: {note(program.user_frame)}, in the base frame")
            lines.append(f"  user = {pose(program.T_controller_user)}")

    def tool(self, item: Tool) -> None:
        self.body.append(f"  # tool: {note(item.name)}")
        self.body.append(f"  set_tcp({pose(item.T_flange_tcp)})")

    def load(self, item: Load) -> None:
        total = item.total
        inertia = total.inertia
        six = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2]]
        six.append(inertia[1, 2])
        self.body.append(f"  # {note(item.describe())}")
        self.body.append(
            f"  # inertia about the centre of gravity, flange axes (Ixx, Iyy, Izz, Ixy, Ixz, "
            f"Iyz): [{', '.join(number(x, 6) for x in six)}] kg m^2"
        )
        self.body.append(
            f"  set_payload({number(total.mass, 4)}, ["
            + ", ".join(number(x, 6) for x in total.com)
            + "])"
        )

    def move(self, item: Move) -> None:
        program, lines = self.program, self.body
        lines.append(f"  # {note(item.where)}: {note(item.text)}")
        k = len([i for i in lines if i.startswith("  # ")])
        if item.motion == "joint":
            q = program.axes(item.q_target)
            blend = (
                f", r={number(item.blend.tcp, 4)}"  # the TCP's blend radius [m]
                if item.blend is not None and not item.guard
                else ""
            )
            motion = (
                "movej([" + ", ".join(number(x) for x in q) + "], "
                f"a={number(item.joint_acceleration, 4)}, v={number(item.joint_speed, 4)}"
                f"{blend})"
            )
        else:
            T = item.T_target
            target = pose(program.in_user(T))
            if program.user_frame:
                target = f"pose_trans(user, {target})"
            motion = (
                f"movel({target}, a={number(item.tool_acceleration, 4)}, "
                f"v={number(item.tool_speed, 4)})"
            )
        if not item.guard:
            lines.append(f"  {motion}")
            return
        # a search: the move runs in a thread; it stops when the sensor's input closes
        sensor = self.signals.sensor
        brake = number(max(item.tool_acceleration, 1.0), 4)
        lines += [
            f"  # a search until {note(item.guard)}: stops when digital input {sensor} closes",
            f"  done_{k} = False",
            f"  thread search_{k}():",
            f"    {motion}",
            f"    done_{k} = True",
            "  end",
            f"  handle_{k} = run search_{k}()",
            f"  while not get_digital_in({sensor}) and not done_{k}:",
            "    sync()",
            "  end",
            f"  kill handle_{k}",
            f"  stop{'j' if item.motion == 'joint' else 'l'}({brake})",
        ]

    def set_output(self, item: Output) -> list[str]:
        index = self.signals.output(item.signal)
        return [f"set_digital_out({index}, {'True' if item.value else 'False'})"]

    def pause(self, seconds: float) -> list[str]:
        return [f"sleep({number(seconds, 6)})"]

    def record(self, item: Record) -> None:
        # where the search stopped (after its stopping distance), or where the robot stands at
        # a capture: the TCP pose in the base frame as the controller logs a pose:
        # p[x, y, z, rx, ry, rz], m and rotation vector (docs/export.md: contact reports)
        self.body += self.remark(item.where, item.text)
        fields = report_fields(self.program, item, "m", user=False)
        self.body.append(f'  textmsg("{fields} pose=", get_actual_tcp_pose())')

    def files(self) -> dict[str, str]:
        lines = [*self.body, "end", f"{self.name}()", ""]
        return {f"{self.name}.script": "\n".join(lines)}


def write(program: DeviceProgram, signals: Signals) -> dict[str, str]:
    return walk(URScriptWriter(program, signals))
