"""Fleets of cells: ``rworld check CELL... --all-runs`` on local processes, on a Dask
LocalCluster and on real ``dask scheduler`` / ``dask worker`` processes - the same results in
the same order - with the reports CI systems read (JSON, JUnit XML read back by junitparser,
GitHub annotations)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rworld_cli.api import check_fleet
from tests.conftest import WORKCELLS

CELLS = sorted(str(p) for p in WORKCELLS.iterdir() if (p / "cell.yaml").is_file())


def _plain(fleet) -> list[dict]:
    """What must be identical on every executor: everything but the wall times."""
    out = []
    for r in fleet.results:
        d = r.as_dict()
        d.pop("seconds")
        out.append(d)
    return out


@pytest.fixture(scope="module")
def fleet_cells(tmp_path_factory):
    """The example cells, plus a folder that is no cell and a cell whose program names an
    unknown frame (bad input, exit 2), beside the cell whose run collides (exit 1)."""
    root = tmp_path_factory.mktemp("fleet")
    broken = root / "broken"
    shutil.copytree(WORKCELLS / "puma560", broken)
    program = broken / "programs" / "pick_place.yaml"
    program.write_text(program.read_text().replace("to: ready", "to: readdy"))
    (root / "empty").mkdir()
    return CELLS + [str(broken), str(root / "empty")]


@pytest.fixture(scope="module")
def local(fleet_cells):
    return check_fleet(fleet_cells, workers=2)


def test_every_run_of_every_cell_is_checked_in_order(local, fleet_cells):
    listed = [(Path(r.cell).name, r.run) for r in local.results]
    expected = []
    for cell in fleet_cells:
        runs = sorted(p.stem for p in (Path(cell) / "runs").glob("*.yaml"))
        expected += [(Path(cell).name, r) for r in runs] or [(Path(cell).name, "")]
    assert listed == expected
    status = {(Path(r.cell).name, r.run): r.status for r in local.results}
    assert status[("puma560", "through_table")] == "failed"
    assert status[("broken", "pick_place")] == "error"
    assert status[("empty", "")] == "error"
    assert status[("ur5", "")] == "skipped"  # a cell with no runs
    assert status[("broken", "probe")] == "ok"  # the broken program spoils its own run only
    # through_table collides in puma560 and in its copy
    assert local.failed == 2 and local.bad_input == 2 and local.exit_code == 2
    bad = next(r for r in local.results if r.status == "error" and r.run)
    assert bad.problems[0].file.endswith("pick_place.yaml") and bad.problems[0].line > 0
    assert "readdy" in bad.error
    collided = next(r for r in local.results if r.status == "failed")
    assert collided.counts["collisions"] == 8
    assert all(p.file.endswith("through_table.yaml") for p in collided.problems)
    assert {p.line for p in collided.problems} == {11, 12}


def test_a_fleet_run_is_what_a_single_check_says(local, cli):
    """Each cell's first ok and first failed verdict and their collision counts equal
    'rworld check CELL RUN --json' (every run until 2026-11-30: 12.7 s of the suite)."""
    seen = set()
    for r in local.results:
        if r.status not in ("ok", "failed") or "paper_fig9" in r.cell:
            continue
        if (r.cell, r.status) in seen:
            continue
        seen.add((r.cell, r.status))
        one = cli(["check", r.cell, r.run, "--json"])
        assert one.exit_code == (0 if r.ok else 1), one.output
        summary = json.loads(one.output)
        assert summary["ok"] == r.ok
        assert len(summary["collisions"]["collisions"]) == r.counts["collisions"]


def test_one_process_and_a_dask_local_cluster_give_identical_results(local, fleet_cells):
    from distributed import LocalCluster

    cells = [c for c in fleet_cells if "probing" not in c]  # the long probe run: time
    expected = [r for r in _plain(local) if "probing" not in r["cell"]]
    inline = check_fleet(cells, workers=1)
    assert _plain(inline) == expected
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True) as cluster:
        on_dask = check_fleet(cells, scheduler=cluster.scheduler_address)
    assert on_dask.executor.startswith("dask tcp://")
    assert _plain(on_dask) == expected


def test_a_fleet_on_real_dask_scheduler_and_worker_processes(tmp_path, local, fleet_cells):
    """`dask scheduler` and `dask worker` started as a cluster operator would, and the CLI
    pointed at them with --scheduler."""
    dask = Path(sys.executable).with_name("dask")
    rworld = Path(sys.executable).with_name("rworld")
    address_file = tmp_path / "scheduler.json"
    scheduler = subprocess.Popen(
        [str(dask), "scheduler", "--scheduler-file", str(address_file), "--port", "0"]
        + ["--dashboard-address", ":0"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    worker = None
    try:
        for _ in range(300):
            if address_file.exists() and address_file.read_text().strip():
                break
            time.sleep(0.1)
        address = json.loads(address_file.read_text())["address"]
        worker = subprocess.Popen(
            [str(dask), "worker", address, "--nworkers", "2", "--nthreads", "1"]
            + ["--dashboard-address", ":0"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        from distributed import Client

        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        cells = [c for c in fleet_cells if "probing" not in c]  # the long probe run: time
        done = subprocess.run(
            [str(rworld), "check", *cells, "--all-runs", "--scheduler", address, "--json"],
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert done.returncode == 2, done.stderr
        report = json.loads(done.stdout)
        assert report["executor"].startswith(f"dask {address}")
        expected = [r for r in _plain(local) if "probing" not in r["cell"]]
        got = [{k: v for k, v in r.items() if k != "seconds"} for r in report["results"]]
        assert got == json.loads(json.dumps(expected))
        assert report["failed"] == 2 and report["bad_input"] == 2
    finally:
        for process in (worker, scheduler):
            if process is not None:
                process.terminate()
                process.wait(timeout=30)


def test_junit_and_github_reports(tmp_path, fleet_cells, cli):
    from junitparser import Error, Failure, JUnitXml, Skipped

    cells = [c for c in fleet_cells if "probing" not in c]
    junit = tmp_path / "report.xml"
    result = cli(["check", *cells, "--all-runs", "--junit", str(junit), "--workers", "1"])
    assert result.exit_code == 2, result.output
    assert "FAILED" in result.output and "through_table.yaml:11: collision" in result.output
    xml = JUnitXml.fromfile(str(junit))
    cases = {
        (suite.name.rstrip("/").rsplit("/", 1)[-1], case.name): case
        for suite in xml
        for case in suite
    }
    assert xml.tests == len(cases)
    failure = cases[("puma560", "through_table")].result
    assert len(failure) == 1 and isinstance(failure[0], Failure)
    assert "through_table.yaml:11: collision: table with puma.link6" in failure[0].text
    assert isinstance(cases[("broken", "pick_place")].result[0], Error)
    assert isinstance(cases[("ur5", "(cell)")].result[0], Skipped)
    assert cases[("puma560", "pick_place")].result == []
    # the annotations from the two cells with a failed and a refused run (all cells until
    # 2026-11-30: the fleet checked twice)
    two = [c for c in cells if Path(c).name in ("puma560", "broken")]
    github = cli(["check", *two, "--all-runs", "--format", "github", "--workers", "1"])
    lines = github.output.splitlines()
    errors = [line for line in lines if line.startswith("::error ")]
    assert any(
        line.startswith("::error file=") and "through_table.yaml,line=11," in line
        for line in errors
    )
    assert any("pick_place.yaml,line=" in line and "readdy" in line for line in errors)
    assert github.exit_code == 2
    # one good run: a notice, exit 0, and the JUnit file even for one CELL RUN
    one = cli(
        ["check", str(WORKCELLS / "puma560"), "pick_place", "--junit", str(tmp_path / "one.xml")]
    )
    assert one.exit_code == 0, one.output
    assert JUnitXml.fromfile(str(tmp_path / "one.xml")).tests == 1


@pytest.mark.parametrize(
    "args, message",
    [
        (["--all-runs"], "name at least one"),
        ([str(WORKCELLS / "puma560")], "give CELL RUN"),
        ([str(WORKCELLS / "puma560"), "pick_place", "--all-runs", "--dt", "0.01"], "--dt"),
    ],
)
def test_fleet_usage_errors_exit_2(cli, args, message):
    result = cli(["check", *args])
    assert result.exit_code == 2 and message in result.output, result.output


def test_a_cell_given_as_its_cell_yaml_is_the_same_cell(cli):
    folder = check_fleet([str(WORKCELLS / "puma560")], workers=1)
    file = check_fleet([str(WORKCELLS / "puma560" / "cell.yaml")], workers=1)
    assert [(r.run, r.status) for r in file.results] == [(r.run, r.status) for r in folder.results]


def test_a_scheduler_nobody_runs_is_a_clear_error(cli):
    result = cli(
        ["check", str(WORKCELLS / "puma560"), "--all-runs", "--scheduler", "tcp://127.0.0.1:9"]
    )
    assert result.exit_code == 2 and "no Dask scheduler answers at tcp://127.0.0.1:9" in (
        result.output
    )
    assert "connection refused" in result.output  # said at once, not after Dask's 10 s wait
    unknown = cli(
        ["check", str(WORKCELLS / "puma560"), "--all-runs", "--scheduler", "tcp://nohost.invalid:1"]
    )
    assert unknown.exit_code == 2 and "unknown host 'nohost.invalid'" in unknown.output
