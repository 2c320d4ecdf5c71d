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


def read(folder: Path, fmt: str, stem: str) -> list[tuple[str, np.ndarray]]:
    if fmt == "urscript":
        return urscript((folder / f"{stem}.script").read_text())
    if fmt == "krl":
        return krl((folder / f"{stem}.src").read_text(), (folder / f"{stem}.dat").read_text())
    if fmt == "fanuc":
        return fanuc((folder / f"{stem.upper()}.ls").read_text())
    return rapid((folder / f"{stem}.mod").read_text())
