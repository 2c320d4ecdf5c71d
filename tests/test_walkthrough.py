"""docs/walkthrough.md is run as written (issue 50): each ```console block's `$ ` commands in
an empty folder outside the clone (issue 62: `RWORLD` names the clone, as the page tells the
user to set it), in order, each exiting 0, and the output lines the document shows appear in
what rworld prints, in order, numbers to a few units of their last digit; and the page shows
every warning rworld prints (a block without `...` shows every line).  Then the calibrated
plate is checked against the made-up truth.

To rewrite the document's outputs after a deliberate change:
``python -m tests.test_walkthrough --write``.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

from tests.conftest import REPO

DOC = REPO / "docs" / "walkthrough.md"
NUMBER = re.compile(r"-?\d+(?:\.\d+)?")


def commands(text: str) -> list[tuple[str, list[str], tuple[int, int]]]:
    """Each command of the console blocks: its text (with its here-document), the output lines
    shown after it, and the line span of those output lines in ``text``."""
    lines = text.splitlines()
    out, i, inside = [], 0, False
    while i < len(lines):
        line = lines[i]
        if line.startswith("```"):
            inside = line == "```console"
            i += 1
            continue
        if not inside:
            i += 1
            continue
        assert line.startswith("$ "), f"{DOC}:{i + 1}: a console block line outside a command"
        command = [line[2:]]
        i += 1
        heredoc = re.search(r"<<'(\w+)'", line)
        if heredoc:
            while lines[i] != heredoc.group(1):
                command.append(lines[i])
                i += 1
            command.append(lines[i])
            i += 1
        start = i
        while not lines[i].startswith(("$ ", "```")):
            i += 1
        out.append(("\n".join(command), lines[start:i], (start, i)))
    return out


def run(command: str, folder: Path) -> str:
    env = dict(os.environ, COLUMNS="80", NO_COLOR="1", TERM="dumb", RWORLD=str(REPO))
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env['PATH']}"
    done = subprocess.run(
        ["bash", "-c", command],
        cwd=folder,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, f"$ {command}\nexit {done.returncode}\n{done.stdout}"
    return done.stdout


def same(printed: str, shown: str) -> bool:
    """The same line: equal text around the numbers, integers equal, each decimal within 5
    units of the shown one's last digit or 1 % of it (rounding of fits on another CPU)."""
    if NUMBER.split(printed.rstrip()) != NUMBER.split(shown.rstrip()):
        return False
    a, b = NUMBER.findall(printed), NUMBER.findall(shown)
    if len(a) != len(b):
        return False
    for x, y in zip(a, b, strict=True):
        if "." not in y:  # counts, lines, columns: exact
            if x != y:
                return False
            continue
        digits = len(y.split(".")[1])
        if abs(float(x) - float(y)) > max(5 * 10.0**-digits, 0.01 * abs(float(y))):
            return False
    return True


def shown_in(printed: list[str], shown: list[str]) -> str | None:
    """None when every shown line (other than `...`) appears in order; else the first missing."""
    at = 0
    for line in shown:
        if line.strip() in ("", "..."):
            continue
        while at < len(printed) and not same(printed[at], line):
            at += 1
        if at == len(printed):
            return line
        at += 1
    return None


def unshown(printed: list[str], shown: list[str]) -> str | None:
    """The first line rworld printed that the page must show and does not: every warning and
    note always, and every line of a block that leaves nothing out (no `...`)."""
    kept = [line for line in shown if line.strip() not in ("", "...")]
    every = not any(line.strip() == "..." for line in shown)
    for line in printed:
        if not line.strip():
            continue
        if (every or "warning:" in line or "note:" in line) and not any(
            same(line, s) for s in kept
        ):
            return line
    return None


def setup_folder(folder: Path) -> None:
    """An empty folder of the user's own, outside the clone (``RWORLD`` names the clone)."""
    assert not any(folder.iterdir())


def test_the_walkthrough_runs_as_written(tmp_path):
    setup_folder(tmp_path)
    for command, shown, _ in commands(DOC.read_text()):
        printed = run(command, tmp_path).splitlines()
        missing = shown_in(printed, shown)
        assert missing is None, (
            f"$ {command}\nthe document shows:\n  {missing}\nrworld printed:\n" + "\n".join(printed)
        )
        left_out = unshown(printed, shown)
        assert left_out is None, f"$ {command}\nthe document does not show:\n  {left_out}"
    # the calibrated plate against the made-up truth, within 3 of its predicted sigmas
    import yaml

    from rworld_cli import spatial
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.world.tree import World

    calibrated = World(load_cell(str(tmp_path / "cell")).cell).T_world("plate")
    true = World(load_cell(str(tmp_path / "truth")).cell).T_world("plate")
    provenance = yaml.safe_load((tmp_path / "cell" / "calibrated.yaml").read_text())
    sigma = provenance["provenance"]["frames"]["plate"]
    error_mm = np.linalg.norm(calibrated[:3, 3] - true[:3, 3]) * 1000
    turned = spatial.rotation_vector(true[:3, :3].T @ calibrated[:3, :3])
    error_arcsec = np.degrees(np.linalg.norm(turned)) * 3600
    print(f"plate: {error_mm:.4f} mm, {error_arcsec:.1f} arcsec from the truth; sigma {sigma}")
    assert error_mm < 3 * sigma["sigma_mm"]
    assert error_arcsec < 3 * sigma["sigma_arcsec"]


def write(folder: Path) -> None:
    """Rewrite the document's outputs with what rworld prints now (long outputs cut)."""
    setup_folder(folder)
    text = DOC.read_text()
    lines = text.splitlines()
    replaced = []
    for command, shown, span in commands(text):
        printed = [s.rstrip() for s in run(command, folder).rstrip("\n").splitlines()]
        keep = [s for s in shown if s.strip() not in ("", "...")]
        if (
            shown == ["OUTPUT"]
            or shown_in(printed, keep) is not None
            or unshown(printed, shown) is not None
        ):
            replaced.append((span, printed))
    for (start, end), printed in reversed(replaced):
        lines[start:end] = printed
    DOC.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        raise SystemExit(__doc__)
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        write(Path(folder))


def test_the_comparison_tells_a_changed_figure_from_rounding():
    shown = ["wrote m.yaml: 3 feature(s), 9 point(s)", "...", " plate  C1  1.0112 mm  0.0038 mm"]
    assert shown_in(["x", "wrote m.yaml: 3 feature(s), 9 point(s)", "y",
                     " plate  C1  1.0114 mm  0.0039 mm"], shown) is None  # fmt: skip
    assert shown_in(["wrote m.yaml: 3 feature(s), 9 point(s)",
                     " plate  C1  1.0112 mm  0.0138 mm"], shown) == shown[2]  # fmt: skip
    assert shown_in([" plate  C1  1.0112 mm  0.0038 mm",
                     "wrote m.yaml: 3 feature(s), 9 point(s)"], shown) == shown[2]  # fmt: skip
    assert not same("wrote m.yaml: 3 feature(s), 8 point(s)", shown[0])
    assert "OUTPUT" not in DOC.read_text()
