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


def urscript(text: str) -> list[tuple[str, np.ndarray]]:
    """[("joint", q) | ("linear", T_base_tcp)] in order; m and rad."""
    out = []
    for kind, body in re.findall(r"^\s*(movej|movel)\((\[.*?\]|p\[.*?\])", text, re.M):
        values = np.array([float(v) for v in re.findall(NUM, body)])
        if kind == "movej":
            out.append(("joint", values))
        else:
            out.append(("linear", _pose(values[:3], Rotation.from_rotvec(values[3:]).as_matrix())))
    return out


def urscript_tcps(text: str) -> list[np.ndarray]:
    out = []
    for body in re.findall(r"set_tcp\(p\[(.*?)\]\)", text):
        v = np.array([float(x) for x in body.split(",")])
        out.append(_pose(v[:3], Rotation.from_rotvec(v[3:]).as_matrix()))
    return out


def krl(src: str, dat: str) -> list[tuple[str, np.ndarray]]:
    """PTP to E6AXIS (deg) and LIN to E6POS (mm; A, B, C about Z, Y', X'')."""
    decl = {}
    for kind, label, body in re.findall(r"DECL (E6AXIS|E6POS) (\w+) = \{(.*?)\}", dat):
        fields = dict(re.findall(rf"([A-Z]\d?) ({NUM})", body))
        if kind == "E6AXIS":
            decl[label] = ("joint", np.radians([float(fields[f"A{i}"]) for i in range(1, 7)]))
        else:
            xyz = np.array([float(fields[k]) for k in "XYZ"]) / 1000
            abc = [float(fields[k]) for k in "ABC"]
            R = Rotation.from_euler("ZYX", abc, degrees=True).as_matrix()
            decl[label] = ("linear", _pose(xyz, R))
    return [decl[label] for label in re.findall(r"^(?:PTP|LIN) (\w+)", src, re.M)]


def rapid(text: str) -> list[tuple[str, np.ndarray]]:
    """MoveAbsJ to jointtarget (deg) and MoveL to robtarget (mm, quaternion w, x, y, z)."""
    joints = {
        name: np.radians([float(v) for v in body.split(",")])
        for name, body in re.findall(r"CONST jointtarget (\w+) := \[\[(.*?)\]", text)
    }
    poses = {}
    for name, xyz, quat in re.findall(r"CONST robtarget (\w+) := \[\[(.*?)\],\[(.*?)\]", text):
        w, x, y, z = (float(v) for v in quat.split(","))
        R = Rotation.from_quat([x, y, z, w]).as_matrix()
        poses[name] = _pose(np.array([float(v) for v in xyz.split(",")]) / 1000, R)
    out = []
    for kind, name in re.findall(r"^\s*(MoveAbsJ|MoveL) (\w+),", text, re.M):
        out.append(("joint", joints[name]) if kind == "MoveAbsJ" else ("linear", poses[name]))
    return out


def read(folder: Path, fmt: str, stem: str) -> list[tuple[str, np.ndarray]]:
    if fmt == "urscript":
        return urscript((folder / f"{stem}.script").read_text())
    if fmt == "krl":
        return krl((folder / f"{stem}.src").read_text(), (folder / f"{stem}.dat").read_text())
    return rapid((folder / f"{stem}.mod").read_text())
