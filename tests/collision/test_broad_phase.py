"""The broad phase (swept bounding boxes per chunk of samples, sweep and prune) changes which
pairs reach the exact distance query, never what is found: on every example run and on lines
of robots close enough to hit each other, the report equals the one of every pair at every
sample in one chunk - the same contacts, depths, spans, points, clearances and nearest pairs."""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

from rworld_cli.api import simulate_run
from rworld_cli.collision import sweep
from tests.conftest import WORKCELLS

RUNS = sorted(
    (cell.name, run.stem)
    for cell in WORKCELLS.iterdir()
    if (cell / "runs").is_dir()
    for run in (cell / "runs").glob("*.yaml")
)


def _scale():
    spec = importlib.util.spec_from_file_location("scale", WORKCELLS.parent / "bench" / "scale.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _report(cell, run, monkeypatch, broad: bool, **options) -> tuple[dict, dict]:
    monkeypatch.setattr(sweep, "BROAD_PHASE", broad)
    _, result = simulate_run(str(cell), run, **options)
    report = result.collisions
    out = report.as_dict()
    out.pop("queries"), out.pop("refinements")
    return out, {d: np.asarray(v) for d, v in report.clearance.items()}, report.queries


def _same(a, b, path="") -> None:
    """Equal structures; floats to 1e-12 (the same numbers computed in another grouping)."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for k in a:
            _same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list | tuple):
        assert len(a) == len(b), path
        for n, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{path}[{n}]")
    elif isinstance(a, float):
        assert math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12), (path, a, b)
    else:
        assert a == b, (path, a, b)


@pytest.mark.parametrize("cell, run", RUNS)
def test_the_broad_phase_finds_what_every_pair_finds_on_every_example(cell, run, monkeypatch):
    options = {"clearance": "5mm"} if cell != "paper_fig9" else {}
    fast, fast_clear, _ = _report(WORKCELLS / cell, run, monkeypatch, True, **options)
    full, full_clear, _ = _report(WORKCELLS / cell, run, monkeypatch, False, **options)
    _same(fast, full)
    assert fast_clear.keys() == full_clear.keys()
    for d in fast_clear:
        np.testing.assert_array_equal(fast_clear[d], full_clear[d])


@pytest.mark.parametrize("spacing", [0.9, 1.3])
def test_robots_that_hit_each_other_are_found_alike(tmp_path, monkeypatch, spacing):
    """Six Pumas on a grid close enough for their arms to meet (0.9 m) or nearly (1.3 m, with
    a 50 mm clearance): runs of hundreds of samples, so that chunk boundaries fall inside
    contacts."""
    cell = _scale().line_cell(tmp_path / "line", 6, seed=3, spacing=spacing)
    options = {"clearance": "50mm"} if spacing > 1 else {}
    fast, fast_clear, fast_queries = _report(cell, "line", monkeypatch, True, **options)
    full, full_clear, full_queries = _report(cell, "line", monkeypatch, False, **options)
    found = fast["collisions"] + fast["clearance_violations"]
    print(f"spacing {spacing} m: {len(found)} contacts; queries {fast_queries} / {full_queries}")
    assert found, "the arms must meet for this test to mean anything"
    _same(fast, full)
    for d in fast_clear:
        np.testing.assert_array_equal(fast_clear[d], full_clear[d])
