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


@pytest.mark.parametrize("cell", ["tx2_60", "iiwa14", "gp7"])
def test_the_vendor_tours_report_what_exact_distances_everywhere_report(cell, monkeypatch):
    """The vendor robots' meshes near the table and the holed plate, with a 5 mm clearance:
    distances asked only as far as each sample needs them (``sweep._within``) give the report
    of every pair measured exactly at every sample, to the clearance columns."""
    from tests.conftest import REPO

    where = REPO / "tests" / "data" / "vendor_cells" / cell
    fast, fast_clear, fast_queries = _report(where, "tour", monkeypatch, True, clearance="5mm")
    full, full_clear, full_queries = _report(where, "tour", monkeypatch, False, clearance="5mm")
    assert any(np.isfinite(v).any() for v in fast_clear.values()), "nothing within 50 mm"
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


def test_a_mesh_pair_culled_in_the_meshs_frame_is_the_exhaustive_minimum():
    """pair_distance between a triangle mesh (the probing plate, 2900 triangles, holes through
    it) and boxes, cylinders and spheres at random poses: the culled search finds the same
    distance as GJK over every triangle; and the plate is not taken as its hull."""
    import numpy as np

    from rworld_cli import spatial
    from rworld_cli.collision import bodies as B
    from rworld_cli.collision import convex
    from rworld_cli.schema.loader import load_cell
    from tests.conftest import WORKCELLS

    cell = load_cell(str(WORKCELLS / "probing")).cell
    model = B.collision_model(cell)
    by_frame = {b.frame: b for b in model.bodies}
    plate = by_frame["plate"]
    assert plate.is_mesh and B.convex_parts(cell.objects["plate"].shape) is None
    others = [by_frame["puma.link6"], by_frame["puma.link2"], by_frame["table"], by_frame["peg"]]
    rng = np.random.default_rng(7)
    K = 40
    T_plate = np.repeat(spatial.make_transform(np.eye(3), [0.45, 0.1, 0.4])[None], K, 0)
    tri = plate._triangles
    # random poses around the plate, then poses hovering just over its top face (level or
    # slightly tilted, over the holes and away from them): there the triangles of the face
    # all tie with the face's plane, and only the one measured may stand for them
    hover = [
        spatial.make_transform(
            spatial.rpy_to_matrix([0.0, 0.0, 0.0] if k % 2 else rng.uniform(-0.05, 0.05, 3)),
            [0.45 + x, 0.1 + y, 0.4 + 0.015 + h],
        )
        for k, (x, y, h) in enumerate(
            zip(
                np.r_[0.04, 0.12, rng.uniform(0.0, 0.16, K // 2 - 2)],
                np.r_[0.06, 0.06, rng.uniform(0.0, 0.12, K // 2 - 2)],
                rng.uniform(0.03, 0.08, K // 2),
            )
        )
    ]
    for other in others:
        T = np.array(
            [
                spatial.make_transform(
                    spatial.rpy_to_matrix(rng.uniform(-np.pi, np.pi, 3)),
                    [0.45, 0.1, 0.4] + rng.uniform([-0.05, -0.05, -0.05], [0.25, 0.2, 0.15]),
                )
                for _ in range(K - len(hover))
            ]
            + hover
        )
        culled = B.pair_distance(plate, other, T_plate, T)
        world = np.einsum("kij,tvj->ktvi", T_plate[:, :3, :3], tri) + T_plate[:, None, None, :3, 3]
        pieces = other.pieces(T)
        every = convex.distance(
            convex.triangles(world.reshape(-1, 3, 3)),
            pieces.take(np.repeat(np.arange(K), len(tri))),
        ).distance.reshape(K, len(tri))
        exhaustive = every.min(axis=1)
        free = ~culled.buried
        assert free.sum() > K // 2
        # a cylinder (the PUMA's link 6) is measured in the plate's frame by the compiled walk,
        # its curved support converging linearly in GJK: equal to 1e-11 m, not to rounding
        atol = 1e-11 if other.shape.kind == "cylinder" else 1e-12
        assert np.allclose(culled.distance[free], exhaustive[free], rtol=0, atol=atol)
