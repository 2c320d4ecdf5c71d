"""Build the motion-planning scenes of issue 48 and their problem set.

Scenes (each a cell folder here; the robots' meshes are read from where they are already
vendored, by relative paths):

* ``panda_shelf``: the Franka Panda of ``workcells/panda`` before a shelf of three boards;
* ``panda_bin``: the Panda over an open bin on its table;
* ``panda_fixtures``: the Panda's table with a divider wall and two posts;
* ``panda_pair``: two Pandas on one table, 0.9 m apart, the second one held at a reaching
  pose (a two-robot cell: the planner works around the other arm where it stands);
* ``gp7_shelf``: the Yaskawa GP7 of ``tests/data/vendor_cells/gp7`` (the vendor's meshes)
  before a shelf;
* ``gp7_fixtures``: the GP7 cell's table with the holed plate, plus a wall and a post.

Problems (``problems.yaml``): per scene, start and goal joint states drawn uniformly in the
joint box (seeded), both free by ``rworld``'s configuration check, the straight joint segment
between them not free (a planner has work to do); a pair is kept when rworld or OMPL's
RRT-Connect (given rworld's checks) solves it within 30 s, so that the set holds no problem
no planner can solve here.  ``bench/motion.py`` runs them.

    python tests/data/motion/build.py           # rewrites the scenes and problems.yaml

The scenes and problems are committed; this script says how they were made.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
PANDA = ROOT / "workcells" / "panda"
GP7 = ROOT / "tests" / "data" / "vendor_cells" / "gp7"
PAIRS_PER_SCENE = 10


def box(name: str, size, xyz) -> tuple[dict, dict]:
    """An object (a box of ``size`` [m] whose frame is its centre) and its pose entry."""
    return {"name": name, "mass": 1.0, "geometry": {"box": [float(v) for v in size]}}, {
        "xyz": [float(v) for v in xyz]
    }


def shelf(x: float, width: float, depth: float, levels, prefix="shelf"):
    """A shelf before the robot: boards at ``levels`` [m], two sides and a back."""
    out = []
    top = max(levels)
    for k, z in enumerate(levels):
        out.append(box(f"{prefix}_board{k + 1}", [depth, width, 0.02], [x + depth / 2, 0, z]))
    for side, y in (("left", width / 2 + 0.01), ("right", -width / 2 - 0.01)):
        out.append(box(f"{prefix}_{side}", [depth, 0.02, top], [x + depth / 2, y, top / 2]))
    out.append(box(f"{prefix}_back", [0.02, width, top], [x + depth + 0.01, 0, top / 2]))
    return out


def bin_(x: float, inner: float, height: float):
    """An open bin on the table: a floor and four walls standing on it, meeting face to face
    (static bodies that overlap would be collisions of the cell itself)."""
    t = 0.01
    wall, z = height - t, t + (height - t) / 2
    return [
        box("bin_floor", [inner + 2 * t, inner + 2 * t, t], [x, 0, t / 2]),
        box("bin_near", [t, inner + 2 * t, wall], [x - inner / 2 - t / 2, 0, z]),
        box("bin_far", [t, inner + 2 * t, wall], [x + inner / 2 + t / 2, 0, z]),
        box("bin_left", [inner, t, wall], [x, inner / 2 + t / 2, z]),
        box("bin_right", [inner, t, wall], [x, -inner / 2 - t / 2, z]),
    ]


SCENES = {
    "panda_shelf": (PANDA, shelf(0.45, 0.6, 0.3, [0.2, 0.45, 0.7])),
    "panda_bin": (PANDA, bin_(0.5, 0.3, 0.2)),
    "panda_fixtures": (
        PANDA,
        [
            box("divider", [0.4, 0.04, 0.4], [0.45, 0.0, 0.2]),
            box("post_left", [0.06, 0.06, 0.5], [0.3, 0.35, 0.25]),
            box("post_right", [0.06, 0.06, 0.5], [0.3, -0.35, 0.25]),
        ],
    ),
    "panda_pair": (PANDA, []),
    "gp7_shelf": (GP7, shelf(0.5, 0.7, 0.3, [0.25, 0.55, 0.85])),
    "gp7_fixtures": (
        GP7,
        [
            box("wall", [0.02, 0.5, 0.5], [0.38, 0.25, 0.55]),
            box("post", [0.08, 0.08, 0.6], [0.35, -0.3, 0.6]),
        ],
    ),
}


def write_scene(name: str) -> Path:
    base, extra = SCENES[name]
    folder = HERE / name
    folder.mkdir(exist_ok=True)
    cell = yaml.safe_load((base / "cell.yaml").read_text())
    poses = yaml.safe_load((base / "poses.yaml").read_text())
    meshes = Path(*[".."] * len(folder.relative_to(ROOT).parts))  # back up to the repository

    def relink(node):
        if isinstance(node, dict):
            for k, v in node.items():
                if k == "file" and isinstance(v, str):
                    node[k] = str(meshes / base.relative_to(ROOT) / v)
                else:
                    relink(v)
        elif isinstance(node, list):
            for v in node:
                relink(v)

    relink(cell)
    cell["name"] = name
    cell["description"] = f"motion-planning scene '{name}' (tests/data/motion/build.py)"
    if base == PANDA:  # the table only: the block and its affixment are the pick example's
        cell["objects"] = [o for o in cell["objects"] if o["name"] == "table"]
        cell.pop("affixments", None)
        cell["units"] = {"length": "m", "angle": "rad"}
        for frame in ("block", "block.grasp", "table.drop"):
            poses["poses"].pop(frame, None)
        cell["objects"][0]["frames"] = [{"name": "top"}]
    if name == "panda_pair":
        other = yaml.safe_load(yaml.safe_dump(cell["devices"][0]))
        other["name"] = "panda_b"
        other["home"] = [0.0, 0.6, 0.0, -1.6, 0.0, 2.2, 0.785]
        cell["devices"].append(other)
        for key, value in list(poses["poses"].items()):
            if key == "panda" or key.startswith("panda."):
                poses["poses"]["panda_b" + key[len("panda") :]] = dict(value)
        poses["poses"]["panda_b"] = {"xyz": [0.9, 0.0, 0.0], "rpy": [0.0, 0.0, np.pi]}
        cell["allowed_contacts"].append(
            {"between": ["panda_b", "table"], "reason": "the base is bolted to the table top"}
        )
        cell["objects"][0]["geometry"] = {
            "box": [1.6, 1.0, 0.05],
            "origin": {"xyz": [0, 0, -0.025]},
        }
        poses["poses"]["table"] = {"xyz": [0.45, 0.0, 0.0]}
        poses["poses"]["table.top"] = {"xyz": [0.0, 0.0, 0.0]}
    if base == GP7:  # home with the arm drawn back: the shelf and the wall are where it reaches
        cell["devices"][0]["home"] = [0.0, -0.6, 0.3, 0.0, -0.5, 0.0]
    if name == "gp7_shelf":  # the shelf stands on the floor: no table, no plate
        cell["objects"] = []
        cell.pop("affixments", None)
        for frame in ("table", "table.top_center", "plate"):
            poses["poses"].pop(frame, None)
    for obj, pose in extra:
        cell["objects"].append(obj)
        poses["poses"][obj["name"]] = pose
    (folder / "cell.yaml").write_text(
        "# yaml-language-server: $schema=../../../../schemas/cell.schema.json\n"
        f"# Written by tests/data/motion/build.py from {base.relative_to(ROOT)}/cell.yaml.\n"
        + yaml.safe_dump(cell, sort_keys=False)
    )
    (folder / "poses.yaml").write_text(
        "# yaml-language-server: $schema=../../../../schemas/poses.schema.json\n"
        + yaml.safe_dump(poses, sort_keys=False)
    )
    return folder


def problems(name: str, seed: int, ompl_solve) -> list[dict]:
    """Start/goal pairs for a scene (module docstring)."""
    from rworld_cli.api import device_context
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.collision.configurations import ConfigurationChecker
    from rworld_cli.planning.motion import plan_in_world, sampled_box

    folder = HERE / name
    device = "motoman_gp7" if name.startswith("gp7") else "panda"
    ctx = device_context(str(folder), device)
    model = collision_model(ctx.world.cell)
    checker = ConfigurationChecker(ctx.world, model, device)
    lo, hi = (sampled_box(ctx.device.limit_array(w)) for w in ("lower", "upper"))
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < PAIRS_PER_SCENE:
        Q = rng.uniform(lo, hi, (64, len(lo)))
        Q = Q[checker.check(Q, nearest=False).free]
        for start, goal in zip(Q[0::2], Q[1::2]):
            if checker.check_segment(start, goal).free:
                continue
            plan, _ = plan_in_world(
                ctx.world, model, device, start, goal, tolerance=1e-3, seed=0, timeout=30.0
            )
            solved = plan.found or ompl_solve(ctx, model, device, start, goal, 30.0)
            print(f"{name}: pair {len(out) + 1}: rworld {plan.found}, kept {solved}", flush=True)
            if solved:
                out.append(
                    {
                        "scene": name,
                        "device": device,
                        "start": start.tolist(),
                        "goal": goal.tolist(),
                    }
                )
            if len(out) == PAIRS_PER_SCENE:
                break
    return out


def main() -> None:
    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(ROOT / "bench"))
    from motion import ompl_solve  # bench/motion.py: OMPL with rworld's checks

    for name in SCENES:
        write_scene(name)
    found = []
    for k, name in enumerate(SCENES):
        found += problems(name, 100 + k, ompl_solve)
    (HERE / "problems.yaml").write_text(
        "# Written by tests/data/motion/build.py: start and goal joint states [rad] per scene,\n"
        "# both free, the straight segment between them not; solvable (module docstring).\n"
        + yaml.safe_dump({"problems": found}, sort_keys=False, default_flow_style=None)
    )


if __name__ == "__main__":
    main()
