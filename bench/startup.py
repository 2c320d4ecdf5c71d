"""Start-up, validation and simulation wall times of the CLI, beside a bare Python start.

Run:  .venv/bin/python bench/startup.py [--repeat 20]
      .venv/bin/python bench/startup.py --baseline ../base --repeat 9   # against a revision

Each command runs REPEAT times in a fresh process; the table gives the
median and the ratio to a bare `python -c pass` measured in the same run
(the machines are shared: compare ratios, not absolute times).  The per-cell
commands (validate, show, kinematics fk of one state) are issue 35's start-up
figures: the meshed Panda cell reads its meshes' facts from the disk cache
after the first run (``schema.loader._mesh_facts``).

The package's bytecode is compiled first, as ``pip install`` does: an editable
checkout under ``PYTHONDONTWRITEBYTECODE=1`` (this machine's default) would
otherwise compile some 30 of rworld's modules from source in every process,
about 0.07 s that no installed copy pays.
"""

from __future__ import annotations

import argparse
import compileall
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def one_time(cmd: list[str], env: dict | None = None) -> float:
    t0 = time.perf_counter()
    subprocess.run(
        cmd, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False, env=env
    )
    return time.perf_counter() - t0


def median_time(cmd: list[str], repeat: int) -> float:
    return statistics.median(one_time(cmd) for _ in range(repeat))


def tree_env(tree: Path, cache: Path) -> dict:
    """Run rworld from the checkout ``tree`` (its package first on the path), with its own
    cache folder (two revisions' cache entries must not evict each other)."""
    return os.environ | {"PYTHONPATH": str(tree), "RWORLD_CACHE_DIR": str(cache)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=20)
    parser.add_argument(
        "--baseline",
        type=Path,
        default=None,
        metavar="DIR",
        help="A checkout of another revision (git worktree add DIR REV): each command runs "
        "alternately from it and from this one, each with its own cache folder; the ratio "
        "this / baseline is printed.",
    )
    args = parser.parse_args()
    compileall.compile_dir(REPO / "rworld_cli", quiet=1)
    rworld = shutil.which("rworld", path=str(Path(sys.executable).parent)) or "rworld"
    cells = sorted(str(p.relative_to(REPO)) for p in (REPO / "workcells").glob("*/cell.yaml"))
    runs = [
        ("python -c pass (baseline)", [sys.executable, "-c", "pass"]),
        ("rworld --help", [rworld, "--help"]),
        (f"rworld validate ({len(cells)} example cells)", [rworld, "validate", *cells]),
        ("rworld show workcells/paper_fig9", [rworld, "show", "workcells/paper_fig9"]),
        (
            "rworld --json show workcells/paper_fig9",
            [rworld, "--json", "show", "workcells/paper_fig9"],
        ),
        *(
            (
                f"rworld {what} workcells/{cell}",
                [rworld, *what.split(), f"workcells/{cell}", *extra],
            )
            for cell, q in (("puma560", "0,0.5,-1,0,0.3,0"), ("panda", "0,0,0,-1.5,0,1.5,0"))
            for what, extra in (("validate", []), ("show", []), ("kinematics fk", ["--q", q]))
        ),
        (  # issue 62: everything check loads before it reads a cell (here: none is there)
            "rworld check: start-up to the cell's read",
            [rworld, "check", "/nonexistent-cell", "/nonexistent-cell/run.yaml"],
        ),
        (
            "rworld check workcells/puma560 pick_place",
            [rworld, "check", "workcells/puma560", "pick_place"],
        ),
        (
            "rworld check workcells/paper_fig9 transfer",
            [rworld, "check", "workcells/paper_fig9", "transfer"],
        ),
    ]
    if args.baseline is not None:
        compare(runs, args.baseline.resolve(), args.repeat)
        return
    base = None
    print(f"{'command':42s} {'median [s]':>11s} {'x baseline':>11s}")
    for label, cmd in runs:
        t = median_time(cmd, args.repeat)
        base = base or t
        print(f"{label:42s} {t:11.3f} {t / base:11.1f}")


def compare(runs, baseline: Path, repeat: int) -> None:
    """Each command alternately from the baseline checkout and from this one (caches warmed
    by one run each first); medians and the ratio."""
    import tempfile

    compileall.compile_dir(baseline / "rworld_cli", quiet=1)
    with tempfile.TemporaryDirectory() as scratch:
        envs = {
            "baseline": tree_env(baseline, Path(scratch) / "baseline"),
            "this": tree_env(REPO, Path(scratch) / "this"),
        }
        print(f"{'command':42s} {'baseline [s]':>12s} {'this [s]':>9s} {'ratio':>6s}")
        for label, cmd in runs[1:]:
            for env in envs.values():
                one_time(cmd, env)  # caches filled
            times: dict[str, list[float]] = {"baseline": [], "this": []}
            for _ in range(repeat):
                for name, env in envs.items():
                    times[name].append(one_time(cmd, env))
            old, new = (statistics.median(times[k]) for k in ("baseline", "this"))
            print(f"{label:42s} {old:12.3f} {new:9.3f} {new / old:6.2f}")


if __name__ == "__main__":
    main()
