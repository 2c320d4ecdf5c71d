"""The first command on a newly imported vendor robot beside the second (issue 62).

Run:  .venv/bin/python bench/first_run.py [--repeat 3]

For each robot (its vendor's ROS package as vendored in tests/data: UR20, Yaskawa GP7, KUKA
LBR iiwa 14): ``rworld import urdf`` into a fresh cache (``RWORLD_CACHE_DIR``: nothing
compiled, nothing built), acceleration limits added (URDF has none), a three-move joint
program, then ``rworld check`` twice, each in a process of its own, as a user runs them.
Printed: the import's time, the first and the second check's, and first / second - the
import builds and compiles what a check needs (``api.robots._warm_caches``); before it, the
first check took 5.5 times the second on the UR20.  Each robot ``--repeat`` times with a
fresh cache; the median of each column.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "tests" / "data"
RWORLD = str(Path(sys.executable).parent / "rworld")

ROBOTS = {
    "UR20": (
        ["import", "urdf", str(DATA / "universal_robots/ur_description/urdf/ur.urdf.xacro")]
        + ["--package-path", str(DATA / "universal_robots")]
        + ["--xacro-arg", "ur_type:=ur20", "--xacro-arg", "name:=ur20"],
        "ur20",
        "[0, -90, 90, -90, -90, 0]",
        "[60, -60, 60, -90, -90, 30]",
    ),
    "GP7": (
        ["import", "urdf", str(DATA / "motoman/motoman_gp7_support/urdf/gp7.xacro")]
        + ["--package-path", str(DATA / "motoman")],
        "motoman_gp7",
        "[0, 0, 0, 0, -90, 0]",
        "[60, 20, -10, 30, -60, 30]",
    ),
    "LBR iiwa 14": (
        [
            "import",
            "urdf",
            str(DATA / "kuka_iiwa/kuka_lbr_iiwa_support/urdf/lbr_iiwa_14_r820.xacro"),
        ]
        + ["--package-path", str(DATA / "kuka_iiwa")],
        "kuka_lbr_iiwa_14_r820",
        "[0, 30, 0, -60, 0, 60, 0]",
        "[40, 50, 20, -80, 30, 40, 10]",
    ),
}


def timed(args: list[str], cache: Path) -> float:
    env = dict(os.environ, RWORLD_CACHE_DIR=str(cache))
    t0 = time.perf_counter()
    done = subprocess.run([RWORLD, *args], env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"rworld {' '.join(args)}: exit {done.returncode}\n{done.stderr}")
    return seconds


def one(name: str, root: Path) -> tuple[float, float, float]:
    command, device, a, b = ROBOTS[name]
    cache, cell = root / "cache", root / "cell"
    imported = timed([*command, "-o", str(cell)], cache)
    text = (cell / "cell.yaml").read_text()
    lines = []
    for line in text.splitlines():
        lines.append(line)
        if line.strip().startswith("velocity:") and line.startswith("      velocity"):
            lines.append("      acceleration: 5.0")
    (cell / "cell.yaml").write_text("\n".join(lines) + "\n")
    (cell / "programs").mkdir(exist_ok=True)
    (cell / "programs" / "tour.yaml").write_text(
        f"device: {device}\nunits: {{angle: deg}}\nsteps:\n  - move: {{joints: {a}}}\n"
        f"  - move: {{joints: {b}}}\n  - move: {{joints: {a}}}\n"
    )
    first = timed(["check", str(cell), "tour"], cache)
    second = timed(["check", str(cell), "tour"], cache)
    return imported, first, second


def main() -> None:
    sys.path.insert(0, str(REPO / "bench"))
    from machine import cpu_model

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(f"# First run on a newly imported robot: {cpu_model()}\n")
    print("| robot | import [s] | first check [s] | second check [s] | first / second |")
    print("|---|---:|---:|---:|---:|")
    for name in ROBOTS:
        rows = []
        for _ in range(args.repeat):
            with tempfile.TemporaryDirectory() as folder:
                rows.append(one(name, Path(folder)))
        imported, first, second = (statistics.median(col) for col in zip(*rows))
        print(
            f"| {name} | {imported:.2f} | {first:.2f} | {second:.2f} | {first / second:.2f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
