"""Measurement planning and the report's accuracy / sensitivity analysis."""

from __future__ import annotations

import json
import shutil

import numpy as np

from rworld_cli.calibration.analysis import constrained, run_analysis, unconstrained
from rworld_cli.calibration.pipeline import calibrate
from rworld_cli.schema.loader import load_cell
from rworld_cli.schema.measurements import load_measurements
from tests.conftest import WORKCELLS


def test_plan_lists_every_conditioned_frame_with_orientation_order(cli):
    data = json.loads(cli(["plan-measurements", "workcells/calibration_example", "--json"]).stdout)
    frames = {f["frame"]: f for f in data["frames"]}
    assert set(frames) == {"block", "block.frame2", "block.frame3", "block.frame5"}
    block = frames["block"]
    assert [d["feature"] for d in block["directives"]] == [
        "block.f1",
        "block.f2",
        "block.f3",
        "block.f4",
        "block.f5",
    ]
    line = next(d for d in block["directives"] if d["kind"] == "line")
    assert line["ordered"] and "first -> last" in line["how"]
    plane = next(d for d in block["directives"] if d["kind"] == "plane")
    assert plane["above_mm"] is not None
    assert (
        2 * block["predicted_sigma_mm"] / np.sqrt(3) <= 0.1 + 1e-9
    )  # within the tolerance at 2 sigma (per axis)


def test_tighter_tolerance_asks_for_more_points(cli):
    def points(tol):
        data = json.loads(
            cli(
                ["plan-measurements", "workcells/calibration_example", "--tolerance", tol, "--json"]
            ).stdout
        )
        return len(data["frames"][0]["directives"][0]["points_mm"])

    assert points("0.02mm") > points("0.2mm")


def test_planned_points_lie_on_their_features():
    from rworld_cli.calibration.plan import plan_measurements
    from rworld_cli.collision.bodies import point_triangle_distance
    from rworld_cli.geometry import shape_mesh
    from rworld_cli.world.tree import World

    cell = load_cell(WORKCELLS / "calibration_example").cell
    world = World(cell)
    tri = shape_mesh(cell.objects["block"].shape).triangles()
    for plan in plan_measurements(cell):
        for d in plan.directives:
            f = cell.features[d.feature]
            T = np.linalg.inv(world.T_world(f.owner))
            local = d.contacts @ T[:3, :3].T + T[:3, 3]
            # on material: on the block's surface (its mesh), not in the air of the hole
            on_surface = point_triangle_distance(local[:, None], tri[None]).min(axis=1)
            np.testing.assert_allclose(on_surface, 0, atol=1e-9)
            if f.kind == "plane":
                np.testing.assert_allclose((local - f.point) @ f.direction, 0, atol=1e-12)
                hole = np.linalg.norm(local[:, :2] - [0.1, 0.075], axis=1)
                assert f.name != "block.f1" or (hole >= 0.02 + 1e-3 - 1e-12).all()  # margin
            elif f.kind == "circle":  # the hole's wall, 15 mm below the rim (half its depth)
                v = local - f.point
                np.testing.assert_allclose(v @ f.direction, -0.015, atol=1e-12)
                radial = np.linalg.norm(v - np.outer(v @ f.direction, f.direction), axis=1)
                assert np.all(np.abs(radial - f.radius) < 1e-6)  # the 360-gon's wall


def test_plan_refuses_an_undeterminable_frame(cli, tmp_path):
    cell_dir = tmp_path / "cell"
    shutil.copytree(WORKCELLS / "calibration_example", cell_dir)
    text = (
        (cell_dir / "cell.yaml")
        .read_text()
        .replace("features: [f1, f2, f3, f4, f5]", "features: [f2, f4]")
    )
    (cell_dir / "cell.yaml").write_text(text)
    result = cli(["plan-measurements", str(cell_dir)])
    assert result.exit_code == 1 and "cannot be determined" in result.stdout


def test_the_example_measurement_file_calibrates():
    cell = load_cell(WORKCELLS / "calibration_example").cell
    m = load_measurements(
        [str(WORKCELLS.parent / "measurements" / "calibration_example" / "block_2026-11-21.yaml")],
        cell,
    )
    result = calibrate(cell, m)
    sol = result.solutions["block"]
    truth = np.array([-98.7, -76.2, 0.4]) / 1000
    assert np.linalg.norm(sol.T_world[:3, 3] - (truth + [0.5, 0, 0.7])) < 5 * np.linalg.norm(
        sol.sigma_translation
    )  # the table is at (500, 0, 700) mm


def test_analysis_reproduces_the_reports_comparison():
    acc, _ = run_analysis("accuracy", trials=200, seed=3)
    assert all(r.max_element_error < 1e-12 for r in acc)  # exact data: both exact
    sens, _ = run_analysis("sensitivity", trials=200, seed=3)
    c, u = sens
    assert (
        c.max_orthogonality < 1e-12 < u.median_orthogonality
    )  # only the constrained R stays a rotation
    assert c.median_element_error < u.median_element_error


def test_methods_agree_on_exact_planes():
    rng = np.random.default_rng(0)
    from rworld_cli import spatial

    T = spatial.make_transform(spatial.rpy_to_matrix([0.3, -0.4, 1.2]), [0.2, -0.1, 0.5])
    A = np.column_stack([rng.normal(size=(5, 3)), rng.uniform(-1, 1, 5)])
    A[:, :3] /= np.linalg.norm(A[:, :3], axis=1, keepdims=True)
    Q = A @ np.linalg.inv(T)
    np.testing.assert_allclose(constrained(A, Q), T, atol=1e-12)
    np.testing.assert_allclose(unconstrained(A, Q), T, atol=1e-12)


def test_analyze_command(cli, tmp_path):
    data = json.loads(
        cli(
            [
                "analyze",
                "sensitivity",
                "--trials",
                "50",
                "--json",
                "--plot",
                str(tmp_path / "s.png"),
            ]
        ).stdout
    )
    assert [m["method"] for m in data["methods"]] == ["constrained", "unconstrained"]
    assert (tmp_path / "s.png").read_bytes()[:4] == b"\x89PNG"


def test_analysis_blocks_give_the_same_figures_on_every_executor():
    """Blocks with their own seeds: one process, a pool and a Dask cluster agree exactly, and
    the in-process run_analysis is the same computation."""
    from distributed import LocalCluster

    from rworld_cli.api import analyze_calibration

    inline, where = analyze_calibration("sensitivity", 1200, 5, 7, workers=1)
    assert where == "1 process"
    pooled, where = analyze_calibration("sensitivity", 1200, 5, 7, workers=2)
    assert where == "2 local processes"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True) as cluster:
        clustered, where = analyze_calibration(
            "sensitivity", 1200, 5, 7, scheduler=cluster.scheduler_address
        )
    assert where.startswith("dask ")
    assert inline == pooled == clustered == run_analysis("sensitivity", 1200, 5, 7)[0]
    # 1200 trials are blocks of 500, 500, 200: a different seed draws other trials
    assert run_analysis("sensitivity", 1200, 5, 8)[0] != inline


def test_analysis_progress_counts_blocks():
    from rworld_cli.api import analyze_calibration

    seen = []
    analyze_calibration("accuracy", 1001, 5, 0, workers=1, progress=lambda *a: seen.append(a))
    assert seen == [(1, 3, "trial blocks"), (2, 3, "trial blocks"), (3, 3, "trial blocks")]
