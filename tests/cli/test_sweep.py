"""``rworld sweep``: a run checked over a grid of payload mass x speed override x pose files, on
local processes or a Dask cluster - the same table in the same order - with its CSV and plot."""

from __future__ import annotations

import csv
import json
import math
import shutil

import pytest

from rworld_cli.api import simulate_run, sweep_run
from tests.conftest import WORKCELLS

PUMA = WORKCELLS / "puma560"


def _plain(result) -> list[dict]:
    out = []
    for p in result.points:
        d = p.as_dict()
        d.pop("seconds")
        out.append(d)
    return out


@pytest.fixture(scope="module")
def grid():
    return sweep_run(
        str(PUMA), "pick_place", "workpiece", [0.5, 2.0, 8.0], [0.25, 0.5, 1.0], workers=2
    )


def test_the_grid_in_order_with_the_physics_it_should_show(grid):
    points = grid.points
    assert [(p.mass, p.speed) for p in points] == [
        (m, s) for m in (0.5, 2.0, 8.0) for s in (0.25, 0.5, 1.0)
    ]
    # the override scales every move's time exactly: the same paths, slower
    for m in (0.5, 2.0, 8.0):
        t = {p.speed: p.cycle_time for p in points if p.mass == m}
        assert math.isclose(t[0.5], 2 * t[1.0], rel_tol=1e-6)
        assert math.isclose(t[0.25], 4 * t[1.0], rel_tol=1e-6)
    # the payload's mass changes the torques, not the timing; heavier is closer to the limits
    for s in (0.25, 0.5, 1.0):
        line = [p for p in points if p.speed == s]
        assert len({p.cycle_time for p in line}) == 1
        ratios = [p.peak_torque_ratio for p in line]
        assert ratios == sorted(ratios) and ratios[0] < ratios[-1]
    heavy = next(p for p in points if p.mass == 8.0 and p.speed == 1.0)
    assert not heavy.ok and heavy.limit_violations > 0 and heavy.peak_torque_ratio > 1
    slow = next(p for p in points if p.mass == 8.0 and p.speed == 0.5)
    assert slow.ok  # the same payload passes at half speed


def test_a_point_is_the_check_of_the_cell_so_changed(grid):
    _, plain = simulate_run(str(PUMA), "pick_place")
    same = next(p for p in grid.points if p.mass == 2.0 and p.speed == 1.0)
    assert math.isclose(same.cycle_time, plain.cycle_time, abs_tol=1e-9)  # reported to 1 ns
    assert same.ok == plain.ok


def test_a_pose_file_variant_equals_the_cell_with_it_listed(tmp_path):
    variant = tmp_path / "longer_probe.yaml"
    variant.write_text(
        "units: {length: mm, angle: deg}\nposes:\n  puma.probe: {xyz: [0, 0, 130]}\n"
    )
    result = sweep_run(str(PUMA), "pick_place", variants=[str(variant)], workers=1)
    base, changed = result.points
    assert base.variant is None and changed.variant == str(variant)
    cell = tmp_path / "cell"
    shutil.copytree(PUMA, cell)
    shutil.copy(variant, cell / "longer_probe.yaml")
    text = (cell / "cell.yaml").read_text()
    (cell / "cell.yaml").write_text(
        text.replace("pose_files: [poses.yaml]", "pose_files: [poses.yaml, longer_probe.yaml]")
    )
    _, direct = simulate_run(str(cell), "pick_place")
    assert math.isclose(changed.cycle_time, direct.cycle_time, abs_tol=1e-9)
    peak = max(max(r for r in direct.peak_ratios(d)["torque"]) for d in direct.devices)
    assert math.isclose(changed.peak_torque_ratio, peak, abs_tol=1e-9)
    assert abs(changed.peak_torque_ratio - base.peak_torque_ratio) > 1e-3  # a longer lever


def test_local_processes_and_a_dask_cluster_give_the_same_table(grid):
    from distributed import LocalCluster

    inline = sweep_run(
        str(PUMA), "pick_place", "workpiece", [0.5, 2.0, 8.0], [0.25, 0.5, 1.0], workers=1
    )
    assert _plain(inline) == _plain(grid)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True) as cluster:
        on_dask = sweep_run(
            str(PUMA),
            "pick_place",
            "workpiece",
            [0.5, 2.0, 8.0],
            [0.25, 0.5, 1.0],
            scheduler=cluster.scheduler_address,
        )
    assert _plain(on_dask) == _plain(grid)


def test_the_command_writes_the_table_and_the_plot(tmp_path, cli):
    table, picture = tmp_path / "sweep.csv", tmp_path / "sweep.png"
    result = cli(
        ["sweep", str(PUMA), "pick_place", "--mass", "workpiece=1,8", "--speed", "50,100"]
        + ["--workers", "1", "-o", str(table), "--plot", str(picture), "--json"]
    )
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert [(p["mass"], p["speed"]) for p in report["points"]] == [
        (1.0, 0.5),
        (1.0, 1.0),
        (8.0, 0.5),
        (8.0, 1.0),
    ]
    rows = list(csv.DictReader(table.open()))
    assert [r["ok"] for r in rows] == ["ok", "ok", "ok", "failed"]
    assert float(rows[3]["peak_torque_ratio"]) == report["points"][3]["peak_torque_ratio"]
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "args, message",
    [
        (["--mass", "workpiece"], "OBJECT=KG"),
        (["--mass", "workpiece=heavy"], "numbers separated by commas"),
        (["--speed", "150"], "at most 100 %"),
        (["--pose-files", "missing.yaml"], "missing.yaml: no such pose file"),
        (["--mass", "workpeice=1"], "did you mean 'workpiece'"),
    ],
)
def test_bad_sweeps_exit_2_with_the_reason(cli, tmp_path, args, message):
    table = tmp_path / "t.csv"
    result = cli(["sweep", str(PUMA), "pick_place", "--workers", "1", "-o", str(table), *args])
    assert result.exit_code == 2, result.output
    assert message in result.output


def _with_ballast(tmp_path, mass: float):
    """The Puma cell with a point mass of ``mass`` kg fixed at the probe TCP's origin."""
    cell = tmp_path / f"ballast_{mass!r}"
    shutil.copytree(PUMA, cell)
    text = (cell / "cell.yaml").read_text()
    text = text.replace(
        "\nsensors:\n", f"\n  - name: ballast\n    mass: {mass!r}\n    com: [0, 0, 0]\n\nsensors:\n"
    ).replace(
        "  - {parent: puma.probe, child: probe_tip, type: rigid, kind: fixture}\n",
        "  - {parent: puma.probe, child: probe_tip, type: rigid, kind: fixture}\n"
        "  - {parent: puma.probe, child: ballast, type: rigid, kind: fixture}\n",
    )
    (cell / "cell.yaml").write_text(text)
    poses = (cell / "poses.yaml").read_text()
    (cell / "poses.yaml").write_text(poses + "  ballast: {xyz: [0, 0, 0]}\n")
    return str(cell)


def test_the_payload_capacity_is_exact_a_ballast_of_it_reaches_the_limit(tmp_path, grid):
    """The payload column is 'plan payload' on the run's motion: that much more at the TCP puts
    the binding joint exactly on its torque limit; 0.1 % more fails the check there."""
    (point,) = sweep_run(str(PUMA), "pick_place", workers=1).points
    assert point.ok and point.payload is not None and point.payload > 0.5
    device, joint, _, t, _, side = point.payload_binding.split()
    assert (device, joint, side) == ("puma", "j1", "(lower)")
    _, at_capacity = simulate_run(_with_ballast(tmp_path, point.payload), "pick_place")
    assert at_capacity.ok
    j = int(joint[1:]) - 1
    assert math.isclose(at_capacity.peak_ratios("puma")["torque"][j], 1.0, abs_tol=1e-9)
    _, beyond = simulate_run(_with_ballast(tmp_path, point.payload * 1.001), "pick_place")
    (violation,) = beyond.violations
    assert (violation.kind, violation.joint) == ("torque", joint)
    assert math.isclose(violation.t_start, float(t), abs_tol=0.0051)
    # the grid: a heavier workpiece leaves less; a slower run leaves more
    for s in (0.25, 0.5, 1.0):
        line = [p.payload for p in grid.points if p.speed == s]
        assert line == sorted(line, reverse=True)
    heavy = next(p for p in grid.points if p.mass == 8.0 and p.speed == 1.0)
    assert heavy.payload < 0  # already overloaded: no room at all
