"""Small readers of the exported subsets, for the round-trip tests: they rebuild joint targets and
Cartesian targets from the text with scipy's Rotation, sharing no code with the writers."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

NUM = r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?"


def _pose(xyz, R) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, xyz
    return T


def _ur_pose(body: str) -> np.ndarray:
    v = np.array([float(x) for x in re.findall(NUM, body)])
    return _pose(v[:3], Rotation.from_rotvec(v[3:]).as_matrix())


def urscript(text: str) -> list[tuple[str, np.ndarray]]:
    """[("joint", q) | ("linear", T_base_tcp)] in order; m and rad; a ``user`` frame applied
    where ``pose_trans(user, p)`` says so."""
    user = np.eye(4)
    found = re.search(r"^\s*user = p\[(.*?)\]", text, re.M)
    if found:
        user = _ur_pose(found.group(1))
    out = []
    pattern = r"^\s*(movej|movel)\((\[.*?\]|p\[.*?\]|pose_trans\(user, p\[.*?\]\))"
    for kind, body in re.findall(pattern, text, re.M):
        if kind == "movej":
            out.append(("joint", np.array([float(v) for v in re.findall(NUM, body)])))
        elif body.startswith("pose_trans"):
            out.append(("linear", user @ _ur_pose(body[len("pose_trans(user, ") :])))
        else:
            out.append(("linear", _ur_pose(body)))
    return out


def urscript_tcps(text: str) -> list[np.ndarray]:
    out = []
    for body in re.findall(r"set_tcp\(p\[(.*?)\]\)", text):
        v = np.array([float(x) for x in body.split(",")])
        out.append(_pose(v[:3], Rotation.from_rotvec(v[3:]).as_matrix()))
    return out


def _krl_frame(body: str) -> np.ndarray:
    fields = dict(re.findall(rf"([A-Z]\d?) ({NUM})", body))
    xyz = np.array([float(fields[k]) for k in "XYZ"]) / 1000
    abc = [float(fields[k]) for k in "ABC"]
    return _pose(xyz, Rotation.from_euler("ZYX", abc, degrees=True).as_matrix())


def krl_tools(src: str) -> list[np.ndarray]:
    """Each ``TOOL_DATA[k] = {X, Y, Z, A, B, C}``: the TCP in $FLANGE (m)."""
    return [_krl_frame(body) for body in re.findall(r"^TOOL_DATA\[\d+\] = \{(.*?)\}", src, re.M)]


def krl(src: str, dat: str) -> list[tuple[str, np.ndarray]]:
    """PTP to E6AXIS (deg) and LIN to E6POS (mm; A, B, C about Z, Y', X''), in $BASE."""
    base = np.eye(4)
    found = re.search(r"^BASE_DATA\[1\] = \{(.*?)\}", src, re.M)
    if found:
        base = _krl_frame(found.group(1))
    decl = {}
    for kind, label, body in re.findall(r"DECL (E6AXIS|E6POS) (\w+) = \{(.*?)\}", dat):
        fields = dict(re.findall(rf"([A-Z]\d?) ({NUM})", body))
        if kind == "E6AXIS":
            decl[label] = ("joint", np.radians([float(fields[f"A{i}"]) for i in range(1, 7)]))
        else:
            decl[label] = ("linear", base @ _krl_frame(body))
    return [decl[label] for label in re.findall(r"^(?:PTP|LIN) (\w+)", src, re.M)]


def rapid(text: str) -> list[tuple[str, np.ndarray]]:
    """MoveAbsJ to jointtarget (deg) and MoveL to robtarget (mm, quaternion w, x, y, z), in the
    work object's user frame."""
    found = re.search(r'PERS wobjdata \w+ := \[FALSE,TRUE,"",\[\[(.*?)\],\[(.*?)\]\]', text)
    user = _abb_pose(found.group(1), found.group(2)) if found else np.eye(4)
    joints = {
        name: np.radians([float(v) for v in body.split(",")])
        for name, body in re.findall(r"CONST jointtarget (\w+) := \[\[(.*?)\]", text)
    }
    poses = {}
    for name, xyz, quat in re.findall(r"CONST robtarget (\w+) := \[\[(.*?)\],\[(.*?)\]", text):
        poses[name] = user @ _abb_pose(xyz, quat)
    out = []
    pattern = r"^\s*(?:(MoveAbsJ|MoveL) (\w+),|SearchL \\Stop, \w+, \w+, (\w+),)"
    for kind, name, searched in re.findall(pattern, text, re.M):
        if searched:  # a search: its target is where it would end
            out.append(("linear", poses[searched]))
        else:
            out.append(("joint", joints[name]) if kind == "MoveAbsJ" else ("linear", poses[name]))
    return out


def _abb_pose(xyz: str, quat: str) -> np.ndarray:
    w, x, y, z = (float(v) for v in quat.split(","))
    R = Rotation.from_quat([x, y, z, w]).as_matrix()
    return _pose(np.array([float(v) for v in xyz.split(",")]) / 1000, R)


def rapid_tools(text: str) -> list[np.ndarray]:
    """Each ``tooldata``'s tframe: the TCP in the flange (m)."""
    return [
        _abb_pose(xyz, quat)
        for xyz, quat in re.findall(r"PERS tooldata \w+ := \[TRUE,\[\[(.*?)\],\[(.*?)\]\]", text)
    ]


def rapid_configurations(text: str) -> list[list[int]]:
    """The confdata [cf1, cf4, cf6, cfx] of each robtarget, in order of declaration."""
    return [
        [int(v) for v in body.split(",")]
        for body in re.findall(r"CONST robtarget \w+ := \[\[.*?\],\[.*?\],\[(.*?)\]", text)
    ]


def _wpr(values) -> np.ndarray:
    """X, Y, Z [mm], W, P, R [deg] -> pose (m); R = Rz(R) Ry(P) Rx(W), as FANUC's manuals give."""
    x, y, z, w, p, r = values
    R = Rotation.from_euler("xyz", [w, p, r], degrees=True).as_matrix()  # extrinsic x, y, z
    return _pose(np.array([x, y, z]) / 1000, R)


def _fanuc_registers(text: str) -> dict[str, dict[int, np.ndarray]]:
    """UTOOL[n] / UFRAME[n] as the program sets them through position register elements."""
    frames: dict[str, dict[int, np.ndarray]] = {"UTOOL": {}, "UFRAME": {}}
    elements: dict[int, float] = {}
    for line in re.findall(r"^\s*\d+:\s+(.*?) ;$", text, re.M):
        found = re.match(rf"PR\[(\d+),(\d)\]=({NUM})$", line)
        if found:
            elements[int(found.group(2))] = float(found.group(3))
            continue
        found = re.match(r"(UTOOL|UFRAME)\[(\d+)\]=PR\[\d+\]$", line)
        if found:
            frames[found.group(1)][int(found.group(2))] = _wpr([elements[k] for k in range(1, 7)])
    return frames


def fanuc_tools(text: str) -> list[np.ndarray]:
    return list(_fanuc_registers(text)["UTOOL"].values())


def fanuc(text: str) -> list[tuple[str, np.ndarray]]:
    """J to joint positions (deg: the controller's axes) and L to Cartesian positions (mm, W, P,
    R) composed with their user frame (UF 0: the world frame)."""
    frames = _fanuc_registers(text)["UFRAME"]
    positions = {}
    pattern = r"^P\[(\d+)\]\{\s*GP1:\s*UF : (\d+), UT : (\d+),(.*?)\};"
    for label, uf, _ut, body in re.findall(pattern, text, re.M | re.S):
        fields = dict(re.findall(rf"([A-Z]\d?) ?= *({NUM})", body))
        if "J1" in fields:
            positions[label] = ("joint", np.radians([float(fields[f"J{i}"]) for i in range(1, 7)]))
        else:
            T = _wpr([float(fields[k]) for k in ("X", "Y", "Z", "W", "P", "R")])
            positions[label] = ("linear", (frames[int(uf)] if int(uf) else np.eye(4)) @ T)
    return [positions[label] for label in re.findall(r"^\s*\d+:[JL] P\[(\d+)\]", text, re.M)]


def fanuc_configurations(text: str) -> list[str]:
    return re.findall(r"CONFIG : '(.*?)'", text)


def _rxyz(values) -> np.ndarray:
    """X, Y, Z [mm], Rx, Ry, Rz [deg] -> pose (m): rotations about the fixed x, y, z axes in
    that order (R = Rz Ry Rx)."""
    x, y, z, rx, ry, rz = values
    R = Rotation.from_euler("xyz", [rx, ry, rz], degrees=True).as_matrix()  # extrinsic
    return _pose(np.array([x, y, z]) / 1000, R)


def _inform_frames(text: str, kind: str) -> dict[int, np.ndarray]:
    """The TOOL / USER frames an INFORM job states in its comments, one value a line."""
    values: dict[int, dict[str, float]] = {}
    pattern = rf"^'{kind} (\d+) (X|Y|Z|Rx|Ry|Rz) ({NUM})\r?$"
    for number, key, value in re.findall(pattern, text, re.M):
        values.setdefault(int(number), {})[key] = float(value)
    return {
        k: _rxyz([v[key] for key in ("X", "Y", "Z", "Rx", "Ry", "Rz")]) for k, v in values.items()
    }


def inform_tools(text: str) -> list[np.ndarray]:
    return [T for _, T in sorted(_inform_frames(text, "TOOL").items())]


def _inform_positions(text: str, pulses=None, zero=None) -> tuple[dict, dict]:
    """The //POS section: label -> q [rad] (a pulse position) or T_base_tcp (USER 1 applied
    under ``///POSTYPE USER``), and label -> the RCONF in force."""
    users = _inform_frames(text, "USER")
    positions: dict[str, np.ndarray] = {}
    configs: dict[str, str] = {}
    postype, rconf = "", ""
    for line in text.split("//INST")[0].splitlines():
        line = line.strip()
        if line.startswith("///POSTYPE"):
            postype = line.split()[1]
        elif line.startswith("///RCONF"):
            rconf = line.split()[1]
        elif re.match(r"^C\d{5}=", line):
            label, body = line.split("=")
            values = [float(v) for v in body.split(",")]
            if postype == "PULSE":
                counts = np.array(values) - np.asarray(zero if zero is not None else 0.0)
                positions[label] = np.radians(counts / np.asarray(pulses))
            else:
                T = _rxyz(values)
                positions[label] = users[1] @ T if postype == "USER" else T
                configs[label] = rconf
    return positions, configs


def _inform_moves(text: str) -> list[tuple[str, str]]:
    return re.findall(r"^(MOVJ|MOVL) (C\d{5})", text, re.M)


def inform(text: str, pulses=None, zero=None) -> list[tuple[str, np.ndarray]]:
    """MOVJ / MOVL to C positions in order: ("joint", q [rad]) for a pulse position
    (``pulses`` per degree, ``zero`` pulse), else (kind, T_base_tcp) - a MOVJ to a Cartesian
    position gives ("joint", a 4 x 4 pose)."""
    positions, _ = _inform_positions(text, pulses, zero)
    return [
        ("joint" if kind == "MOVJ" else "linear", positions[label])
        for kind, label in _inform_moves(text)
    ]


def inform_configurations(text: str) -> list[list[int]]:
    """The RCONF of each move's Cartesian position, in order ([] for a pulse position)."""
    _, configs = _inform_positions(text, 1.0)
    return [
        [int(v) for v in configs[label].split(",")] if label in configs else []
        for _, label in _inform_moves(text)
    ]


def _val3_pose(value) -> np.ndarray:
    """x, y, z [mm], rx, ry, rz [deg] -> pose (m): about x, then the new y, then the new z."""
    x, y, z, rx, ry, rz = (float(value.get(k)) for k in ("x", "y", "z", "rx", "ry", "rz"))
    R = Rotation.from_euler("XYZ", [rx, ry, rz], degrees=True).as_matrix()  # intrinsic
    return _pose(np.array([x, y, z]) / 1000, R)


def _val3_data(dtx: str) -> dict[str, list]:
    import xml.etree.ElementTree as ET

    root = ET.fromstring(dtx)
    out = {}
    for data in root.iter():
        if data.tag.endswith("}Data") and data.get("name"):
            values = sorted(
                (v for v in data if v.tag.endswith("}Value")), key=lambda v: int(v.get("key"))
            )
            out[data.get("name")] = values
    return out


def val3_tools(dtx: str) -> list[np.ndarray]:
    return [_val3_pose(v) for v in _val3_data(dtx)["tTool"]]


def val3(dtx: str, pgx: str) -> list[tuple[str, np.ndarray]]:
    """movej to jTarget (deg) and movel to pTarget (mm, deg; on fUser[0] or world[0]), in the
    order of the code."""
    data = _val3_data(dtx)
    user = _val3_pose(data["fUser"][0]) if "fUser" in data else np.eye(4)
    out = []
    for kind, name, k in re.findall(r"^\s*(movej|movel)\((\w+)\[(\d+)\]", pgx, re.M):
        value = data[name][int(k)]
        if name == "jTarget":
            out.append(("joint", np.radians([float(value.get(f"j{i}")) for i in range(1, 7)])))
        else:
            T = _val3_pose(value)
            out.append(("linear", user @ T if value.get("fatherId") == "fUser[0]" else T))
    return out


def val3_configurations(dtx: str, pgx: str) -> list[dict[str, str]]:
    """The shoulder, elbow and wrist of each point moved to, in the order of the code."""
    data = _val3_data(dtx)
    return [
        {k: data["pTarget"][int(i)].get(k) for k in ("shoulder", "elbow", "wrist")}
        for i in re.findall(r"^\s*movel\(pTarget\[(\d+)\]", pgx, re.M)
    ]


def _drl_posx(body: str) -> np.ndarray:
    """posx(x, y, z, rx, ry, rz): mm, and the ZYZ Euler angles (deg, intrinsic z, y', z'')."""
    x, y, z, a, b, c = (float(v) for v in re.findall(NUM, body))
    R = Rotation.from_euler("ZYZ", [a, b, c], degrees=True).as_matrix()
    return _pose(np.array([x, y, z]) / 1000, R)


def drl_tools(text: str) -> list[np.ndarray]:
    return [_drl_posx(b) for b in re.findall(r'^add_tcp\("\w+", posx\((.*?)\)\)', text, re.M)]


def drl(text: str) -> list[tuple[str, np.ndarray]]:
    """movej(posj) (deg) and movel / amovel(posx, ..., ref=R) in DR_BASE or the user frame
    ``R = set_user_cart_coord(posx(...), DR_BASE)``."""
    frames = {"DR_BASE": np.eye(4)}
    for name, body in re.findall(
        r"^(\w+) = set_user_cart_coord\(posx\((.*?)\), DR_BASE\)", text, re.M
    ):
        frames[name] = _drl_posx(body)
    out = []
    pattern = r"^(movej|movel|amovel)\((posj|posx)\((.*?)\)(.*)$"
    for kind, _, body, rest in re.findall(pattern, text, re.M):
        if kind == "movej":
            out.append(("joint", np.radians([float(v) for v in re.findall(NUM, body)])))
        else:
            ref = re.search(r"ref=(\w+)", rest).group(1)
            out.append(("linear", frames[ref] @ _drl_posx(body)))
    return out


def _sunrise_frame(args: str) -> np.ndarray:
    """x, y, z [mm], A, B, C [rad]: R = Rz(A) Ry(B) Rx(C)."""
    x, y, z, a, b, c = (float(v) for v in re.findall(NUM, args))
    R = Rotation.from_euler("ZYX", [a, b, c]).as_matrix()  # intrinsic z, y', x''
    return _pose(np.array([x, y, z]) / 1000, R)


def sunrise_tools(text: str) -> list[np.ndarray]:
    return [_sunrise_frame(a) for a in re.findall(r"Transformation\.ofRad\((.*?)\)", text)]


def sunrise(text: str) -> list[tuple[str, np.ndarray]]:
    """ptp(new JointPosition(...)) [rad] and lin(target) to ``new Frame(parent, ...)`` on the
    root frame or ``userFrame``, in the order of the code."""
    user = np.eye(4)
    found = re.search(r"userFrame = new Frame\(robot\.getRootFrame\(\), (.*?)\);", text)
    if found:
        user = _sunrise_frame(found.group(1))
    out = []
    pattern = (
        r"new JointPosition\((.*?)\)"
        r"|Frame target = new Frame\((\w+(?:\(\))?(?:\.\w+\(\))?), (.*?)\);"
    )
    for joints, parent, args in re.findall(pattern, text):
        if joints:
            out.append(("joint", np.array([float(v) for v in joints.split(",")])))
        else:
            T = _sunrise_frame(args)
            out.append(("linear", user @ T if parent == "userFrame" else T))
    return out


def sunrise_redundancy(text: str) -> list[tuple[float, int, int]]:
    """(E1 [rad], Status, Turn) of each frame moved to, in order."""
    return [
        (float(e1), int(status), int(turn))
        for e1, status, turn in re.findall(rf"new LBRE1Redundancy\(({NUM}), (\d+), (\d+)\)", text)
    ]


def read(folder: Path, fmt: str, stem: str) -> list[tuple[str, np.ndarray]]:
    if fmt == "urscript":
        return urscript((folder / f"{stem}.script").read_text())
    if fmt == "krl":
        return krl((folder / f"{stem}.src").read_text(), (folder / f"{stem}.dat").read_text())
    if fmt == "fanuc":
        return fanuc((folder / f"{stem.upper()}.ls").read_text())
    return rapid((folder / f"{stem}.mod").read_text())
