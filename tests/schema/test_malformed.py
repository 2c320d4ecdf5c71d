"""Golden files: each malformed cell gives exactly the expected lines and exit code.

Each case is a directory under testdata/malformed with cell.yaml (and
poses.yaml); expected.txt holds the exit code on its first line and then
the exact stderr of ``rworld validate CASE/cell.yaml`` run from the corpus
directory.  After a deliberate change of wording, regenerate with
``RWORLD_UPDATE_GOLDEN=1 pytest tests/schema/test_malformed.py`` and review
the diff line by line.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from tests.conftest import run_cli

CORPUS = Path(__file__).parent / "testdata" / "malformed"
CASES = sorted(p.name for p in CORPUS.iterdir() if p.is_dir())
LINE = re.compile(r"^[^:\s]+(:\d+:\d+)?: (warning: )?\S+: .+$")


def test_corpus_is_large_enough():
    assert len(CASES) >= 30


@pytest.mark.parametrize("case", CASES)
def test_malformed_case(case):
    result = run_cli(["validate", f"{case}/cell.yaml"], cwd=CORPUS)
    got = f"exit: {result.exit_code}\n{result.stderr}"
    expected_file = CORPUS / case / "expected.txt"
    if os.environ.get("RWORLD_UPDATE_GOLDEN"):
        expected_file.write_text(got)
    assert got == expected_file.read_text()
    assert "Traceback" not in result.output
    issue_lines = [l for l in result.stderr.splitlines() if not l.startswith("invalid: ")]
    assert issue_lines, "every case reports at least one located line"
    for line in issue_lines:
        assert LINE.match(line), line
    if result.exit_code == 2:
        assert any(": warning: " not in l for l in issue_lines)
    else:
        assert result.exit_code == 0 and all(": warning: " in l for l in issue_lines)
