"""The copied reference data is the one its provenance names (tests/data/reference)."""

from __future__ import annotations

import hashlib
import re

from tests.conftest import REFERENCE


def test_reference_files_match_their_recorded_hashes():
    table = (REFERENCE / "PROVENANCE.md").read_text()
    recorded = dict(re.findall(r"\| `([a-z0-9_/]+\.json)` \|.*\| `([0-9a-f]{64})` \|", table))
    assert len(recorded) == 4
    for name, digest in recorded.items():
        assert hashlib.sha256((REFERENCE / name).read_bytes()).hexdigest() == digest, name
