"""CSV text as spreadsheets and measuring software write it, read with the csv module.

* a UTF-8 byte-order mark is dropped (Excel writes one);
* the delimiter is found from the header line: ``,``, ``;`` (locales whose decimal mark is a
  comma) or a tab;
* quoted fields are unquoted (``"block.f1"``);
* lines that are empty or start with ``#`` are comments; a comment ``# units: mm`` states the
  length unit of a file whose header does not.

Every cell keeps its line and 1-based column, for located errors; every refusal says why.
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import Issue, UserError

DELIMITERS = ",;\t"


@dataclass
class CsvTable:
    """A CSV file's header and rows.

    Attributes
    ----------
    path : str
    header : list of str
        The header's fields, stripped.
    header_line : int
        1-based line of the header.
    rows : list of (line, fields, columns)
        Each data row: its 1-based line, its fields (stripped), the 1-based column where each
        field starts.
    delimiter : str
    comments : list of (line, text)
        Comment lines (their 1-based line, the text without ``#``), in order.
    """

    path: str
    header: list[str]
    header_line: int
    rows: list[tuple[int, list[str], list[int]]] = field(default_factory=list)
    delimiter: str = ","
    comments: list[tuple[int, str]] = field(default_factory=list)

    def stated(self, key: str) -> tuple[str | None, int]:
        """The value of a ``# KEY: VALUE`` comment, and its line (None, 0 when absent)."""
        for line, text in self.comments:
            m = re.fullmatch(rf"{key}\s*[:=]\s*(\S+)", text)
            if m:
                return m.group(1), line
        return None, 0


def read_csv_table(path: str, expected: str) -> CsvTable:
    """Read ``path`` into a :class:`CsvTable`.

    Parameters
    ----------
    path : str
    expected : str
        The header the format wants (for the message when there is none), e.g.
        ``"feature,x,y,z"``.

    Raises
    ------
    UserError
        No such file, not UTF-8, or no header.
    """
    try:
        raw = Path(path).read_bytes()
    except FileNotFoundError:
        raise UserError(
            f"{path}: no such file", [Issue(path, 0, 0, "(file)", "no such file")]
        ) from None
    except OSError as exc:
        raise UserError(
            f"{path}: cannot read", [Issue(path, 0, 0, "(file)", f"cannot read: {exc}")]
        ) from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise UserError(
            f"{path}: not UTF-8",
            [
                Issue(
                    path,
                    line,
                    1,
                    "(file)",
                    f"byte {raw[exc.start]:#04x} is not UTF-8; save the file as UTF-8 (CSV UTF-8 "
                    "in Excel)",
                )
            ],
        ) from None
    lines = text.splitlines()
    comments: list[tuple[int, str]] = []
    header_at = None
    for i, line in enumerate(lines):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            comments.append((i + 1, stripped[1:].strip()))
            continue
        header_at = i
        break
    if header_at is None:
        raise UserError(
            f"{path}: empty",
            [
                Issue(
                    path, 1, 1, "(header)", f"the file is empty (no header); expected '{expected}'"
                )
            ],
        )
    counts = {d: lines[header_at].count(d) for d in DELIMITERS}
    # the most frequent of them; none: one column (the format's own check says if that is wrong)
    delimiter = max(DELIMITERS, key=lambda d: counts[d]) if any(counts.values()) else ","
    table = CsvTable(path, [], header_at + 1, delimiter=delimiter)
    for i in range(header_at, len(lines)):
        line = lines[i]
        stripped = line.strip()
        if i > header_at and (not stripped or stripped.startswith("#")):
            if stripped:
                comments.append((i + 1, stripped[1:].strip()))
            continue
        fields, columns = _split(line, delimiter)
        if i == header_at:
            table.header = fields
        else:
            table.rows.append((i + 1, fields, columns))
    table.comments = comments
    return table


def _split(line: str, delimiter: str) -> tuple[list[str], list[int]]:
    """One line's fields (unquoted, stripped) and the 1-based column where each starts."""
    fields = next(csv.reader(io.StringIO(line), delimiter=delimiter, skipinitialspace=True))
    columns = []
    at = 0
    for _ in fields:  # where each field starts: after the previous delimiter outside quotes
        columns.append(at + 1 + (len(line[at:]) - len(line[at:].lstrip())))
        quoted = False
        while at < len(line):
            ch = line[at]
            if ch == '"':
                quoted = not quoted
            elif ch == delimiter and not quoted:
                break
            at += 1
        at += 1
    return [f.strip() for f in fields], columns
