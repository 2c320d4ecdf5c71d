"""Camera cells around vendor robots imported from their ROS packages: the probing cell of
``tests.calibration.probe_cells`` (the robot as ``rworld import urdf`` wrote it, the table
placed by its reach) with the probe, its stylus and the plate taken off, a 9 x 6 chessboard
(30 mm squares) on the table and a camera on the robot's TCP (60 mm beside it, looking along
its z) - the same cell for any robot, placed by the robot's reach, not by hand.

``fixed=True``: eye-to-hand instead - the camera beside the robot (at 0.7, -0.9 and 0.6 of
the table's distance along x, y and z), looking across at it (+y), and a 7 x 5 board (25 mm)
on the TCP, 50 mm out, facing away from the flange; the probing cell's wall (at y = -0.5 m)
moved 100 mm behind the camera where the camera would stand behind it (the table over 0.52 m
out: the GP12, the UR10e), else the camera would look at the wall's back.
"""

from __future__ import annotations

import shutil
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
        wall = poses["poses"]["wall"]["xyz"]
        camera_y = poses["poses"]["wrist_camera"]["xyz"][1]
        # the camera's back (20 mm behind it) at or behind the wall's face (10 mm in front of
        # its centre)
        if camera_y < wall[1] + 0.03:
            poses["poses"]["wall"]["xyz"] = [wall[0], round(camera_y - 0.1, 3), wall[2]]
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


def list_pose_file(cell: Path, name: str) -> None:
    """Add ``name`` last to ``cell``'s ``pose_files`` (either YAML form of the list)."""
    text = (cell / "cell.yaml").read_text()
    if "pose_files: [poses.yaml]" in text:
        text = text.replace("pose_files: [poses.yaml]", f"pose_files: [poses.yaml, {name}]")
    else:
        assert "- poses.yaml" in text, "the cell's pose_files"
        text = text.replace("- poses.yaml", f"- poses.yaml\n- {name}", 1)
    (cell / "cell.yaml").write_text(text)


def robot_off_its_model(cell: Path, out: Path, rng: np.random.Generator) -> Path:
    """A copy of ``cell`` at ``out`` whose robot (its first device) is off its kinematics, the
    truth of a robot calibration: a small pose before every DH row (``corrections:``) or after
    every joint frame (``joints:``), 0.5 mm and 0.05 deg sigma an axis, drawn from ``rng``
    (lengths, then angles, joint by joint) into ``robot_truth.yaml``, listed last."""
    from rworld_cli import spatial
    from rworld_cli.calibration.robot import small_pose
    from rworld_cli.schema.loader import load_cell

    shutil.copytree(cell, out)
    model = load_cell(str(out)).cell
    name, dev = next(iter(model.devices.items()))
    if dev.convention == "frames":
        lines = ["units: {length: mm, angle: deg}", "joints:"]
        for j in dev.joints:  # the joint's frame itself, moved by the small pose
            d = np.r_[rng.normal(0, 0.5e-3, 3), np.radians(rng.normal(0, 0.05, 3))]
            T = np.asarray(j.origin) @ small_pose(d)
            xyz = ", ".join(f"{v * 1000:.9f}" for v in T[:3, 3])
            rpy = ", ".join(f"{v:.9f}" for v in np.degrees(spatial.matrix_to_rpy(T[:3, :3])))
            lines.append(f"  {name}.{j.name}: {{xyz: [{xyz}], rpy: [{rpy}]}}")
    else:
        lines = ["units: {length: mm, angle: deg}", "corrections:"]
        for j in dev.joints:
            xyz = ", ".join(f"{v:.6f}" for v in rng.normal(0, 0.5, 3))
            rpy = ", ".join(f"{v:.6f}" for v in rng.normal(0, 0.05, 3))
            lines.append(f"  {name}.{j.name}: {{xyz: [{xyz}], rpy: [{rpy}]}}")
    (out / "robot_truth.yaml").write_text("\n".join(lines) + "\n")
    list_pose_file(out, "robot_truth.yaml")
    return out


def emulated_captures(
    root: Path, nominal, truth, joints: np.ndarray, rng: np.random.Generator, noise_px: float
) -> Path:
    """A capture file ``root/captures.yaml`` (and its ``corners.csv``) of the camera's views
    of the board at ``joints`` (K, n): the corners as the ``truth`` cell's robot puts them,
    with ``noise_px`` of noise from ``rng`` view by view, the flange poses as the ``nominal``
    robot's controller reports them, the joints with ``robot:`` naming ``root/cell``. The
    wrist camera over ``board`` - or, where the camera is fixed in the cell (``camera_cell(...,
    fixed=True)``), ``hand_board`` on the robot (eye-to-hand)."""
    from rworld_cli.schema.captures import capture_template_text, corners_text
    from rworld_cli.vision.emulate import seen_corners
    from rworld_cli.world.tree import World

    name = next(iter(nominal.devices))
    true_world, nominal_world = World(truth), World(nominal)
    camera = nominal.sensors["wrist_camera"].camera
    fixed = "hand_board" in nominal.objects
    board_name = "hand_board" if fixed else "board"
    board = nominal.objects[board_name].board
    # the frame on the flange: the camera's mount, or the board's holder eye-to-hand
    flange = nominal_world.parent(board_name if fixed else "wrist_camera")
    corners, flanges = [], []
    for q in joints:
        true_world.set_joints(name, q)
        nominal_world.set_joints(name, q)
        seen = seen_corners(camera, board, true_world.T("wrist_camera", board_name))
        corners.append(seen + rng.normal(0, noise_px, seen.shape))
        flanges.append(nominal_world.T(name, flange))  # what the controller reports
    names = [f"view{k + 1:02d}.png" for k in range(len(joints))]
    captures = root / "captures.yaml"
    text = capture_template_text(
        camera,
        name if fixed else flange,
        flange if fixed else name,
        board,
        np.array(flanges),
        names,
        "eye-to-hand" if fixed else "eye-in-hand",
        robot=("cell", nominal.devices[name]),
        joints=joints,
    )
    captures.write_text(text + "corners: corners.csv\n")
    (root / "corners.csv").write_text(corners_text(names, np.array(corners)))
    return captures
