"""Build the vendor cells of issue 47 from the vendors' own ROS descriptions in tests/data.

Each cell is the robot as ``rworld import urdf`` writes it from the vendor's xacro, plus a
table, the holed plate of ``workcells/probing`` (2 900 triangles: a non-convex fixture) and a
program of joint moves that passes over, around and close to the plate.  The acceleration
limits (URDF has none) are this file's choice, in the ROS ``joint_limits.yaml`` format:
each joint's velocity limit per second (full speed in 1 s).

    python tests/data/vendor_cells/build.py        # rewrites tests/data/vendor_cells/*/

The cells are committed; this script says how they were made.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent
DATA = HERE.parent
ROOT = DATA.parent.parent

ROBOTS = {
    # name: (xacro, package path, table x [m], program joints [deg] per move)
    "tx2_60": (
        "staubli/staubli_tx2_60_support/urdf/tx2_60.xacro",
        "staubli",
        0.45,
        [
            [0, 20, 100, 0, 50, 0],
            [30, 40, 90, 10, 40, 0],
            [-20, 35, 95, -10, 45, 30],
            [0, 0, 90, 0, 0, 0],
        ],
    ),
    "iiwa14": (
        "kuka_iiwa/kuka_lbr_iiwa_support/urdf/lbr_iiwa_14_r820.xacro",
        "kuka_iiwa",
        0.55,
        [
            [0, 40, 0, -80, 0, 50, 0],
            [25, 45, 10, -75, 0, 55, 20],
            [-25, 45, -10, -75, 0, 55, -20],
            [0, 20, 0, -100, 0, 50, 0],
            [0, 0, 0, 0, 0, 0, 0],
        ],
    ),
    "gp7": (
        "motoman/motoman_gp7_support/urdf/gp7.xacro",
        "motoman",
        0.5,
        [
            [0, 20, -20, 0, -70, 0],
            [25, 30, -10, 0, -80, 0],
            [-25, 30, -10, 0, -80, 0],
            [0, 10, -30, 0, -60, 0],
            [0, 0, 0, 0, 0, 0],
        ],
    ),
}


def import_robot(xacro: Path, package: Path, out: Path, limits: Path | None = None) -> None:
    command = [
        "rworld",
        "import",
        "urdf",
        str(xacro.relative_to(ROOT)),
        "--package-path",
        str(package.relative_to(ROOT)),
        "-o",
        str(out),
    ]
    if limits is not None:
        command += ["--joint-limits", str(limits)]
    subprocess.run(command, check=True, cwd=ROOT, capture_output=True)


def joint_limits(cell: Path) -> dict:
    """Velocities as imported from the vendor's URDF, accelerations equal to them (module
    docstring), in ROS's joint_limits.yaml format."""
    joints = yaml.safe_load((cell / "cell.yaml").read_text())["devices"][0]["joints"]
    return {
        "joint_limits": {
            j["name"]: {
                "has_velocity_limits": True,
                "max_velocity": j["limits"]["velocity"],
                "has_acceleration_limits": True,
                "max_acceleration": round(j["limits"]["velocity"], 4),
            }
            for j in joints
        }
    }


def build(name: str) -> None:
    xacro_rel, package_rel, table_x, moves = ROBOTS[name]
    xacro, package = DATA / xacro_rel, DATA / package_rel
    out = HERE / name
    with tempfile.TemporaryDirectory() as tmp:
        first = Path(tmp) / "first"
        import_robot(xacro, package, first)
        limits = Path(tmp) / "joint_limits.yaml"
        limits.write_text(yaml.safe_dump(joint_limits(first)))
        cell = Path(tmp) / "cell"
        import_robot(xacro, package, cell, limits)
        text = (cell / "cell.yaml").read_text()
        device = yaml.safe_load(text)["devices"][0]["name"]
        shutil.copy(ROOT / "workcells/probing/meshes/plate.stl", cell / "meshes/plate.stl")
        (cell / "cell.yaml").write_text(
            text
            + """
objects:
  - name: table
    geometry: {box: [0.6, 0.8, 0.3], origin: {xyz: [0, 0, -0.15]}}
    frames:
      - name: top_center
  - name: plate            # workcells/probing's 160 x 120 x 15 mm plate with two 20 mm holes
    mass: 2.2
    geometry: {mesh: {file: meshes/plate.stl, units: mm}}

affixments:
  - {parent: table.top_center, child: plate, type: non_rigid, kind: rests_on}
"""
        )
        poses = (cell / "poses.yaml").read_text()
        (cell / "poses.yaml").write_text(
            poses
            + f"""  table: {{xyz: [{table_x}, 0, 0.3]}}
  table.top_center: {{xyz: [0, 0, 0]}}
  plate: {{xyz: [-0.08, -0.06, 0]}}
"""
        )
        programs = cell / "programs"
        programs.mkdir()
        steps = "\n".join(f"  - move: {{joints: {m}}}" for m in moves)
        (programs / "tour.yaml").write_text(
            f"""device: {device}
description: joint moves over and around the plate on the table
units: {{angle: deg}}
steps:
{steps}
"""
        )
        if out.exists():
            shutil.rmtree(out)
        shutil.copytree(cell, out)


if __name__ == "__main__":
    for robot in sys.argv[1:] or ROBOTS:
        build(robot)
        print(f"wrote {HERE / robot}")
