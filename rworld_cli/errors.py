"""Errors and the located problems ("issues") that rworld reports.

Every problem found in a user's file becomes an :class:`Issue` that knows its
file, line and column, so the CLI can print ``file:line:col: where: message``
lines that editors and CI logs link to.  Library code raises
:class:`UserError` (bad input: exit code 2) or :class:`CheckFailed` (a check
failed: exit code 1); any other exception is a bug, which the CLI reports
with exit code 3.  Only the CLI prints and exits.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

Severity = Literal["error", "warning", "note"]


@dataclass(frozen=True)
class Issue:
    """One located problem in an input file.

    Attributes
    ----------
    file : str
        The path as the user named it (kept relative when it was given so).
    line, column : int
        1-based position of the offending key or value; 0 when unknown.
    location : str
        Dotted location inside the document, e.g. ``devices[0].joints[2].a``;
        ``(root)`` for the whole document.
    message : str
        What is wrong, and where possible what would be right.
    severity : {"error", "warning", "note"}
        A note says what the files already acknowledge (meshes marked as open surfaces): the
        global ``--quiet`` leaves notes out.
    """

    file: str
    line: int
    column: int
    location: str
    message: str
    severity: Severity = "error"

    def format(self) -> str:
        """The one-line form ``file:line:col: [warning: ]location: message``."""
        tag = f"{self.severity}: " if self.severity != "error" else ""
        where = f"{self.file}:{self.line}:{self.column}" if self.line > 0 else self.file
        return f"{where}: {tag}{self.location}: {self.message}"

    def as_dict(self) -> dict:
        return {
            "file": self.file,
            "line": self.line,
            "column": self.column,
            "location": self.location,
            "message": self.message,
            "severity": self.severity,
        }


class RworldError(Exception):
    """Base of every error rworld raises on purpose."""

    exit_code = 3


class UserError(RworldError):
    """Bad input or usage: the user can fix it.  CLI exit code 2.

    Parameters
    ----------
    message : str
        A one-line summary.
    issues : iterable of Issue, optional
        The located problems behind it (all of them, not only the first).
    """

    exit_code = 2

    def __init__(self, message: str, issues: Iterable[Issue] = ()):
        super().__init__(message)
        self.message = message
        self.issues: list[Issue] = list(issues)

    def lines(self) -> list[str]:
        """The lines to print: one per issue, or the message alone."""
        if self.issues:
            return [i.format() for i in self.issues]
        return [self.message]


class CheckFailed(UserError):
    """The input is well formed but fails a check the command makes (e.g. a path that leaves a
    joint's range between its waypoints).  CLI exit code 1, with the located issues; ``report``
    (a dict): what the command's ``--json`` prints beside the error (a plan that failed: its
    outcome, counts and time)."""

    exit_code = 1

    def __init__(self, message: str, issues: Iterable[Issue] = (), report: dict | None = None):
        super().__init__(message, issues)
        self.report = report


def did_you_mean(word: str, choices, cutoff: float = 0.6) -> str:
    """`` (did you mean 'x'?)`` for the closest choice, or an empty string."""
    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=cutoff)
    return f" (did you mean '{close[0]}'?)" if close else ""
