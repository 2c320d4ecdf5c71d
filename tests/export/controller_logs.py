"""What a controller records when it runs an exported probe program, written independently of
rworld's exporters (scipy's Rotation, plain string formatting): the tests' stand-in for a real
controller's output, in each language's own form (docs/export.md: contact reports).

Each writer takes the contacts as :class:`Reported`: the report's fields as the export writes
them (read from the exported program's text, not from rworld) and the TCP pose the controller
reports, in its reporting frame, in metres.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation


@dataclass
class Reported:
    fields: str  # "rworld contact K/N program=... dir=..." as the exported program states it
    T: np.ndarray  # (4, 4) the TCP in the controller's reporting frame [m]


def _fmt(x: float, digits: int) -> str:
    return f"{x:.{digits}f}"


def urscript_log(contacts: list[Reported], digits: int = 12) -> str:
    """A UR controller log: time stamps and the log's own columns around each textmsg; the pose
    as URScript prints one, p[x, y, z, rx, ry, rz] (m, rotation vector)."""
    out = ["2026-11-27 09:00:00.000 PolyScope started", "2026-11-27 09:00:01.250 Program running"]
    for k, c in enumerate(contacts):
        v = list(c.T[:3, 3]) + list(Rotation.from_matrix(c.T[:3, :3]).as_rotvec())
        pose = "p[" + ", ".join(_fmt(x, digits) for x in v) + "]"
        out.append(f"2026-11-27 09:00:{10 + k:02d}.500 [ROBOT] {c.fields} pose={pose}")
    out.append("2026-11-27 09:01:00.000 Program stopped")
    return "\n".join(out) + "\n"


def rapid_file(contacts: list[Reported], digits: int = 8) -> str:
    """The file a RAPID program appends to with Write: x, y, z in mm, the quaternion q1..q4 (w,
    x, y, z)."""
    out = []
    for c in contacts:
        p = c.T[:3, 3] * 1000
        x, y, z, w = Rotation.from_matrix(c.T[:3, :3]).as_quat()
        out.append(
            f"{c.fields} x={_fmt(p[0], digits)} y={_fmt(p[1], digits)} z={_fmt(p[2], digits)} "
            f"q={_fmt(w, 12)},{_fmt(x, 12)},{_fmt(y, 12)},{_fmt(z, 12)}"
        )
    return "\n".join(out) + "\n"


def krl_dat(
    exported_dat: str, contacts: list[Reported], count: int | None = None, prefix: str = "RWC"
) -> str:
    """The exported .dat as the controller keeps it after the run: each RWC_K assigned its
    $POS_INT (mm; A, B, C: R = Rz(A) Ry(B) Rx(C), deg), RWC_COUNT the contacts recorded; the
    KSS writes values without the spaces after commas.  ``prefix`` "RWV": a capture
    program's poses ($POS_ACT at each image, RWV_COUNT the images taken)."""
    text = exported_dat
    for k, c in enumerate(contacts, start=1):
        p = c.T[:3, 3] * 1000
        a, b, cc = Rotation.from_matrix(c.T[:3, :3]).as_euler("ZYX", degrees=True)
        values = (
            f"X {p[0]:.9f},Y {p[1]:.9f},Z {p[2]:.9f},A {a:.9f},B {b:.9f},C {cc:.9f},S 2,T 35,"
            "E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0"
        )
        text = re.sub(rf"(DECL E6POS {prefix}_{k})=\{{[^}}]*\}}", rf"\1={{{values}}}", text)
    recorded = len(contacts) if count is None else count
    return re.sub(rf"DECL INT {prefix}_COUNT=\d+", f"DECL INT {prefix}_COUNT={recorded}", text)


def fanuc_posreg(contacts: list[Reported], first: int, digits: int = 3, size: int = 200) -> str:
    """POSREG.VA as the controller lists its position registers: group 1, the contacts from
    PR[first] on (X, Y, Z mm; W, P, R deg: R = Rz(R) Ry(P) Rx(W)), the others uninitialised
    or a joint position."""

    def num(x: float) -> str:
        text = f"{x:{digits + 7}.{digits}f}"
        return text.replace("-0.", " -.").replace(" 0.", "  .")  # FANUC drops the leading 0

    out = [f"[*POSREG*]$POSREG  Storage: CMOS  Access: RW  : ARRAY[1,{size}] OF Position Reg"]
    by_register = {first + k: c for k, c in enumerate(contacts)}
    for i in range(1, size + 1):
        c = by_register.get(i)
        if i == 1:
            out += [
                "    [1,1] =   'HOME'   Group: 1",
                "  J1 =     0.000 deg   J2 =     0.000 deg   J3 =     0.000 deg ",
                "  J4 =     0.000 deg   J5 =   -90.000 deg   J6 =     0.000 deg ",
                "",
            ]
        elif c is None:
            out.append(f"    [1,{i}] =   '' Uninitialized")
        else:
            p = c.T[:3, 3] * 1000
            r, pp, w = Rotation.from_matrix(c.T[:3, :3]).as_euler("ZYX", degrees=True)
            out += [
                f"    [1,{i}] =   '' ",
                "  Group: 1   Config: N U T, 0, 0, 0",
                f"  X: {num(p[0])}   Y: {num(p[1])}   Z: {num(p[2])}",
                f"  W: {num(w)}   P: {num(pp)}   R: {num(r)}",
            ]
    return "\n".join(out) + "\n"


def inform_var_dat(
    contacts: list[Reported],
    first: int,
    digits: tuple[int, int] = (9, 9),
    tools: list[int] | None = None,
    user: int | None = None,
    size: int = 128,
) -> str:
    """A Yaskawa controller's saved variable data with the position variables in the job data
    format (NX100/DX100 manuals, the job format's ``///POSTYPE``, ``///TOOL``, ``///RECTAN``,
    ``///RCONF`` and ``Pyyyy=X,Y,Z,Rx,Ry,Rz``): the contacts from P<first> on (mm; deg, R =
    Rz(Rz) Ry(Ry) Rx(Rx): scipy's intrinsic 'ZYX' read backwards), in the base frame or user
    frame ``user``, with the tool each was taken with (``tools``, 1 for each if None); each
    other variable a pulse position of zeros; byte and integer variables before them, as a
    controller's file holds other sections."""
    out = ["//VAR", "///B", *(f"B{i:03d}=0" for i in range(4)), "///I", "I000=7", "///P"]
    by_number = {first + k: c for k, c in enumerate(contacts)}
    tool_of = {first + k: t for k, t in enumerate(tools or [1] * len(contacts))}
    kind, tool = "", -1
    for i in range(size):
        c = by_number.get(i)
        if c is None:
            if kind != "pulse":
                out += ["///POSTYPE PULSE", "///PULSE"]
                kind = "pulse"
            out.append(f"P{i:04d}=0,0,0,0,0,0")
            continue
        if tool_of[i] != tool:
            tool = tool_of[i]
            out.append(f"///TOOL {tool}")
        if kind != "rectan":
            out += ["///POSTYPE BASE"] if user is None else [f"///USER {user}", "///POSTYPE USER"]
            out += ["///RECTAN", "///RCONF 0,0,0,0,0,0,0,0"]
            kind = "rectan"
        p = c.T[:3, 3] * 1000
        rz, ry, rx = Rotation.from_matrix(c.T[:3, :3]).as_euler("ZYX", degrees=True)
        values = [_fmt(v, digits[0]) for v in p] + [_fmt(v, digits[1]) for v in (rx, ry, rz)]
        out.append(f"P{i:04d}=" + ",".join(values))
    return "\r\n".join(out) + "\r\n"


def inform_contact_tools(job: str) -> list[int]:
    """The tool each ``GETS`` of an INFORM job takes its position with: the ``///TOOL`` of the
    position the move before it went to (the job data format: a ``///TOOL n`` line holds for
    the positions after it)."""
    tool_of, tool = {}, 0
    for line in job.splitlines():
        found = re.fullmatch(r"///TOOL (\d+)", line)
        if found:
            tool = int(found.group(1))
        found = re.fullmatch(r"(C\d{5})=.*", line)
        if found:
            tool_of[found.group(1)] = tool
    out, last = [], None
    for line in job.splitlines():
        found = re.match(r"MOV[JL] (C\d{5})", line)
        if found:
            last = found.group(1)
        if line.startswith("GETS "):
            out.append(tool_of[last])
    return out


def _tp_logs(text: str) -> list[tuple[str, bool]]:
    """A DRL program's tp_log lines in order: (the literal string, whether the pose follows
    it: the line ``tp_log('... posx=' + str(list(rwc_pos)))``), read by Python's own parser."""
    import ast

    out = []
    for line in text.splitlines():
        found = re.match(r"tp_log\((.*)\)$", line.strip())
        if found is None:
            continue
        call = ast.parse(line.strip(), mode="eval").body
        argument = call.args[0]
        if isinstance(argument, ast.BinOp):  # 'rworld contact K/N posx=' + str(list(rwc_pos))
            out.append((ast.literal_eval(argument.left), True))
        else:
            out.append((ast.literal_eval(argument), False))
    return out


def drl_log(exported: str, contacts: list[Reported], digits: int | None = None) -> str:
    """A Doosan teach pendant's log of the program's run: each tp_log line as it was logged,
    time stamps before it; ``str(list(posx))`` where the program prints the pose: Python's own
    float text (or ``digits`` decimals), x, y, z mm and ZYZ Euler angles in degrees
    (scipy's intrinsic 'ZYZ')."""
    out = ["2026-11-27 09:00:00 [INFO] program started"]
    k = 0
    for n, (literal, pose) in enumerate(_tp_logs(exported)):
        if pose:
            T = contacts[k].T
            angles = Rotation.from_matrix(T[:3, :3]).as_euler("ZYZ", degrees=True)
            values = [*(T[:3, 3] * 1000), *angles]
            text = (
                str([float(v) for v in values])
                if digits is None
                else ("[" + ", ".join(_fmt(v, digits) for v in values) + "]")
            )
            literal += text
            k += 1
        out.append(f"2026-11-27 09:00:{10 + n % 50:02d} [USER] {literal}")
    out.append("2026-11-27 09:01:00 [INFO] program ended")
    return "\n".join(out) + "\n"


def _log_msgs(text: str) -> list[tuple[str, bool]]:
    """A VAL3 program's logMsg lines in order: (the leading string literal, whether the point
    follows it: ``logMsg("... point=" + toString(".6", pContact[0].trsf.x) + ...)``)."""
    out = []
    for line in text.splitlines():
        found = re.match(r'\s*logMsg\("([^"]*)"(.*)\)$', line)
        if found is not None:
            out.append((found.group(1), "toString(" in found.group(2)))
    return out


def val3_log(exported: str, contacts: list[Reported], digits: int = 9) -> str:
    """A Staubli controller's log of the program's run: each logMsg line after a time stamp
    and the logger's columns; where the program prints the point, here()'s x, y, z (mm) and
    rx, ry, rz (deg; about x, then the new y, then the new z: scipy's intrinsic 'XYZ'), each
    as ``toString(".9", ...)`` prints it, joined by commas."""
    out = ["27/11/2026 09:00:00  INFO  application started"]
    k = 0
    for n, (literal, point) in enumerate(_log_msgs(exported)):
        if point:
            T = contacts[k].T
            angles = Rotation.from_matrix(T[:3, :3]).as_euler("XYZ", degrees=True)
            literal += ",".join(_fmt(v, digits) for v in [*(T[:3, 3] * 1000), *angles])
            k += 1
        out.append(f"27/11/2026 09:00:{10 + n % 50:02d}  USER  {literal}")
    out.append("27/11/2026 09:01:00  INFO  application stopped")
    return "\n".join(out) + "\n"


def _joined(pieces: list[tuple[str, bool]]) -> list[str]:
    """One report's fields from its lines (each beginning with 'rworld contact K/N'), the
    line with the pose ending it."""
    out, current = [], ""
    for literal, pose in pieces:
        if pose:
            out.append(current.strip())
            current = ""
        else:
            head = " ".join(literal.split()[:3])  # rworld contact K/N
            current = literal if not current else current + literal[len(head) :]
    return out


def java_double(x: float) -> str:
    """A double as Java's ``String.valueOf`` prints it: the shortest digits that read back
    (Python's repr), decimal from 1e-3 to 1e7, else ``d.dddE-n``; always a '.'."""
    x = float(x)
    if x == 0.0 or 1e-3 <= abs(x) < 1e7:
        text = repr(x)
        return text if "." in text else text + ".0"
    for places in range(17):  # the fewest mantissa digits that read back
        candidate = f"{x:.{places}e}"
        if float(candidate) == x:
            break
    mantissa, exponent = candidate.split("e")
    return f"{mantissa if '.' in mantissa else mantissa + '.0'}E{int(exponent)}"


def sunrise_log(exported: str, contacts: list[Reported]) -> str:
    """A Sunrise application's log: each ``getLogger().info`` line after a time stamp and
    the logger's columns; the pose as the program concatenates it: x, y, z (mm) and A, B, C
    (rad; ``R = Rz(A) Ry(B) Rx(C)``: scipy's intrinsic 'ZYX'), each as Java prints a double."""
    infos = re.findall(r'getLogger\(\)\.info\("([^"]*) pose=" \+ contact\.getX\(\)', exported)
    assert len(infos) == len(contacts), (len(infos), len(contacts))
    out = ["2026-11-27 09:00:00,000 INFO  [Sunrise] application started"]
    for k, (fields, c) in enumerate(zip(infos, contacts)):
        a, b, cc = Rotation.from_matrix(c.T[:3, :3]).as_euler("ZYX")
        values = [*(c.T[:3, 3] * 1000), a, b, cc]
        pose = ",".join(java_double(v) for v in values)
        out.append(f"2026-11-27 09:00:{10 + k:02d},500 INFO  [Probe] {fields} pose={pose}")
    out.append("2026-11-27 09:01:00,000 INFO  [Sunrise] application ended")
    return "\n".join(out) + "\n"


def reports_in(text: str) -> list[str]:
    """The report fields an exported program states, in order (URScript's textmsg, RAPID's
    Write pieces joined, KRL's .dat comment lines, DRL's tp_log and VAL3's logMsg lines of one
    report joined)."""
    if "tp_log(" in text:
        return _joined(_tp_logs(text))
    if "logMsg(" in text:
        return _joined(_log_msgs(text))
    if "getLogger().info(" in text:
        return re.findall(r'getLogger\(\)\.info\("([^"]*) pose=" \+', text)
    found = re.findall(
        r'textmsg\("(rworld (?:contact|capture) [^"]*?) pose=", get_actual_tcp_pose\(\)\)', text
    )
    if found:
        return found
    if "Write rworld_log" in text:  # literal pieces, then the x= expression
        out, current = [], ""
        for line in text.splitlines():
            piece = re.match(r'\s*Write rworld_log, "([^"]*)"\\NoNewLine;$', line)
            if piece:
                current += piece.group(1)
            elif re.match(r'\s*Write rworld_log, "x="', line):
                out.append(current.strip())
                current = ""
        return out
    return [
        line[2:]
        for line in text.splitlines()
        if line.startswith(("; rworld contact ", "; rworld capture "))
    ]
