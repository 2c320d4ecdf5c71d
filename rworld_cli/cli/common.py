"""What every command shares: --json, error printing, exit codes."""

from __future__ import annotations

import functools
import json
import logging
import sys
from collections.abc import Callable
from typing import Any

import click

EXIT_OK, EXIT_CHECK_FAILED, EXIT_BAD_INPUT, EXIT_INTERNAL = 0, 1, 2, 3
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE: what a shell reports for a writer whose reader left


def json_option(fn: Callable) -> Callable:
    """Add ``--json`` to a command; it is also on when the group got ``rworld --json``."""

    @click.option(
        "--json", "json_output", is_flag=True, help="Print machine-readable JSON on stdout."
    )
    @functools.wraps(fn)
    def wrapper(*args, json_output: bool = False, **kwargs):
        ctx = click.get_current_context()
        group_json = bool((ctx.find_root().obj or {}).get("json"))
        return fn(*args, json_output=json_output or group_json, **kwargs)

    return wrapper


def emit_json(payload: Any) -> None:
    from ..api import json_ready

    click.echo(json.dumps(json_ready(payload), indent=2, ensure_ascii=False, allow_nan=False))


class _StderrLines(logging.Handler):
    """The ``rworld`` logger's records as ``rworld: message`` lines on the stderr of the moment."""

    def emit(self, record: logging.LogRecord) -> None:
        click.echo(f"rworld: {record.getMessage()}", err=True)


class FiniteFloat(click.FloatRange):
    """A number option checked like a file's value: finite (NaN and infinities refused, which
    click's FloatRange lets through) and within its range."""

    name = "number"

    def convert(self, value, param, ctx):
        import math

        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        return number


class ReportedExit(SystemExit):
    """An exit whose code reports what was found (a fleet with bad cells: 2) but whose files
    are the report of it: kept, as a failed check's are."""


def _in_one_output_set(fn: Callable, args, kwargs):
    """Run a command with every file it writes in one output set (``fileio.output_set``): the
    files appear together when it ends, or - on bad input, an interrupt or a bug - none do.
    A failed check (exit 1) keeps what the command wrote (its report of the failure)."""
    from ..api import output_set
    from ..errors import CheckFailed

    log = logging.getLogger("rworld")
    if not log.handlers:  # what a killed run left and this one finished or removed: one line each
        log.addHandler(_StderrLines())
        log.propagate = False
    failed = None
    with output_set():
        try:
            result = fn(*args, **kwargs)
        except CheckFailed as exc:
            failed = exc
        except SystemExit as exc:
            if exc.code not in (None, 0, EXIT_CHECK_FAILED) and not isinstance(exc, ReportedExit):
                raise
            failed = exc
    if failed is not None:
        raise failed
    return result


def _no_empty_values(kwargs: dict) -> None:
    """An option or argument given as empty text (``--pose-files ""``) is refused, never
    silently ignored: exit 2 naming it."""
    ctx = click.get_current_context(silent=True)
    if ctx is None:
        return
    for param in ctx.command.params:
        value = kwargs.get(param.name)
        values = value if isinstance(value, tuple) else (value,)
        if any(isinstance(v, str) and not v.strip() for v in values):
            raise click.BadParameter(
                "an empty value: give one, or leave the option out", ctx, param
            )


def handle_errors(fn: Callable) -> Callable:
    """Turn rworld errors into printed lines and exit codes; never a traceback for bad input.

    UserError -> its issue lines on stderr, exit 2 (or the JSON error object
    on stdout with --json).  Anything unexpected is a bug: exit 3 with a
    one-line request to report it (the traceback with RWORLD_DEBUG=1).
    """

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        from ..errors import RworldError, UserError

        _no_empty_values(kwargs)
        try:
            return _in_one_output_set(fn, args, kwargs)
        except click.exceptions.Exit:
            raise
        except click.ClickException:
            raise
        except RworldError as exc:
            if kwargs.get("json_output"):
                issues = exc.issues if isinstance(exc, UserError) else []
                report = getattr(exc, "report", None) or {}
                emit_json({"error": str(exc), "issues": [i.as_dict() for i in issues], **report})
            else:
                lines = exc.lines() if isinstance(exc, UserError) else [str(exc)]
                for line in lines:
                    click.echo(line, err=True)
            sys.exit(exc.exit_code)
        except KeyboardInterrupt:
            click.echo("interrupted", err=True)
            sys.exit(130)
        except BrokenPipeError:
            # the reader of stdout went away (`rworld ... | head -1`): no bug, no message; the
            # command did not finish, so it wrote nothing (its output set was dropped).  Python
            # would report the pipe again when it flushes stdout at exit: point it at devnull
            import os

            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            sys.exit(EXIT_BROKEN_PIPE)
        except Exception as exc:  # a bug: say so plainly
            import os
            import traceback

            if os.environ.get("RWORLD_DEBUG"):
                traceback.print_exc()
            click.echo(
                f"internal error: {type(exc).__name__}: {exc}\n"
                "This is a bug in rworld; please report it with the command and files "
                "(RWORLD_DEBUG=1 shows the traceback).",
                err=True,
            )
            sys.exit(EXIT_INTERNAL)

    return wrapper


# --frames F1,F2,...: the calibration commands' choice of conditioned frames
def output_option(
    help: str,
    *,
    folder: bool = False,
    required: bool = False,
    name: str | None = None,
    default: str | None = None,
) -> Callable:
    """``-o/--output``: the file (or, with ``folder``, the folder) a command writes; each
    command says in ``help`` what it writes there."""
    return click.option(
        "-o",
        "--output",
        *([name] if name else []),
        default=default,
        show_default=default is not None,
        required=required,
        type=click.Path(file_okay=False) if folder else click.Path(dir_okay=False),
        help=help,
    )


#: the languages whose controller logs rworld reads back (``schema/contactlog.LANGUAGES``)
LOG_FORMATS = ("urscript", "rapid", "krl", "fanuc", "inform", "drl", "val3", "sunrise")


def log_format_option(help: str) -> Callable:
    """``--format LANGUAGE``: the language of a controller's log (``measure --from-log``,
    ``captures --from-log``); each command says in ``help`` what it takes by default."""
    return click.option("--format", "fmt", default=None, type=click.Choice(LOG_FORMATS), help=help)


def device_option(help: str, *, required: bool = False) -> Callable:
    """``--device NAME``: which device of the cell a command acts on; each command says in
    ``help`` what it does with it and what it takes by default."""
    return click.option("--device", default=None, required=required, metavar="NAME", help=help)


def seed_option(help: str | None = None) -> Callable:
    """``--seed N``: a random search's seed (0 or more), so that a run repeats."""
    return click.option(
        "--seed", default=0, show_default=True, type=click.IntRange(min=0), help=help
    )


frames_option = click.option(
    "--frames",
    default=None,
    metavar="F1,F2,...",
    help="Only these conditioned frames (default: all).",
)

# --joints DEVICE=q1,... (repeatable): a cell's state, for the commands that look at one state
joints_option = click.option(
    "--joints",
    multiple=True,
    metavar="DEVICE=q1,...",
    help="Joint values (SI); repeatable. Default: home.",
)


def parse_joint_assignments(values: tuple[str, ...]) -> dict[str, list[float]]:
    """``("robot=0,0.5,1", ...)`` -> ``{"robot": [0, 0.5, 1]}``; usage errors exit 2."""
    out: dict[str, list[float]] = {}
    for item in values:
        name, sep, rest = item.partition("=")
        if not sep or not name:
            raise click.BadParameter(
                f"'{item}': expected DEVICE=q1,q2,... (SI: rad or m)", param_hint="--joints"
            )
        try:
            q = [float(v) for v in rest.split(",")]
        except ValueError:
            raise click.BadParameter(
                f"'{item}': joint values must be numbers separated by commas", param_hint="--joints"
            ) from None
        if any(v != v or v in (float("inf"), float("-inf")) for v in q):
            raise click.BadParameter(
                f"'{item}': joint values must be finite", param_hint="--joints"
            )
        out[name] = q
    return out


def with_progress(show: bool, call, what: str):
    """``call(progress)`` under a transient rich progress bar on stderr when ``show`` (else
    ``call(None)``); ``progress(done, total, what)`` updates it (``total`` None: no end known)."""
    if not show:
        return call(None)
    from rich.console import Console
    from rich.progress import Progress

    with Progress(transient=True, console=Console(stderr=True)) as bar:
        task = bar.add_task(what, total=None)

        def progress(done, total, text):
            bar.update(task, completed=done, total=total, description=text)

        return call(progress)


def shown_issues(issues) -> list:
    """The warnings and notes a command prints: notes (what the files acknowledge) left out
    under the global ``--quiet``."""
    ctx = click.get_current_context(silent=True)
    quiet = bool(ctx is not None and ctx.find_root().params.get("quiet"))
    return [i for i in issues if not (quiet and i.severity == "note")]
