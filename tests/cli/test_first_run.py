"""The first command on a newly imported robot is as quick as the second (issue 62): the
import builds what a check would build - the links' convex parts, trees and walk tables, the
compiled collision and kinematics kernels - and leaves it in the cache, so the first
``check`` adds nothing there (measured in docs/performance.md; tests assert no timings)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from tests.conftest import REPO

UR = REPO / "tests" / "data" / "universal_robots"
TOUR = """\
device: ur20
units: {angle: deg}
steps:
  - move: {joints: [0, -90, 90, -90, -90, 0]}
  - move: {joints: [60, -60, 60, -90, -90, 30]}
"""


def _rworld(args: list[str], cache) -> subprocess.CompletedProcess:
    """rworld in a process of its own, as a user runs it (kernels are kept in a process)."""
    env = dict(os.environ, RWORLD_CACHE_DIR=str(cache))
    return subprocess.run(
        [str(Path(sys.executable).parent / "rworld"), *args],
        env=env,
        capture_output=True,
        text=True,
    )


def test_the_first_check_after_an_import_compiles_and_builds_nothing(tmp_path):
    cache = tmp_path / "cache"
    cell = tmp_path / "ur20"
    imported = _rworld(
        ["import", "urdf", str(UR / "ur_description" / "urdf" / "ur.urdf.xacro")]
        + ["--package-path", str(UR), "--xacro-arg", "ur_type:=ur20", "--xacro-arg", "name:=ur20"]
        + ["-o", str(cell)],
        cache,
    )
    assert imported.returncode == 0, imported.stderr
    text = (cell / "cell.yaml").read_text()  # URDF has no accelerations: the user adds them
    (cell / "cell.yaml").write_text(
        "\n".join(
            line + ("\n      acceleration: 5.0" if line.startswith("      velocity: ") else "")
            for line in text.splitlines()
        )
        + "\n"
    )
    (cell / "programs").mkdir()
    (cell / "programs" / "tour.yaml").write_text(TOUR)

    def built() -> set:
        return {
            p.relative_to(cache) for kind in ("kernels", "meshes") for p in (cache / kind).glob("*")
        }

    before = built()
    assert any(str(p).startswith("kernels") for p in before)  # the import compiled them
    checked = _rworld(["check", str(cell), "tour"], cache)
    assert checked.returncode == 0, checked.stderr
    assert built() == before
