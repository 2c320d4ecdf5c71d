"""Universal Robots' factory calibrations: the ``kinematics:`` file ``ur_calibration`` writes
from a robot's controller (and ``ur_description`` ships as ``default_kinematics.yaml``)::

    kinematics:
      shoulder:  {x: 0, y: 0, z: 0.1625, roll: 0, pitch: 0, yaw: 0}
      upper_arm: {x: ..., y: ..., z: ..., roll: 1.5707963, pitch: ..., yaw: ...}
      forearm:   {...}
      wrist_1:   {...}
      wrist_2:   {...}
      wrist_3:   {...}
      hash: calib_...

Metres and radians, as ROS gives them; each group is a joint's ``origin`` in
``ur_description``'s ``ur_macro.xacro``: ``xyz = (x, y, z)``, ``rpy = (roll, pitch, yaw)``
(``R = Rz(yaw) Ry(pitch) Rx(roll)``), for shoulder_pan, shoulder_lift, elbow and wrist 1-3.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from .. import spatial
from ..errors import UserError
from .yamlio import comment_text, read_yaml, yaml_value

GROUPS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
KEYS = ("x", "y", "z", "roll", "pitch", "yaw")


def read_ur_calibration(path: str) -> tuple[list[np.ndarray], str | None]:
    """The six joint origins (4, 4) of a UR calibration file, in order, and its ``hash``.

    Raises
    ------
    UserError
        A missing group or key, a value that is not a finite number: every one located.
    """
    doc = read_yaml(path, str(path))
    data = doc.data
    issues = []
    kinematics = data.get("kinematics") if isinstance(data, dict) else None
    if not isinstance(kinematics, dict):
        issue = doc.issue(
            (), "not a UR calibration: no 'kinematics:' section (ur_calibration's output)"
        )
        raise UserError(issue.format(), [issue])
    origins = []
    for group in GROUPS:
        values = kinematics.get(group)
        where = ("kinematics", group)
        if not isinstance(values, dict):
            issues.append(doc.issue(("kinematics",), f"no '{group}' group ({', '.join(GROUPS)})"))
            continue
        numbers = []
        for key in KEYS:
            value = values.get(key)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                issues.append(doc.issue(where + (key,), f"'{key}' is not a number (m, rad)"))
                continue
            if not math.isfinite(value) or abs(value) > 10.0:
                issues.append(
                    doc.issue(where + (key,), f"{value!r} is not a length in m or angle in rad")
                )
                continue
            numbers.append(float(value))
        if len(numbers) == 6:
            origins.append(spatial.make_transform(spatial.rpy_to_matrix(numbers[3:]), numbers[:3]))
    label = kinematics.get("hash")
    if label is not None and not (isinstance(label, str) and _HASH.fullmatch(label)):
        problem = f"the hash {str(label)[:60]!r} is not a plain token (letters, digits, '_-.')"
        issues.append(doc.issue(("kinematics", "hash"), problem))
    if issues:
        raise UserError(issues[0].format(), issues)
    return origins, label


_HASH = re.compile(r"[A-Za-z0-9_.\-]{1,128}")  # ur_calibration's: calib_12788084448423163542


def joint_overlay_text(device: str, origins: dict[str, np.ndarray], comments: list[str]) -> str:
    """A pose-file overlay (mm, deg) setting each joint's frame (``joints:``)."""

    def pose(T) -> str:
        xyz = ", ".join(repr(float(x) * 1000) for x in T[:3, 3])
        rpy = ", ".join(repr(float(x)) for x in np.degrees(spatial.matrix_to_rpy(T[:3, :3])))
        return f"{{xyz: [{xyz}], rpy: [{rpy}]}}"

    lines = [f"# {comment_text(c)}" for c in comments] + [
        "units: {length: mm, angle: deg}",
        "joints:",
    ]
    lines += [f"  {yaml_value(f'{device}.{name}')}: {pose(T)}" for name, T in origins.items()]
    return "\n".join(lines) + "\n"


def write_joint_overlay(path: str | Path, device: str, origins, comments: list[str]) -> None:
    from ..fileio import atomic_write_text

    atomic_write_text(path, joint_overlay_text(device, origins, comments))
