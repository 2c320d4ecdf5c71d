"""Fleets: ``rworld check CELL... --all-runs`` - every run of every cell, on local processes or a
Dask cluster, with reports CI systems read (JSON, JUnit XML, GitHub annotations).

One code path for both executors: a ``concurrent.futures`` executor - a
``ProcessPoolExecutor`` here, or ``distributed.Client.get_executor()`` on a cluster - runs
:func:`check_one` on each (cell, run); results come back in the order the runs were listed,
whatever order they finish in.  A run is checked as ``rworld check CELL RUN`` would check it;
its result is plain data (picklable, JSON-ready).
"""

from __future__ import annotations

import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import UserError


@dataclass
class Problem:
    """One reason a run failed, located where a reviewer would fix it."""

    kind: str  # collision | clearance | limit | handling | unreachable | input
    message: str
    file: str | None = None
    line: int | None = None

    def as_dict(self) -> dict:
        return {"kind": self.kind, "message": self.message, "file": self.file, "line": self.line}


@dataclass
class RunCheck:
    """The outcome of one run: ``ok``, failed (``problems``), or bad input (``error``)."""

    cell: str
    run: str
    ok: bool
    error: str | None = None
    cycle_time: float | None = None
    counts: dict = field(default_factory=dict)
    problems: list[Problem] = field(default_factory=list)
    seconds: float = 0.0
    skipped: bool = False  # a cell with no runs: nothing to check

    @property
    def status(self) -> str:
        if self.skipped:
            return "skipped"
        return "error" if self.error is not None else ("ok" if self.ok else "failed")

    def as_dict(self) -> dict:
        return {
            "cell": self.cell,
            "run": self.run,
            "ok": self.ok,
            "status": self.status,
            "error": self.error,
            "cycle_time": self.cycle_time,
            **self.counts,
            "problems": [p.as_dict() for p in self.problems],
            "seconds": self.seconds,
        }


@dataclass
class FleetCheck:
    """Every run's outcome, in the order the runs were listed."""

    results: list[RunCheck]
    executor: str

    @property
    def failed(self) -> int:
        return sum(r.status == "failed" for r in self.results)

    @property
    def bad_input(self) -> int:
        return sum(r.status == "error" for r in self.results)

    @property
    def exit_code(self) -> int:
        """2 when any input is bad, else 1 when any run failed, else 0."""
        return 2 if self.bad_input else (1 if self.failed else 0)

    def as_dict(self) -> dict:
        return {
            "results": [r.as_dict() for r in self.results],
            "failed": self.failed,
            "bad_input": self.bad_input,
            "executor": self.executor,
        }


def fleet_runs(cells: list[str], run: str | None = None) -> list[tuple[str, str]]:
    """(cell, run) pairs: ``run`` on each cell, or every ``runs/*.yaml`` of each cell (sorted).
    A folder that is no cell (reported bad), or a cell with no runs (skipped), is kept as
    (cell, "")."""
    out = []
    for cell in cells:
        if run is not None:
            out.append((cell, run))
            continue
        folder = _folder(cell)
        runs = sorted((folder / "runs").glob("*.yaml")) if (folder / "cell.yaml").is_file() else []
        out += [(cell, r.stem) for r in runs] or [(cell, "")]
    return out


def _folder(cell: str) -> Path:
    """The cell's folder, whether given as the folder or as its cell.yaml."""
    path = Path(cell)
    return path.parent if path.is_file() else path


_WHERE = re.compile(r"^(?P<file>[^:\n]+):(?P<line>\d+)(?::\d+)?: ")


def _located(message: str) -> tuple[str | None, int | None]:
    match = _WHERE.match(message)
    return (match["file"], int(match["line"])) if match else (None, None)


def _split(where: str | None) -> tuple[str | None, int | None]:
    if not where or ":" not in where:
        return where, None
    file, line = where.rsplit(":", 1)
    return (file, int(line)) if line.isdigit() else (where, None)


def check_one(cell: str, run: str, options: dict, where: str | None = None) -> RunCheck:
    """Check one run as ``rworld check CELL RUN`` does; bad input becomes ``error`` (with the
    file and line when the message has them), never an exception.

    ``where``: the cell's absolute path as the client saw it, checked on a cluster's worker
    (``options["scheduler"]`` names the cluster) - a worker that cannot see it says so."""

    started = time.perf_counter()
    remote = options.get("scheduler")
    if remote and where is not None and not os.path.exists(where):
        import socket

        why = (
            f"the worker at {remote} (host {socket.gethostname()}) cannot see {where}: "
            "workers must see the cells at the same paths as the client"
        )
        return RunCheck(cell, run, False, why, problems=[Problem("input", why, cell)])
    options = {k: v for k, v in options.items() if k != "scheduler"}
    if where is not None:
        cell_shown, cell = cell, where
    else:
        cell_shown = cell
    result_check = _check(cell, run, options, started)
    result_check.cell = cell_shown
    return result_check


def _check(cell: str, run: str, options: dict, started: float) -> RunCheck:
    from .simulation import simulate_run

    if not run:
        if (_folder(cell) / "cell.yaml").is_file():
            return RunCheck(cell, run, True, skipped=True)  # a cell with nothing to run
        why = f"{cell}: not a cell (no cell.yaml)"
        return RunCheck(cell, run, False, why, problems=[Problem("input", why, cell)])
    try:
        loaded, result = simulate_run(cell, run, **options)
    except UserError as exc:
        if exc.exit_code == 1:  # well formed, but the check fails (an unreachable target)
            file, line = _located(str(exc))
            return RunCheck(
                cell,
                run,
                False,
                problems=[Problem("unreachable", str(exc), file or cell, line)],
                seconds=time.perf_counter() - started,
            )
        lines = exc.lines()
        problems = []
        for issue in exc.issues or []:
            problems.append(Problem("input", issue.message, issue.file, issue.line or None))
        if not problems:
            file, line = _located(str(exc))
            problems.append(Problem("input", str(exc), file or cell, line))
        return RunCheck(
            cell,
            run,
            False,
            "\n".join(lines),
            problems=problems,
            seconds=time.perf_counter() - started,
        )
    where_of = {p.device: [s.where for s in p.steps] for p in loaded.programs}
    problems = []
    for v in result.violations:
        file, line = _split(where_of[v.device][v.step] if v.step is not None else None)
        problems.append(Problem("limit", v.describe(), file, line))
    report = result.collisions
    counts = {"limit_violations": len(result.violations)}
    if report is not None:
        for c in report.contacts:
            file, line = _split(c.steps[0].where if c.steps else None)
            kind = "collision" if c.contact.collision else "clearance"
            problems.append(Problem(kind, c.describe().replace("\n", " "), file, line))
        for h in report.handling:
            file, line = _split(h.step.where if h.step else None)
            problems.append(Problem("handling", h.describe(), file, line))
        counts |= {
            "collisions": len(report.collisions),
            "clearance_violations": len(report.clearance_violations),
            "handling": len(report.handling),
        }
    return RunCheck(
        cell,
        run,
        bool(result.ok),
        None,
        # to the nanosecond: BLAS threading differs between executors (Dask workers run one
        # thread) and moves the last digits; the report is the same on every executor
        round(float(result.cycle_time), 9),
        counts,
        problems,
        time.perf_counter() - started,
    )


class _Inline:
    """One worker: the runs in this process, one after the other (the same interface)."""

    def submit(self, fn, *args):
        from concurrent.futures import Future

        future: Future = Future()
        try:
            future.set_result(fn(*args))
        except BaseException as exc:  # noqa: BLE001 - handed to the caller as a pool would
            future.set_exception(exc)
        return future

    def shutdown(self, wait: bool = True) -> None:
        pass


_ADDRESS = re.compile(
    r"^(?:(?P<scheme>tcp|tls|ws|wss|ucx)://)?(?P<host>\[[0-9a-fA-F:.]+\]|[A-Za-z0-9_.-]+):"
    r"(?P<port>\d{1,5})/?$"
)
WORKER_WAIT = 30.0  # [s]: how long a cluster without workers is waited for, mid-run
# (RWORLD_WORKER_WAIT overrides it: seconds)
POLL = 1.0  # [s]: how often the cluster is looked at while runs are pending


def scheduler_address(text: str) -> str:
    """A Dask scheduler's address, ``tcp://HOST:PORT`` (or ``HOST:PORT``, tls, ws, wss, ucx);
    anything else is bad input naming the option."""
    match = _ADDRESS.match(text.strip())
    if match is None or not 0 < int(match["port"]) < 65536:
        raise UserError(
            f"--scheduler '{text}' is not a Dask scheduler address: give tcp://HOST:PORT "
            "(e.g. tcp://10.0.0.5:8786)"
        )
    return text.strip()


def _refuses(address: str) -> str | None:
    """Why nothing listens at a tcp:// scheduler ``address`` when the host says so at once
    (connection refused, unknown host); None when it may be there.  Dask's client retries a
    refused connection until its timeout: ten seconds of waiting for an answer already given."""
    import socket

    match = _ADDRESS.match(address)
    if match is None or (match["scheme"] or "tcp") != "tcp":
        return None
    host = match["host"].strip("[]")
    try:
        socket.create_connection((host, int(match["port"])), timeout=2.0).close()
    except ConnectionRefusedError:
        return "connection refused"
    except socket.gaierror as exc:
        return f"unknown host '{host}' ({exc.strerror})"
    except OSError:  # timed out, unreachable: left to Dask's own wait
        return None
    return None


def _workers(client) -> int:
    try:
        return len(client.scheduler_info().get("workers", {}))
    except Exception:  # the scheduler went away: no workers either
        return 0


def _executor(workers: int | None, scheduler: str | None):
    """(executor, description, close, client): a Dask cluster's executor, a process pool, or
    inline; ``client`` the cluster's (None otherwise)."""
    if scheduler is not None:
        address = scheduler_address(scheduler)
        try:
            from distributed import Client
        except ImportError:
            raise UserError(
                "--scheduler needs Dask's distributed scheduler client: pip install "
                "'rworld[cluster]' (or distributed)"
            ) from None
        refused = _refuses(address)
        if refused is not None:
            raise UserError(f"no Dask scheduler answers at {address}: {refused}")
        try:
            client = Client(address, timeout="10s")
        except Exception as exc:  # refused, timed out, an address Dask cannot parse
            raise UserError(f"no Dask scheduler answers at {address}: {exc}") from None
        workers_there = _workers(client)
        if workers_there == 0:  # the runs would wait for ever: say so now
            client.close()
            raise UserError(
                f"{address}: 0 workers: start some ('dask worker {address}') before checking"
            )
        description = f"dask {address} ({workers_there} workers)"
        return client.get_executor(), description, client.close, client
    count = workers or os.cpu_count() or 1
    if count == 1:
        return _Inline(), "1 process", lambda: None, None
    from concurrent.futures import ProcessPoolExecutor

    pool = ProcessPoolExecutor(max_workers=count)
    return pool, f"{count} local processes", lambda: pool.shutdown(wait=True), None


def check_fleet(
    cells: list[str],
    run: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    clearance: float | str | None = None,
    collision_tolerance: float | str | None = None,
    collisions: bool = True,
    progress=None,
) -> FleetCheck:
    """Check ``run`` on each cell, or every run of every cell, on ``workers`` local processes
    (default: the cores; 1: this process) or the Dask cluster at ``scheduler``
    (``tcp://host:port``).  Results are in the order of :func:`fleet_runs`, identical on
    every executor.  ``progress(done, total, what)`` as runs finish.

    Raises
    ------
    UserError
        No cells, a bad --workers, no scheduler at the address.
    """
    if not cells:
        raise UserError("give at least one cell")
    if workers is not None and workers < 1:
        raise UserError("--workers must be at least 1")
    if run is not None and Path(run).is_file():  # a run file: where the workers find it too
        run = os.path.abspath(run)
    tasks = fleet_runs(cells, run)
    options = {
        "clearance": clearance,
        "collision_tolerance": collision_tolerance,
        "collisions": collisions,
        "report": False,  # a check prints no distances: only what decides it is measured
        "scheduler": scheduler,
    }
    # a cluster's workers get absolute paths (their working folder is not the client's)
    jobs = [(cell, name, options, os.path.abspath(cell)) for cell, name in tasks]
    results, description = run_tasks(check_one, jobs, workers, scheduler, progress)
    return FleetCheck(results, description)


def run_tasks(fn, tasks: list[tuple], workers, scheduler, progress=None, what: str = "runs"):
    """``fn(*task)`` for every task on the executor (:func:`_executor`), the results in the
    order of ``tasks`` whatever order they finish in; ``progress(done, total, what)``.

    Returns
    -------
    (list, str)
        The results, and the executor's description.
    """
    from concurrent.futures import FIRST_COMPLETED, wait

    executor, description, close, client = _executor(workers, scheduler)
    patience = float(os.environ.get("RWORLD_WORKER_WAIT", WORKER_WAIT))
    try:
        futures = [executor.submit(fn, *task) for task in tasks]
        pending, done = set(futures), 0
        idle_since = None  # when the cluster was first seen without workers
        while pending:
            finished, pending = wait(pending, timeout=POLL, return_when=FIRST_COMPLETED)
            for _ in finished:  # one call per task, as each finishes
                done += 1
                if progress:
                    progress(done, len(futures), what)
            if client is None or finished or not pending:
                idle_since = None
                continue
            if _workers(client) > 0:
                idle_since = None
                continue
            now = time.monotonic()
            idle_since = idle_since or now
            _say(
                f"{scheduler}: 0 workers, {len(pending)} {what} waiting; giving up in "
                f"{max(patience - (now - idle_since), 0):.0f} s"
            )
            if now - idle_since >= patience:
                left = [tasks[k] for k, f in enumerate(futures) if f in pending]
                for f in pending:
                    f.cancel()
                named = ", ".join(" ".join(str(x) for x in t[:2]).strip() for t in left[:10])
                raise UserError(
                    f"{scheduler}: no worker for {patience:g} s, {len(left)} {what} not "
                    f"done ({named}{', ...' if len(left) > 10 else ''}): restart the workers "
                    "and check again"
                )
        return [f.result() for f in futures], description
    finally:
        close()


def _say(line: str) -> None:
    """A progress line on the ``rworld`` logger (the CLI prints it on stderr)."""
    import logging

    logging.getLogger("rworld").warning(line)


def junit_xml(fleet: FleetCheck) -> str:
    """JUnit XML of a fleet check: a testsuite per cell, a testcase per run; a failed run is a
    ``failure`` listing its problems as ``file:line: message``, bad input an ``error``."""
    import xml.etree.ElementTree as ET

    suites = ET.Element("testsuites", name="rworld check")
    by_cell: dict[str, list[RunCheck]] = {}
    for r in fleet.results:
        by_cell.setdefault(r.cell, []).append(r)
    totals = {"tests": 0, "failures": 0, "errors": 0}
    totals["skipped"] = 0
    for cell, runs in by_cell.items():
        failures = sum(r.status == "failed" for r in runs)
        errors = sum(r.status == "error" for r in runs)
        skipped = sum(r.status == "skipped" for r in runs)
        suite = ET.SubElement(
            suites,
            "testsuite",
            name=cell,
            tests=str(len(runs)),
            failures=str(failures),
            errors=str(errors),
            skipped=str(skipped),
            time=f"{sum(r.seconds for r in runs):.3f}",
        )
        for r in runs:
            case = ET.SubElement(
                suite, "testcase", classname=cell, name=r.run or "(cell)", time=f"{r.seconds:.3f}"
            )
            text = "\n".join(
                (f"{p.file}:{p.line}: " if p.file and p.line else f"{p.file}: " if p.file else "")
                + p.message
                for p in r.problems
            )
            if r.status == "failed":
                first = r.problems[0].message if r.problems else "failed"
                ET.SubElement(case, "failure", message=first, type="check").text = text
            elif r.status == "error":
                ET.SubElement(case, "error", message=(r.error or "").splitlines()[0]).text = text
            elif r.status == "skipped":
                ET.SubElement(case, "skipped", message="no runs/*.yaml in the cell")
        totals["tests"] += len(runs)
        totals["failures"] += failures
        totals["errors"] += errors
        totals["skipped"] += skipped
    for key, value in totals.items():
        suites.set(key, str(value))
    ET.indent(suites)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(suites, "unicode") + "\n"


def write_junit(fleet: FleetCheck, path: str) -> None:
    """Write :func:`junit_xml` to ``path`` atomically."""
    from ..fileio import atomic_write_text

    atomic_write_text(path, junit_xml(fleet))


def _escape_data(text: str) -> str:
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def _escape_property(text: str) -> str:
    return _escape_data(text).replace(":", "%3A").replace(",", "%2C")


def github_annotations(fleet: FleetCheck) -> list[str]:
    """GitHub Actions workflow commands: an ``::error`` per problem on its file and line (a
    collision shows on the program line that was running), a ``::notice`` per run that
    passed."""
    out = []
    for r in fleet.results:
        title = f"rworld check {r.cell} {r.run}".strip()
        if r.status in ("ok", "skipped"):
            what = "ok" if r.status == "ok" else "no runs to check"
            out.append(f"::notice title={_escape_property(title)}::{what}")
            continue
        for p in r.problems or [Problem("input", r.error or "failed", r.cell)]:
            where = ""
            if p.file:
                where = f"file={_escape_property(p.file)},"
                if p.line:
                    where += f"line={p.line},"
            out.append(f"::error {where}title={_escape_property(title)}::{_escape_data(p.message)}")
    return out
