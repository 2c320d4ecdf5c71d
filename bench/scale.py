"""Scale: one cell of N Puma 560s on a grid, 2 m apart, each with its own program of four joint
moves (nothing to hit), checked in one run by ``rworld check`` with and without collisions.

Run:  .venv/bin/python bench/scale.py [--robots 16 64 256] [--repeat 3] [--keep DIR]

Printed per N: the median wall time and peak memory (max RSS) of ``rworld check CELL line``
and of ``rworld check CELL line --no-collisions`` in fresh processes, run alternately, their
ratio, and the time per robot (linear growth: the same per robot at every N).  Both start from
the same state: a ``validate`` first fills the caches (compiled kernels, the loaded cell,
``schema/cellcache.py``).  The last three columns repeat the pair with the cell cache off
(``RWORLD_CELL_CACHE=0``: YAML and every check of the cell on every run, as on a CI machine
with an empty cache).
"""

from __future__ import annotations

import argparse
import copy
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]


def line_cell(folder: Path, robots: int, seed: int = 0, spacing: float = 2.0) -> Path:
    """Write a cell of ``robots`` copies of workcells/puma560's Puma on a square grid
    ``spacing`` [m] apart, each with a program of four joint moves to random states within
    its limits and back home, and a run ``line`` of all the programs.  Returns the cell folder.
    """
    source = yaml.safe_load((REPO / "workcells" / "puma560" / "cell.yaml").read_text())
    puma = source["devices"][0]
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "programs").mkdir(exist_ok=True)
    (folder / "runs").mkdir(exist_ok=True)
    side = int(np.ceil(np.sqrt(robots)))
    rng = np.random.default_rng(seed)
    devices, poses, programs = [], {}, []
    lower = np.array([j["limits"]["position"][0] for j in puma["joints"]])
    upper = np.array([j["limits"]["position"][1] for j in puma["joints"]])
    for k in range(robots):
        name = f"puma_{k:03d}"
        device = copy.deepcopy(puma)
        device["name"] = name
        devices.append(device)
        poses[name] = {"xyz": [spacing * (k % side), spacing * (k // side), 0.0]}
        poses[f"{name}.tool"] = {"xyz": [0, 0, 0]}
        poses[f"{name}.probe"] = {"xyz": [0, 0, 0.1]}
        steps = []
        for _ in range(4):  # the middle half of each joint's range: no self-collision
            q = rng.uniform(0.75 * lower + 0.25 * upper, 0.25 * lower + 0.75 * upper)
            steps.append({"move": {"joints": [round(float(v), 4) for v in np.degrees(q)]}})
        steps.append({"move": {"to": "home"}})
        program = {
            "device": name,
            "description": f"four joint moves of {name}",
            "units": {"length": "mm", "angle": "deg"},
            "steps": steps,
        }
        (folder / "programs" / f"{name}.yaml").write_text(yaml.safe_dump(program, sort_keys=False))
        programs.append(f"../programs/{name}.yaml")
    cell = {
        "name": f"line_{robots}",
        "description": f"{robots} Puma 560s on a {spacing} m grid",
        "units": source["units"],
        "pose_files": ["poses.yaml"],
        "devices": devices,
    }
    (folder / "cell.yaml").write_text(yaml.safe_dump(cell, sort_keys=False))
    (folder / "poses.yaml").write_text(
        yaml.safe_dump({"units": {"length": "m", "angle": "deg"}, "poses": poses}, sort_keys=False)
    )
    run = {"description": f"all {robots} robots at once", "programs": programs, "dt": 0.01}
    (folder / "runs" / "line.yaml").write_text(yaml.safe_dump(run, sort_keys=False))
    return folder


def measured(cmd: list[str], env: dict | None = None) -> tuple[float, float, int]:
    """(wall time [s], peak RSS of the child [MB], exit code) of one fresh process."""
    wrapper = [
        sys.executable,
        "-c",
        "import resource, subprocess, sys, time; t = time.perf_counter(); "
        "rc = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL).returncode; "
        "w = time.perf_counter() - t; "
        "print(w, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024, rc)",
    ]
    out = subprocess.run(
        wrapper + cmd, capture_output=True, text=True, check=True, cwd=REPO, env=env
    ).stdout
    wall, rss, rc = out.split()
    return float(wall), float(rss), int(rc)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robots", type=int, nargs="+", default=[16, 64, 256])
    parser.add_argument("--keep", type=Path, default=None, help="Write the cells here.")
    parser.add_argument("--repeat", type=int, default=3, help="Alternating runs per figure.")
    args = parser.parse_args()
    rworld = shutil.which("rworld", path=str(Path(sys.executable).parent)) or "rworld"
    root = args.keep or Path(tempfile.mkdtemp())
    print(
        f"{'robots':>6} {'check':>9} {'MB':>6} {'limits only':>11} {'MB':>6} {'ratio':>6} "
        f"{'s / robot':>9} | cell cache off: {'check':>7} {'limits':>7} {'ratio':>6}"
    )
    cold = os.environ | {"RWORLD_CELL_CACHE": "0"}
    for n in args.robots:
        cell = line_cell(root / f"line_{n}", n)
        subprocess.run([rworld, "validate", str(cell)], capture_output=True, check=True)

        def pair(env=None):
            full, bare = [], []
            for _ in range(args.repeat):
                full.append(measured([rworld, "check", str(cell), "line"], env))
                bare.append(measured([rworld, "check", str(cell), "line", "--no-collisions"], env))
            assert all(r[2] == 0 for r in full + bare), (full, bare)
            return [
                (statistics.median(r[0] for r in runs), max(r[1] for r in runs))
                for runs in (full, bare)
            ]

        (t_full, mb_full), (t_bare, mb_bare) = pair()
        (c_full, _), (c_bare, _) = pair(cold)
        print(
            f"{n:>6} {t_full:>8.2f}s {mb_full:>6.0f} {t_bare:>10.2f}s {mb_bare:>6.0f} "
            f"{t_full / t_bare:>6.2f} {t_full / n:>9.3f} | {'':15}{c_full:>6.2f}s {c_bare:>6.2f}s "
            f"{c_full / c_bare:>6.2f}"
        )


if __name__ == "__main__":
    main()
