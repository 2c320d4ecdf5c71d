"""Pose planning for robot calibration (``rworld plan-robot-calibration``) at a vendor robot's
size: the Yaskawa GP7 from ROS-Industrial's xacro (tests/data/motoman), 30 tracker poses of
its flange from 2000 candidates, and the program that visits them checked in simulation.
Issue 46 asks for 30 s and 1 GB here.

Run:  .venv/bin/python bench/robot_calibration_plan.py
      .venv/bin/python bench/robot_calibration_plan.py --baseline /tmp/prev   # another checkout

Prints the wall time and the peak resident memory of the command (its own process, from
``os.wait4``), and with ``--baseline`` the same for the other checkout's rworld_cli (put first
on PYTHONPATH) in the same run, with the ratios.  The link meshes' hulls have up to 3202
vertices: the collision queries' memory is what this measures.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MOTOMAN = REPO / "tests" / "data" / "motoman"
LIMITS = "joint_limits:\n" + "".join(  # as docs/walkthrough.md gives them
    f"  {name}: {{has_acceleration_limits: true, max_acceleration: {a}}}\n"
    for name, a in (("joint_1_s", 10.0), ("joint_2_l", 10.0), ("joint_3_u", 10.0),
                    ("joint_4_r", 20.0), ("joint_5_b", 20.0), ("joint_6_t", 20.0))
)  # fmt: skip
RWORLD = str(Path(sys.executable).parent / "rworld")  # the venv's script: PYTHONPATH picks the code


def measure(folder: Path, pythonpath: str | None, label: str) -> tuple[float, float]:
    """(seconds, peak RSS [GB]) of one plan-robot-calibration run on the GP7 cell."""
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    program = folder / f"cal_{label}.yaml"
    command = [RWORLD, "plan-robot-calibration", str(folder / "gp7")]
    command += ["--device", "motoman_gp7", "--poses", "30", "--target", "tool0"]
    command += ["--program", str(program), "-o", str(folder / f"obs_{label}.yaml")]
    started = time.perf_counter()
    child = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    _, status, usage = os.wait4(child.pid, 0)
    seconds = time.perf_counter() - started
    output = child.stdout.read().decode() if child.stdout else ""
    if status != 0:
        raise SystemExit(f"{label}: exit {status >> 8}\n{output}")
    return seconds, usage.ru_maxrss / 1024**2  # kB -> GB


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--baseline", help="another checkout's folder (its rworld_cli)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        gp7 = MOTOMAN / "motoman_gp7_support" / "urdf" / "gp7.xacro"
        (folder / "joint_limits.yaml").write_text(LIMITS)
        subprocess.run(
            [RWORLD, "import", "urdf", str(gp7), "--package-path"]
            + [str(MOTOMAN), "--joint-limits", str(folder / "joint_limits.yaml")]
            + ["-o", str(folder / "gp7")],
            check=True,
            capture_output=True,
        )
        rows = [("this checkout", *measure(folder, None, "this"))]
        if args.baseline:
            rows.append(("baseline", *measure(folder, args.baseline, "baseline")))
    print(f"{'rworld':<16}{'wall [s]':>10}{'peak RSS [GB]':>16}")
    for label, seconds, gigabytes in rows:
        print(f"{label:<16}{seconds:>10.1f}{gigabytes:>16.2f}")
    if len(rows) == 2:
        print(
            f"ratio this/baseline: time {rows[0][1] / rows[1][1]:.2f}, "
            f"memory {rows[0][2] / rows[1][2]:.2f}"
        )


if __name__ == "__main__":
    main()
