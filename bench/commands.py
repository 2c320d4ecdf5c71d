"""Wall time of rworld commands, for one or more source trees of rworld, in one run.

Run:  .venv/bin/python bench/commands.py [--trees DIR ...] [--repeat 3] [--only NAME ...]

Each tree is a checkout of this repository (``git worktree add /tmp/before REV`` gives an older
one); the commands run with that tree first on ``PYTHONPATH``, under this interpreter, in fresh
processes that take turns (tree after tree within each repetition), so a busy spell of the shared
machine hits every tree alike.  Reported: the best wall time per command and tree, and each tree
against the first.  The kernel cache is warm (a first run before the timed ones).

Commands (the examples of ``docs/planning.md`` on ``workcells/puma560``, and the probing
example of ``docs/calibration.md``):

* ``time-optimal``: the reference path, rated limits and torque, 400 grid points;
* ``payload``: the capacity of that path's time-optimal timing;
* ``load-optimal --shape``: the heaviest payload in 2.2 s, knots moved (Nelder-Mead);
* ``impulse``: the probe TCP to ``table.drop`` straight down with 2 kg;
* ``check probe``: ``rworld check workcells/probing probe`` (29 stops, 39 guarded moves), and
  with ``--no-collisions``;
* ``check tx2_60``, ``check iiwa14``, ``check gp7``: the vendor cells' tours
  (``tests/data/vendor_cells``), and each with ``--no-collisions``;
* ``check gp7 probe_top`` / ``probe_bottom``: the GP7 cell with a touch probe
  (:func:`gp7_probe_cell`), three touches on the plate's top planned and checked, and its
  underside asked for (a refusal: exit 1 is expected there);
* ``plan-measurements --program``: the probe program planned, checked and written (to a
  temporary file).
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
CELL = str(REPO / "workcells" / "puma560")  # the same input files for every tree
PATH = str(REPO / "workcells" / "puma560" / "paths" / "reference.yaml")
PROBING = str(REPO / "workcells" / "probing")
VENDOR = REPO / "tests" / "data" / "vendor_cells"
GP7_PROBE = Path(tempfile.gettempdir()) / "rworld-bench-gp7-probe"  # gp7_probe_cell()
OUT = Path(tempfile.gettempdir()) / "rworld-bench-probe.yaml"
COMMANDS = {
    "time-optimal": ["plan", "time-optimal", CELL, "--path", PATH],
    "payload": ["plan", "payload", CELL, "--path", PATH, "--tcp", "probe"],
    "load-optimal --shape": [
        "plan",
        "load-optimal",
        CELL,
        "--path",
        PATH,
        "--tcp",
        "probe",
        "--duration",
        "2.2",
        "--shape",
    ],
    "impulse": [
        "plan",
        "impulse",
        CELL,
        "--tcp",
        "probe",
        "--target",
        "table.drop",
        "--direction",
        "0,0,-1",
        "--payload-mass",
        "2",
    ],
    "check probe": ["check", PROBING, "probe"],
    "check probe --no-collisions": ["check", PROBING, "probe", "--no-collisions"],
    "check gp7 probe_top": ["check", str(GP7_PROBE), "probe_top"],
    "check gp7 probe_bottom": ["check", str(GP7_PROBE), "probe_bottom"],
    **{
        f"check {name}{extra}": ["check", str(VENDOR / name), "tour"] + extra.split()
        for name in ("tx2_60", "iiwa14", "gp7")
        for extra in ("", " --no-collisions")
    },
    "plan-measurements --program": ["plan-measurements", PROBING, "--program", str(OUT)],
}


def gp7_probe_cell() -> Path:
    """The GP7 vendor cell (tests/data/vendor_cells/gp7) with a touch probe (a 3 mm ball 100 mm
    past the flange) and the plate's features, in a temporary folder: ``probe_top`` plans and
    checks three touches on the plate's top; ``probe_bottom`` asks for its underside, which
    lies on the table (a refusal)."""
    import shutil

    folder = Path(tempfile.gettempdir()) / "rworld-bench-gp7-probe"
    shutil.rmtree(folder, ignore_errors=True)
    shutil.copytree(VENDOR / "gp7", folder)
    cell = (folder / "cell.yaml").read_text()
    cell = cell.replace("  tcps:\n  - name: tool0\n", "  tcps:\n  - name: tool0\n  - name: probe\n")
    cell = cell.replace(
        "    geometry: {mesh: {file: meshes/plate.stl, units: mm}}\n",
        "    geometry: {mesh: {file: meshes/plate.stl, units: mm}}\n"
        "    features:\n"
        "      - {name: top, plane: {point: [0.08, 0.06, 0.015], normal: [0, 0, 1]}}\n"
        "      - {name: bottom, plane: {point: [0.08, 0.06, 0], normal: [0, 0, -1]}}\n"
        "\nsensors:\n  - {name: probe_ball, type: touch, ball: 0.003}\n",
    )
    cell += "  - {parent: motoman_gp7.probe, child: probe_ball, type: rigid, kind: fixture}\n"
    (folder / "cell.yaml").write_text(cell)
    probe = "  motoman_gp7.probe:\n    xyz: [0.18, 0.0, 0.0]\n    rpy: [3.1415926, -1.570796, 0]\n"
    poses = (folder / "poses.yaml").read_text()
    poses = poses.replace("  motoman_gp7.base:", probe + "  motoman_gp7.base:")
    (folder / "poses.yaml").write_text(poses + "  probe_ball: {xyz: [0, 0, 0]}\n")
    for name, face in (("probe_top", "top"), ("probe_bottom", "bottom")):
        (folder / "programs" / f"{name}.yaml").write_text(
            "device: motoman_gp7\nunits: {angle: deg}\nsteps:\n"
            "  - move: {joints: [0, 20, -20, 0, -70, 0]}\n"
            f"  - probe: {{feature: plate.{face}, points: 3}}\n"
        )
    return folder


def run(tree: Path, args: list[str]) -> float:
    """Wall time [s] of ``rworld ARGS`` with ``tree``'s package, in a fresh process."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as users run it: bytecode kept between runs
    OUT.unlink(missing_ok=True)  # plan-measurements writes it
    code = (
        "import sys; from rworld_cli.cli import main; sys.argv = ['rworld'] + sys.argv[1:]; main()"
    )
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", code, "--json", *args],
        cwd=tree,  # python -c puts the working folder first on sys.path
        env=env,
        capture_output=True,
        text=True,
    )
    elapsed = time.perf_counter() - t0
    if done.returncode not in (0, 1) or (done.returncode == 1 and "probe_bottom" not in args):
        raise SystemExit(f"{tree}: rworld {' '.join(args)} exited {done.returncode}\n{done.stderr}")
    return elapsed


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trees", nargs="+", type=Path, default=[REPO])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--only", nargs="+", choices=list(COMMANDS), default=list(COMMANDS))
    args = parser.parse_args()
    trees = [t.resolve() for t in args.trees]
    if any("gp7 probe" in name for name in args.only):
        gp7_probe_cell()
    for tree in trees:  # warm the kernel cache and the imports' bytecode
        for name in args.only:
            run(tree, COMMANDS[name])
    best = {(name, tree): float("inf") for name in args.only for tree in trees}
    for _ in range(args.repeat):
        for name in args.only:
            for tree in trees:
                best[name, tree] = min(best[name, tree], run(tree, COMMANDS[name]))
    labels = [str(t) for t in trees]
    print(f"best of {args.repeat}, wall time of a fresh process [s]; ratio to the first tree\n")
    print(f"{'command':28s} | " + " | ".join(f"{label[-28:]:>28s}" for label in labels))
    for name in args.only:
        first = best[name, trees[0]]
        cells = [f"{best[name, t]:8.2f} s ({best[name, t] / first:5.2f}x)".rjust(28) for t in trees]
        print(f"{name:28s} | " + " | ".join(cells))


if __name__ == "__main__":
    main()
