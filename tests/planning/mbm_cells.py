"""MotionBenchMaker's Panda problems (``tests/data/mbm``, SOURCE.md there) as rworld cells.

Each problem of the archive - a MoveIt scene (boxes, cylinders, spheres with their poses) and a
request (the start state, the goal's joint constraints) - becomes a cell folder: MBM's own Panda
(``tests/data/mbm/panda``: robowflex_resources' URDF and collision meshes as vamp ships them,
the fingers fixed 65 mm open, imported once by ``rworld import urdf`` with its SRDF's disabled
pairs) at the world's origin, as MBM places it, and the scene's primitives as objects.

    python -m tests.planning.mbm_cells /tmp/mbm [--families box cage] [--limit 5]  # to look at

``bench/motion.py --mbm`` plans them (:func:`problems`, :func:`write_cell`).
"""

from __future__ import annotations

import argparse
import re
import sys
import tarfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[2]
ARCHIVE = REPO / "tests" / "data" / "mbm" / "panda_problems.tar.bz2"
PANDA_URDF = REPO / "tests" / "data" / "mbm" / "panda" / "panda.urdf"
FAMILIES = (
    "table_pick",
    "table_under_pick",
    "box",
    "bookshelf_small",
    "bookshelf_tall",
    "bookshelf_thin",
    "cage",
)
JOINTS = [f"panda_joint{k}" for k in range(1, 8)]
FRANKA_ACCELERATION = [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0]  # [rad/s^2], Franka's datasheet
LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def _pose(entry: dict) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat(np.asarray(entry["orientation"], dtype=float)).as_matrix()
    T[:3, 3] = entry["position"]
    return T


def _objects(scene: dict) -> list[dict]:
    """The scene's collision objects: name, kind, dimensions (MoveIt's), pose (4, 4) in world."""
    out = []
    for item in scene["world"]["collision_objects"]:
        base = _pose(item["pose"]) if "pose" in item else np.eye(4)
        primitive = item["primitives"][0]
        out.append(
            {
                "name": item["id"],
                "kind": primitive["type"],
                "dimensions": [float(v) for v in primitive["dimensions"]],
                "pose": base @ _pose(item["primitive_poses"][0]),
            }
        )
    return out


def _request(request: dict) -> tuple[list[float], list[float]]:
    state = request["start_state"]["joint_state"]
    start = [float(state["position"][state["name"].index(j)]) for j in JOINTS]
    goal_of = {
        c["joint_name"]: float(c["position"])
        for c in request["goal_constraints"][0]["joint_constraints"]
    }
    return start, [goal_of[j] for j in JOINTS]


def problems(families=None, limit: int | None = None) -> Iterator[dict]:
    """The archive's problems in order (family, then index): dicts with ``family``, ``index``,
    ``objects`` (see :func:`_objects`), ``start`` and ``goal`` (7 joint values [rad]).
    ``limit``: the first ``limit`` indices of each family."""
    wanted = set(families or FAMILIES)
    scenes: dict[tuple[str, int], dict] = {}
    requests: dict[tuple[str, int], dict] = {}
    with tarfile.open(ARCHIVE, "r:bz2") as tar:
        for member in tar.getmembers():
            if not member.isfile():
                continue
            _, folder, filename = member.name.split("/")
            family = folder.removesuffix("_panda")
            if family not in wanted:
                continue
            index = int(re.findall(r"\d+", filename)[0])
            if limit is not None and index > limit:  # MBM counts from 1
                continue
            data = yaml.load(tar.extractfile(member).read(), Loader=LOADER)  # type: ignore[union-attr]
            (scenes if filename.startswith("scene") else requests)[(family, index)] = data
    for family in FAMILIES:
        for key in sorted(k for k in scenes if k[0] == family):
            start, goal = _request(requests[key])
            yield {
                "family": family,
                "index": key[1],
                "objects": _objects(scenes[key]),
                "start": start,
                "goal": goal,
            }


def robot_cell(root: Path) -> Path:
    """MBM's Panda imported by rworld into ``root/panda`` (once; the folder reused after)."""
    from rworld_cli.api import import_urdf

    out = root / "panda"
    if not (out / "cell.yaml").is_file():
        import_urdf(
            str(PANDA_URDF),
            str(out),
            package_paths=[str(PANDA_URDF.parent)],
            tip="panda_hand",
            srdf=str(PANDA_URDF.with_suffix(".srdf")),
            overlap_states=0,
        )
        # the URDF has no acceleration limits; Franka's datasheet's, so programs can be timed
        cell = yaml.safe_load((out / "cell.yaml").read_text())
        for joint, limit in zip(cell["devices"][0]["joints"], FRANKA_ACCELERATION):
            joint["limits"]["acceleration"] = limit
        (out / "cell.yaml").write_text(yaml.safe_dump(cell, sort_keys=False))
    return out


def write_cell(problem: dict, folder: Path, robot: Path) -> Path:
    """The problem as a cell folder at ``folder`` (written, or rewritten): the Panda of
    ``robot`` (:func:`robot_cell`) and the scene's objects, in metres and radians."""
    folder.mkdir(parents=True, exist_ok=True)
    cell = yaml.safe_load((robot / "cell.yaml").read_text())
    poses = yaml.safe_load((robot / "poses.yaml").read_text())

    def relink(node):
        if isinstance(node, dict):
            for key, value in node.items():
                if key == "file" and isinstance(value, str):
                    node[key] = str(robot / value)
                else:
                    relink(value)
        elif isinstance(node, list):
            for value in node:
                relink(value)

    from rworld_cli import spatial

    relink(cell)
    cell["name"] = f"mbm_{problem['family']}_{problem['index']:04d}"
    cell["description"] = (
        f"MotionBenchMaker Panda, {problem['family']} {problem['index']} "
        "(tests/planning/mbm_cells.py)"
    )
    cell["pose_files"] = ["poses.yaml"]
    cell["objects"] = []
    for item in problem["objects"]:
        d = item["dimensions"]
        if item["kind"] == "box":
            geometry = {"box": d}
        elif item["kind"] == "cylinder":  # MoveIt: [height, radius]
            geometry = {"cylinder": {"radius": d[1], "length": d[0]}}
        elif item["kind"] == "sphere":
            geometry = {"sphere": {"radius": d[0]}}
        else:
            raise ValueError(f"{cell['name']}: a {item['kind']} primitive")
        cell["objects"].append({"name": item["name"], "mass": 1.0, "geometry": geometry})
        T = item["pose"]
        poses["poses"][item["name"]] = {
            "xyz": [float(v) for v in T[:3, 3]],
            "rpy": [float(v) for v in spatial.matrix_to_rpy(T[:3, :3])],
        }
    (folder / "cell.yaml").write_text(yaml.safe_dump(cell, sort_keys=False))
    (folder / "poses.yaml").write_text(yaml.safe_dump(poses, sort_keys=False))
    return folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="a folder for the cells")
    parser.add_argument("--families", nargs="+", default=list(FAMILIES), choices=FAMILIES)
    parser.add_argument("--limit", type=int, default=None, help="problems per family at most")
    args = parser.parse_args()
    count = 0
    robot = robot_cell(args.out)
    for problem in problems(args.families, args.limit):
        name = f"{problem['family']}_{problem['index']:04d}"
        write_cell(problem, args.out / name, robot)
        (args.out / name / "problem.yaml").write_text(
            yaml.safe_dump({"start": problem["start"], "goal": problem["goal"]})
        )
        count += 1
    print(f"wrote {count} cells under {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
