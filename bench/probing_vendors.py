"""Probing on vendor robots rworld was not built on (issue 60): for each robot of
``tests/data/probe_robots`` from its vendor's zero pose and from a folded home, in the cell of
``tests/calibration/probe_cells.py`` (a table, the holed plate, a wall, a ball probe on a stem):

* ``check features``: the program of feature steps (the plate's top, front face, two holes,
  then home by a free path), the first run (kernels and the cell cache cold for this cell)
  and the second;
* ``plan-measurements --program``: the planned probe program, written only if it passes its
  own check;
* ``check planned``: that program checked again, as CI would;
* ``after calibration``: both programs checked again with the plate where a calibration put it
  (an overlay pose file moving it 0.8 mm and 0.75 mm in the table's plane and 0.3 deg about its
  normal): its targets move with it and the programs do not change.

Each command is a fresh process; reported are its exit code and wall time.

Run:  .venv/bin/python bench/probing_vendors.py [--robots NAME ...] [--homes zero folded]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from tests.calibration.probe_cells import NAMES, calibrated_copy, probe_cell  # noqa: E402


def run(args: list[str]) -> tuple[int, float, str]:
    """(exit code, wall time [s], last line of stderr and stdout) of ``rworld ARGS``."""
    t0 = time.perf_counter()
    code = "import sys; from rworld_cli.cli import main; sys.argv[0] = 'rworld'; main()"
    done = subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=REPO
    )
    elapsed = time.perf_counter() - t0
    lines = [line for line in (done.stdout + done.stderr).splitlines() if "watertight" not in line]
    return done.returncode, elapsed, (lines[-1] if lines else "")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=list(NAMES), choices=NAMES)
    parser.add_argument("--homes", nargs="+", default=["zero", "folded"])
    parser.add_argument("--verbose", action="store_true", help="each failure's last line")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="rworld-probe-vendors-"))
    rows, failures = [], []
    for robot in args.robots:
        for home in args.homes:
            cell = probe_cell(robot, root / f"{robot}_{home}", home)
            features = str(cell / "programs" / "features.yaml")
            planned = str(cell / "programs" / "planned.yaml")
            results = [
                run(["check", str(cell), features]),
                run(["check", str(cell), features]),
                run(["plan-measurements", str(cell), "--program", planned]),
            ]
            results.append(
                run(["check", str(cell), planned]) if Path(planned).exists() else (None, 0.0, "")
            )
            moved = calibrated_copy(cell)
            results.append(run(["check", str(moved), features]))
            results.append(
                run(["check", str(moved), planned]) if Path(planned).exists() else (None, 0.0, "")
            )
            rows.append((robot, home, results))
            names = ("check features", "check features", "plan-measurements", "check planned")
            names += ("calibrated: check features", "calibrated: check planned")
            for what, (code, _, last) in zip(names, results):
                if code not in (0, None):
                    failures.append(f"{robot} {home} {what}: {last}")
    print("exit code and wall time [s] of each command (fresh processes)\n")
    print(
        f"{'robot':<14}{'home':<8}{'check features 1st':>20}{'2nd':>12}"
        f"{'plan-measurements':>20}{'check planned':>16}{'calibrated: features':>22}"
        f"{'planned':>12}"
    )
    for robot, home, results in rows:
        c = [
            "-" if code is None else f"{'ok' if code == 0 else f'exit {code}'} {t:6.1f}"
            for code, t, _ in results
        ]
        print(f"{robot:<14}{home:<8}{c[0]:>20}{c[1]:>12}{c[2]:>20}{c[3]:>16}{c[4]:>22}{c[5]:>12}")
    passed = sum(code == 0 for _, _, results in rows for code, _, _ in results if code is not None)
    total = sum(code is not None for _, _, results in rows for code, _, _ in results)
    print(f"\n{passed} of {total} commands passed")
    if args.verbose:
        for line in failures:
            print(line)


if __name__ == "__main__":
    main()
