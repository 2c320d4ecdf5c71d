"""Probing cells around vendor robots imported from their ROS packages (issue 60): the robot
as ``rworld import urdf`` wrote it (``tests/data/probe_robots/<name>``, each with its
SOURCE.md), a table in front of it, the probing example's plate (160 x 120 x 15 mm, two 20 mm
holes: ``workcells/probing/meshes/plate.stl``) on the table, a wall beside the table, and a
touch probe: a 3 mm (radius) ball 100 mm past the robot's TCP on a 4 mm stem.

Placed by the robot's reach (:func:`_reach`: the probe pointing down at the table's height),
not by hand, so that the same cell works for a robot it has not seen: the table's centre at
65 % of that reach in front of the base, its top at the base's height; the wall on the side,
parallel to the table.

``home``: ``"zero"`` keeps the vendor's zero pose; ``"folded"`` takes a collision-free state
with the probe down close over the base (the arm tucked), found by IK.

Run as a script, it writes the cells for a look:
``.venv/bin/python -m tests.calibration.probe_cells /tmp/cells``.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[2]
ROBOTS = REPO / "tests" / "data" / "probe_robots"
PLATE_MESH = REPO / "workcells" / "probing" / "meshes" / "plate.stl"
STYLUS = 0.1  # [m]: the ball's centre past the robot's TCP
NAMES = ("kr6r900sixx", "cr7ial", "vs060", "gen3", "ur10e", "iiwa14", "gp12")


def _device(cell: dict) -> tuple[str, str]:
    device = cell["devices"][0]
    return device["name"], device["tcps"][0]["name"]


def _compose(pose: dict, dz: float) -> dict:
    """A pose file's entry moved ``dz`` along its own z."""
    from rworld_cli import spatial

    xyz = np.array(pose.get("xyz", [0, 0, 0]), dtype=float)
    R = spatial.rpy_to_matrix(pose.get("rpy", [0, 0, 0]))
    moved = xyz + R @ np.array([0.0, 0.0, dz])
    return {"xyz": [round(float(v), 12) for v in moved], "rpy": list(pose.get("rpy", [0, 0, 0]))}


def probe_cell(robot: str, out: Path, home: str = "zero") -> Path:
    """Write the probing cell of ``robot`` (a folder of ``tests/data/probe_robots``) to
    ``out``; returns ``out``."""
    if out.exists():
        shutil.rmtree(out)
    shutil.copytree(ROBOTS / robot, out, ignore=shutil.ignore_patterns("SOURCE.md"))
    cell = yaml.safe_load((out / "cell.yaml").read_text())
    poses = yaml.safe_load((out / "poses.yaml").read_text())
    assert poses["units"] == {"length": "m", "angle": "rad"}, "the importer's units"
    name, tcp = _device(cell)
    device = cell["devices"][0]
    device["tcps"].append({"name": "probe"})
    for joint in device["joints"]:  # URDF has none: what a vendor's joint_limits.yaml would add
        limits = joint.setdefault("limits", {})
        limits.setdefault("acceleration", round(2.0 * float(limits.get("velocity", 1.0)), 4))
        if float(limits.get("effort", 2.0)) <= 1.0:  # the VS060's URDF: 1 N m, a placeholder
            del limits["effort"]
    poses["poses"][f"{name}.probe"] = _compose(poses["poses"].get(f"{name}.{tcp}", {}), STYLUS)
    shutil.copy(PLATE_MESH, out / "meshes" / "probe_plate.stl")
    cell["objects"] = [
        {
            "name": "table",
            "mass": 40.0,
            "com": [0, 0, -0.2],
            "geometry": {"box": [0.5, 0.9, 0.4], "origin": {"xyz": [0, 0, -0.2]}},
            "frames": [{"name": "top_center"}],
        },
        {
            "name": "plate",
            "mass": 2.2,
            "com": [0.08, 0.06, 0.0075],
            "geometry": {"mesh": {"file": "meshes/probe_plate.stl", "units": "mm"}},
            "features": [
                {"name": "top", "plane": {"point": [0.08, 0.06, 0.015], "normal": [0, 0, 1]}},
                {"name": "front", "plane": {"point": [0, 0, 0], "normal": [0, -1, 0]}},
                {
                    "name": "hole1",
                    "circle": {"center": [0.04, 0.06, 0.015], "normal": [0, 0, 1], "radius": 0.01},
                },
                {
                    "name": "hole2",
                    "circle": {"center": [0.12, 0.06, 0.015], "normal": [0, 0, 1], "radius": 0.01},
                },
            ],
        },
        {
            "name": "wall",
            "mass": 20.0,
            "com": [0, 0, 0.3],
            "geometry": {"box": [0.6, 0.02, 0.6], "origin": {"xyz": [0, 0, 0.3]}},
        },
        {
            "name": "stylus",  # the probe's shaft, from the TCP to the ball
            "mass": 0.02,
            "com": [0, 0, STYLUS / 2],
            "geometry": {
                "cylinder": {"radius": 0.002, "length": STYLUS - 0.006},
                "origin": {"xyz": [0, 0, (STYLUS - 0.006) / 2]},
            },
        },
    ]
    cell["sensors"] = [{"name": "probe_ball", "type": "touch", "ball": 0.003}]
    cell["affixments"] = [
        *(cell.get("affixments") or []),
        {"parent": "table.top_center", "child": "plate", "type": "non_rigid", "kind": "rests_on"},
        {"parent": f"{name}.probe", "child": "probe_ball", "type": "rigid", "kind": "fixture"},
        {"parent": f"{name}.{tcp}", "child": "stylus", "type": "rigid", "kind": "fixture"},
    ]
    cell["conditions"] = [
        {
            "frame": "plate",
            "type": "natural_unoriented",
            "features": ["top", "front", "hole1", "hole2"],
        }
    ]
    reach = 0.0
    for placed in (False, True):  # the poses written first, then placed by the reach
        if placed:
            reach = _reach(out, cell["devices"][0]["name"])
        d = 0.65 * reach
        poses["poses"].update(
            {
                "table": {"xyz": [round(d, 4), 0.0, 0.0]},
                "table.top_center": {"xyz": [0, 0, 0]},
                "plate": {"xyz": [-0.08, -0.06, 0.0]},
                "wall": {"xyz": [round(d, 4), round(-0.5, 4), 0.0]},
                "stylus": {"xyz": [0, 0, 0]},
                "probe_ball": {"xyz": [0, 0, 0]},
            }
        )
        _write(out, cell, poses)
    if home == "folded":
        device["home"] = _folded(out, name, reach)
        _write(out, cell, poses)
    (out / "programs").mkdir(exist_ok=True)
    (out / "programs" / "features.yaml").write_text(
        f"device: {name}\n"
        "description: the plate's features probed, then back home by a free path\n"
        "steps:\n"
        "  - probe: {feature: plate.top, points: 3}\n"
        "  - probe: {feature: plate.front, points: 3}\n"
        "  - probe: {feature: plate.hole1, points: 3}\n"
        "  - probe: {feature: plate.hole2, points: 3}\n"
        "  - move: {to: home, path: free}\n"
    )
    return out


def calibrated_copy(cell: Path) -> Path:
    """A copy of ``cell`` whose plate a calibration moved (0.8 and 0.75 mm in the table's plane,
    0.3 deg about its normal): an overlay pose file after the nominal one, with provenance as
    ``rworld calibrate`` writes it; the programs the same files (copied)."""
    moved = cell.with_name(cell.name + "_calibrated")
    shutil.copytree(cell, moved, dirs_exist_ok=True)
    poses = yaml.safe_load((moved / "poses.yaml").read_text())
    xyz = [float(v) for v in poses["poses"]["plate"]["xyz"]]
    overlay = {
        "units": {"length": "m", "angle": "deg"},
        "poses": {
            "plate": {"xyz": [xyz[0] + 0.0008, xyz[1] - 0.00075, xyz[2]], "rpy": [0, 0, 0.3]}
        },
        "provenance": {"date": "2026-11-29T00:00:00", "measurements": [], "frames": {}},
    }
    (moved / "calibrated.yaml").write_text(yaml.safe_dump(overlay, sort_keys=False))
    text = (moved / "cell.yaml").read_text()
    (moved / "cell.yaml").write_text(
        text.replace("pose_files:\n- poses.yaml", "pose_files:\n- poses.yaml\n- calibrated.yaml")
    )
    assert "calibrated.yaml" in (moved / "cell.yaml").read_text(), "the cell's pose_files"
    return moved


def simulated_loop(robot: str, root: Path, home: str = "zero") -> tuple:
    """The probing cell of ``robot`` under ``root``, a truth cell whose plate a calibration
    moved, the feature program's simulated run on the nominal cell, its contacts as the truth
    gives them, and the simulated loop's measurement file (noise-free): (cell, program, run,
    result, probed, simulated) for the contact-log tests of each language."""
    from rworld_cli.api import simulate_probe_measurements
    from rworld_cli.calibration.probe_run import probe_run
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.schema.programs import load_run
    from rworld_cli.simulate.engine import simulate

    cell = probe_cell(robot, root / robot, home)
    truth = calibrated_copy(cell)
    program = cell / "programs" / "features.yaml"
    run = load_run(str(cell), str(program))
    result = simulate(run, collisions=False)
    probed = probe_run(result, run, load_cell(str(truth)).cell)
    simulated = root / "simulated.yaml"
    simulate_probe_measurements(str(cell), str(truth), str(program), str(simulated), 0.0)
    return cell, program, run, result, probed, simulated


def _write(out: Path, cell: dict, poses: dict) -> None:
    head = "# yaml-language-server: $schema=../../schemas/cell.schema.json\n"
    (out / "cell.yaml").write_text(head + yaml.safe_dump(cell, sort_keys=False))
    (out / "poses.yaml").write_text(yaml.safe_dump(poses, sort_keys=False))


def _reach(out: Path, name: str) -> float:
    """How far from the base the probe ball reaches pointing down, near the base's height
    [m]: the 90th percentile of 40 000 random joint states' ball distances whose stylus points
    within 15 deg of straight down and whose ball lies within 10 cm of that height (a reach
    bound by the chain's offsets overstates it for a small arm: the VS060's by 70 %)."""
    from rworld_cli.calibration.probing import ProbeRig
    from rworld_cli.kinematics.jacobian import tool_pose
    from rworld_cli.planning.motion import sampled_box
    from rworld_cli.schema.loader import load_cell

    model = load_cell(out / "cell.yaml").cell
    rig = ProbeRig(model, name, f"{name}.probe", "probe_ball")
    dev = model.devices[name]
    lo, hi = (sampled_box(dev.limit_array(side)) for side in ("lower", "upper"))
    Q = np.random.default_rng(0).uniform(lo, hi, (40_000, dev.dof))
    T = rig.T_world_base @ tool_pose(dev, Q, rig.mount) @ rig.T_tcp_sensor
    down = T[:, 2, 2] < -np.cos(np.radians(15))
    level = np.abs(T[:, 2, 3] - rig.T_world_base[2, 3]) < 0.1
    ball = T[down & level, :2, 3] - rig.T_world_base[:2, 3]
    return float(np.percentile(np.linalg.norm(ball, axis=1), 90))


def _folded(out: Path, name: str, reach: float) -> list[float]:
    """A home with the arm tucked: the probe pointing down, close over the base's front,
    collision-free (IK seeded from zero, checked like a program's state)."""
    from rworld_cli.calibration.probing import ProbeRig
    from rworld_cli.schema.loader import load_cell

    model = load_cell(out / "cell.yaml").cell
    rig = ProbeRig(model, name, f"{name}.probe", "probe_ball")
    for x, z in (
        (0.3, 0.45),
        (0.25, 0.5),
        (0.35, 0.4),
        (0.3, 0.6),
        (0.4, 0.6),
        (0.3, 0.8),
        (0.5, 0.8),
    ):
        T = rig.tcp_pose(np.array([x * reach, 0.0, z * reach]), np.array([0.0, 0.0, -1.0]), 0.0)
        res = rig.ik(T, np.zeros(model.devices[name].dof), restarts=8)
        if res.success and rig.collision(res.q) is None:
            return [round(float(v), 6) for v in res.q]
    raise AssertionError(f"{name}: no folded home found")


if __name__ == "__main__":
    root = Path(sys.argv[1])
    for robot in NAMES:
        for home in ("zero", "folded"):
            print(probe_cell(robot, root / f"{robot}_{home}", home))
