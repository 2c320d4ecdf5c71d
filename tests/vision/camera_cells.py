"""Camera cells around vendor robots imported from their ROS packages: the probing cell of
``tests.calibration.probe_cells`` (the robot as ``rworld import urdf`` wrote it, the table
placed by its reach) with the probe, its stylus and the plate taken off, a 9 x 6 chessboard
(30 mm squares) on the table and a camera on the robot's TCP (60 mm beside it, looking along
its z) - the same cell for any robot, placed by the robot's reach, not by hand.

``fixed=True``: eye-to-hand instead - the camera beside the robot (at 0.7, -0.9 and 0.6 of
the table's distance along x, y and z), looking across at it (+y), and a 7 x 5 board (25 mm)
on the TCP, 50 mm out, facing away from the flange.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from tests.calibration.probe_cells import _device, _write, probe_cell


def camera_cell(robot: str, out: Path, fixed: bool = False) -> Path:
    """Write the camera cell of ``robot`` (a folder of ``tests/data/probe_robots``) to
    ``out``; returns ``out``."""
    probe_cell(robot, out)
    cell = yaml.safe_load((out / "cell.yaml").read_text())
    poses = yaml.safe_load((out / "poses.yaml").read_text())
    name, tcp = _device(cell)
    cell["objects"] = [o for o in cell["objects"] if o["name"] not in ("plate", "stylus")]
    cell["objects"].append(
        {
            "name": "board",
            "mass": 0.3,
            "geometry": {"box": [0.3, 0.21, 0.004], "origin": {"xyz": [0.12, 0.075, 0.002]}},
            "board": {"pattern": "chessboard", "columns": 9, "rows": 6, "square": 0.03},
        }
    )
    cell["sensors"] = [{"name": "wrist_camera", "type": "camera", "size": [0.05, 0.04, 0.04]}]
    cell["affixments"] = [
        a for a in cell["affixments"] if a["child"] not in ("plate", "stylus", "probe_ball")
    ] + [
        {"parent": "table.top_center", "child": "board", "type": "non_rigid", "kind": "rests_on"},
        {"parent": f"{name}.{tcp}", "child": "wrist_camera", "type": "rigid", "kind": "fixture"},
    ]
    cell["conditions"] = []
    for gone in ("plate", "stylus", "probe_ball"):
        poses["poses"].pop(gone, None)
    poses["poses"]["board"] = {"xyz": [-0.15, -0.1, 0.004], "rpy": [float(np.pi), 0.0, 0.0]}
    poses["poses"]["wrist_camera"] = {"xyz": [0.0, 0.06, 0.03]}
    if fixed:
        cell["affixments"] = [a for a in cell["affixments"] if a["child"] != "wrist_camera"]
        cell["objects"].append(
            {
                "name": "hand_board",
                "mass": 0.2,
                "geometry": {"box": [0.2, 0.15, 0.004], "origin": {"xyz": [0.075, 0.05, 0.002]}},
                "board": {"pattern": "chessboard", "columns": 7, "rows": 5, "square": 0.025},
            }
        )
        cell["affixments"].append(
            {"parent": f"{name}.{tcp}", "child": "hand_board", "type": "rigid", "kind": "fixture"}
        )
        d = float(poses["poses"]["table"]["xyz"][0])
        poses["poses"]["wrist_camera"] = {
            "xyz": [round(0.7 * d, 3), round(-0.9 * d, 3), round(0.6 * d, 3)],
            "rpy": [-float(np.pi) / 2, 0.0, 0.0],
        }
        poses["poses"]["hand_board"] = {
            "xyz": [-0.075, 0.05, 0.05],
            "rpy": [float(np.pi), 0.0, 0.0],
        }
    poses["cameras"] = {
        "wrist_camera": {
            "resolution": [1920, 1200],
            "intrinsics": {"fx": 1050, "fy": 1050, "cx": 960, "cy": 600},
        }
    }
    _write(out, cell, poses)
    return out
