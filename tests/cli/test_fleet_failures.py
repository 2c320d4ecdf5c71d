"""Fleets on clusters that fail (issue 45), with real ``dask scheduler`` / ``dask worker``
processes: a scheduler with no worker is refused at once, a worker killed mid-run and not
restarted ends in exit 2 naming the runs not done within the documented wait, malformed
addresses are exit 2 naming the option, and a worker that cannot see a cell says so."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import REPO, WORKCELLS

DASK = Path(sys.executable).with_name("dask")
RWORLD = [sys.executable, "-c", "from rworld_cli.cli import main; main()"]


def _scheduler(tmp_path: Path) -> tuple[subprocess.Popen, str]:
    address_file = tmp_path / "scheduler.json"
    process = subprocess.Popen(
        [str(DASK), "scheduler", "--scheduler-file", str(address_file), "--port", "0"]
        + ["--dashboard-address", ":0"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    for _ in range(300):
        if address_file.exists() and address_file.read_text().strip():
            return process, json.loads(address_file.read_text())["address"]
        time.sleep(0.1)
    process.kill()
    pytest.fail("the scheduler did not start")


def _worker(address: str, tmp_path: Path, hidden: Path | None = None) -> subprocess.Popen:
    """A worker process; ``hidden``: a folder the worker cannot see (an empty file system
    mounted over it in the worker's own mount namespace - as on another machine)."""
    local = tmp_path / "worker-space"
    local.mkdir(exist_ok=True)
    prefix = []
    if hidden is not None:
        prefix = ["unshare", "--mount", "--propagation", "private", "--", "sh", "-c"]
        prefix += ['mount -t tmpfs none "$0" && exec "$@"', str(hidden)]
    return subprocess.Popen(
        prefix
        + [str(DASK), "worker", address, "--nworkers", "1", "--nthreads", "1"]
        + ["--dashboard-address", ":0", "--local-directory", str(local)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        cwd=str(local),
        start_new_session=True,
    )


def _wait_for_workers(address: str, count: int) -> None:
    from distributed import Client

    with Client(address, timeout="30s") as client:
        client.wait_for_workers(count, timeout=60)


def _stop(*processes) -> None:
    for process in processes:
        if process is not None and process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL) if process.pid else None
            process.wait(timeout=30)


def _check(args, timeout=120, **env) -> tuple[subprocess.CompletedProcess, float]:
    started = time.monotonic()
    done = subprocess.run(
        RWORLD + ["check", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=os.environ | env,
    )
    return done, time.monotonic() - started


def test_a_scheduler_without_workers_is_refused_at_once(tmp_path):
    scheduler, address = _scheduler(tmp_path)
    try:
        done, seconds = _check(["workcells/puma560", "pick_place", "--scheduler", address])
        assert done.returncode == 2, done.stderr
        assert f"{address}: 0 workers: start some" in done.stderr
        assert seconds < 30
    finally:
        scheduler.kill()
        scheduler.wait()


def test_a_worker_killed_mid_run_ends_in_exit_2_naming_the_runs_not_done(tmp_path):
    scheduler, address = _scheduler(tmp_path)
    worker = _worker(address, tmp_path)
    try:
        _wait_for_workers(address, 1)
        cells = [str(WORKCELLS / name) for name in ("puma560", "paper_fig9", "probing", "ur5")]
        process = subprocess.Popen(
            RWORLD + ["check", *cells, "--all-runs", "--scheduler", address],
            cwd=REPO,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=os.environ | {"RWORLD_WORKER_WAIT": "5"},
        )
        time.sleep(3)
        os.killpg(worker.pid, signal.SIGKILL)  # the worker dies and is not restarted
        worker.wait(timeout=30)
        started = time.monotonic()
        out, err = process.communicate(timeout=120)
        assert process.returncode == 2, err
        assert time.monotonic() - started < 60
        assert f"{address}: no worker for 5 s" in err and "not done (" in err, err
        assert "0 workers" in err and "giving up in" in err  # the progress line
    finally:
        _stop(worker)
        scheduler.kill()
        scheduler.wait()


@pytest.mark.parametrize("address", ["foo://bar", "tcp://", "127.0.0.1:8786x", "tcp://h:99999"])
def test_malformed_scheduler_addresses_are_exit_2_naming_the_option(cli, address):
    result = cli(["check", str(WORKCELLS / "puma560"), "pick_place", "--scheduler", address])
    assert result.exit_code == 2, result.output
    assert f"--scheduler '{address}' is not a Dask scheduler address" in result.output


def test_a_worker_that_cannot_see_a_cell_says_so(tmp_path):
    """The cell in a folder the worker's machine does not have (hidden in the worker's own
    mount namespace); the run names it, relative to the client's folder as it was given."""
    probe = subprocess.run(
        ["unshare", "--mount", "--propagation", "private", "--", "mount", "-t", "tmpfs"]
        + ["none", str(tmp_path)],
        capture_output=True,
    )
    if probe.returncode != 0:
        pytest.skip(f"no mount namespaces here: {probe.stderr.decode().strip()}")
    private = tmp_path / "private"
    cell = private / "puma560"
    shutil.copytree(WORKCELLS / "puma560", cell)
    scheduler, address = _scheduler(tmp_path)
    worker = _worker(address, tmp_path, hidden=private)
    try:
        _wait_for_workers(address, 1)
        relative = os.path.relpath(cell, REPO)  # resolved by the client before shipping
        done, _ = _check([relative, "pick_place", "--scheduler", address, "--json"])
        assert done.returncode == 2, done.stderr
        [run] = json.loads(done.stdout)["results"]
        assert run["cell"] == relative
        assert f"the worker at {address}" in run["error"]
        assert f"cannot see {cell}: workers must see the cells at the same paths" in run["error"]
    finally:
        _stop(worker)
        scheduler.kill()
        scheduler.wait()
