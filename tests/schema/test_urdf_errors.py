"""Golden files: each broken URDF gives exactly the expected lines, exit 2, and writes nothing.

Each case is a folder under testdata/urdf with robot.urdf; expected.txt holds the exit code and
the exact stderr of ``rworld import urdf CASE/robot.urdf -o OUT`` run from the corpus folder.
Regenerate after a deliberate change of wording with
``RWORLD_UPDATE_GOLDEN=1 pytest tests/schema/test_urdf_errors.py`` and review the diff.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.conftest import run_cli

CORPUS = Path(__file__).parent / "testdata" / "urdf"
CASES = sorted(p.name for p in CORPUS.iterdir() if p.is_dir())


def test_every_required_case_is_there():
    required = {
        "malformed_xml",
        "missing_link",
        "two_roots",
        "missing_mesh",
        "unsupported_joint_type",
        "negative_mass",
        "inertia_not_psd",
        "mimic_on_chain",
        "floating_joint",
        "planar_joint",
        "closed_loop",
        "xacro_macros",
    }
    assert required <= set(CASES)


@pytest.mark.parametrize("case", CASES)
def test_broken_urdf(case, tmp_path):
    out = tmp_path / "cell"
    result = run_cli(["import", "urdf", f"{case}/robot.urdf", "-o", str(out)], cwd=CORPUS)
    got = f"exit: {result.exit_code}\n{result.stderr}"
    expected_file = CORPUS / case / "expected.txt"
    if os.environ.get("RWORLD_UPDATE_GOLDEN"):
        expected_file.write_text(got)
    assert got == expected_file.read_text()
    assert result.exit_code == 2
    assert f"{case}/robot.urdf:" in result.stderr  # located: file, line and column
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []  # no staging folder left behind either
