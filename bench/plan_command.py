"""The whole ``rworld --json plan path`` command on MotionBenchMaker's Panda problems: its wall
time beside the planner's own (``seconds`` in its JSON); the rest is start-up, reading the cell,
building the checks, the ends' checks and the output.

Run:  .venv/bin/python bench/plan_command.py [--per-family 3]

The first ``--per-family`` problems of each family (``tests/data/mbm``) are written as cells
(``tests/planning/mbm_cells.py``); each command runs twice and the second is timed (the first
fills the cell's and the kernels' caches, as a user's second command finds them).
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
RWORLD = Path(sys.executable).parent / "rworld"


def main() -> None:
    from machine import cpu_model

    from tests.planning import mbm_cells as mbm

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-family", type=int, default=3, help="problems of each family")
    args = parser.parse_args()
    cpu = cpu_model()
    print(f"# rworld plan path, whole commands: {cpu}, Python {platform.python_version()}\n")
    root = Path(tempfile.mkdtemp(prefix="rworld-command-"))
    robot = mbm.robot_cell(root)
    rows = []
    for problem in mbm.problems(None, args.per_family):
        name = f"{problem['family']} {problem['index']}"
        folder = mbm.write_cell(problem, root / name.replace(" ", "_"), robot)
        command = [str(RWORLD), "--json", "plan", "path", str(folder), "--device", "panda"]
        command += ["--from", ",".join(f"{v:.17g}" for v in problem["start"])]
        command += ["--to", ",".join(f"{v:.17g}" for v in problem["goal"])]
        command += ["--seed", str(problem["index"])]
        subprocess.run(command, capture_output=True, text=True)
        t0 = time.perf_counter()
        out = subprocess.run(command, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        report = json.loads(out.stdout)
        rows.append((name, bool(report.get("found")), wall, float(report.get("seconds", np.nan))))
        print(f"{name}: found {rows[-1][1]}, command {wall:.3f} s, planning {rows[-1][3]:.3f} s")
    wall = np.array([r[2] for r in rows])
    plan = np.array([r[3] for r in rows])
    print(
        f"\n{sum(r[1] for r in rows)} of {len(rows)} found; the command a median "
        f"{np.median(wall):.3f} s, planning {np.median(plan):.3f} s, the rest "
        f"{np.median(wall - plan):.3f} s"
    )


if __name__ == "__main__":
    main()
