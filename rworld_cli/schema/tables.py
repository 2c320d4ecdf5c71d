"""CSV state files: ``q1..qn, qd1..qdn, qdd1..qddn, tau1..taun`` in SI, with located errors.

A state file has a header row naming its columns; a command reads only the
groups it needs and says which are missing.  Columns it does not need
(a time column, say) are ignored.  Every bad cell is reported as
``file:line:col: column 'qd3': ...``.
"""

from __future__ import annotations

import io
import math

import numpy as np

from ..errors import Issue, UserError
from ..fileio import atomic_write_text


def column_names(group: str, n: int) -> list[str]:
    return [f"{group}{i}" for i in range(1, n + 1)]


def read_states(
    path: str, n: int, groups: list[str], scalars: tuple[str, ...] = ()
) -> dict[str, np.ndarray]:
    """Read the column groups (e.g. ``["q", "qd", "qdd"]``) of an n-joint device.

    ``scalars`` names single columns to read as well (e.g. ``("t",)``).

    Returns
    -------
    dict
        group -> ndarray of shape (N, n); each scalar column -> shape (N,); ``"_line"`` -> the
        1-based line of each row in the file, ``"_column"`` -> scalar name -> its 1-based column
        on each row (for located errors about the values).

    Raises
    ------
    UserError
        Missing file or columns, wrong field counts, text, NaN or infinite values; all at once.
    """
    from .csvtext import read_csv_table

    wanted = list(scalars) + [name for g in groups for name in column_names(g, n)]
    table = read_csv_table(path, ",".join(wanted))
    header, header_line = table.header, table.header_line
    issues: list[Issue] = []
    missing = [w for w in wanted if w not in header]
    if missing:
        extra = [h for h in header if h and h[:1] in "qt" and h not in wanted]
        hint = f"; it has {', '.join(extra)} (the device has {n} joint(s))" if extra else ""
        issues.append(
            Issue(path, header_line, 1, "(header)", f"missing column(s) {', '.join(missing)}{hint}")
        )
        raise UserError(f"{path}: missing columns", issues)
    duplicated = sorted({h for h in header if header.count(h) > 1 and h in wanted})
    if duplicated:
        raise UserError(
            f"{path}: duplicate columns",
            [
                Issue(
                    path, header_line, 1, "(header)", f"duplicate column(s) {', '.join(duplicated)}"
                )
            ],
        )
    index = {name: header.index(name) for name in wanted}
    rows: list[list[float]] = []
    row_lines: list[int] = []
    scalar_cols: dict[str, list[int]] = {name: [] for name in scalars}
    for lineno, fields, columns in table.rows:
        if len(fields) != len(header):
            issues.append(
                Issue(
                    path,
                    lineno,
                    1,
                    "(row)",
                    f"{len(fields)} field(s) separated by '{table.delimiter}' but the header has "
                    f"{len(header)}",
                )
            )
            continue
        row = []
        cols = {}
        for name in wanted:
            k = index[name]
            raw = fields[k]
            col = columns[k]
            cols[name] = col
            try:
                value = float(raw)
            except ValueError:
                hint = " (a decimal comma? use '.' or ';' between fields)" if "," in raw else ""
                issues.append(
                    Issue(
                        path,
                        lineno,
                        col,
                        f"column '{name}'",
                        f"expected a number, got '{raw}'{hint}",
                    )
                )
                continue
            if not math.isfinite(value):
                issues.append(
                    Issue(
                        path,
                        lineno,
                        col,
                        f"column '{name}'",
                        f"expected a finite number, got '{raw}'",
                    )
                )
                continue
            row.append(value)
        if len(row) == len(wanted):
            rows.append(row)
            row_lines.append(lineno)
            for name in scalars:
                scalar_cols[name].append(cols[name])
    if issues:
        raise UserError(f"{path}: {len(issues)} error(s)", issues[:50])
    if not rows:
        raise UserError(
            f"{path}: no data",
            [Issue(path, header_line, 1, "(rows)", "the header is followed by no data rows")],
        )
    data = np.array(rows, dtype=float)
    out: dict = {name: data[:, i] for i, name in enumerate(scalars)}
    data = data[:, len(scalars) :]
    out.update({g: data[:, i * n : (i + 1) * n] for i, g in enumerate(groups)})
    out["_line"] = np.array(row_lines)
    out["_column"] = {name: np.array(c) for name, c in scalar_cols.items()}
    return out


def limit_warnings(
    path: str, q: np.ndarray, lower: np.ndarray, upper: np.ndarray, first_line: int = 2
) -> list[Issue]:
    """Warnings (not errors: analysis may want them) for joint values outside their limits."""
    out = []
    bad = np.argwhere((q < lower) | (q > upper))
    for row, j in bad[:20]:
        out.append(
            Issue(
                path,
                0,
                0,
                f"row {row + 1}",
                f"q{j + 1} = {q[row, j]:.6g} is outside its limits "
                f"[{lower[j]:.6g}, {upper[j]:.6g}]",
                "warning",
            )
        )
    if len(bad) > 20:
        out.append(
            Issue(
                path,
                0,
                0,
                "(rows)",
                f"{len(bad) - 20} more joint value(s) outside their limits",
                "warning",
            )
        )
    return out


INTEGER_COLUMNS = ("step",)  # counts, written as integers (1-based program steps, 0: none)


def format_csv(columns: list[str], data: np.ndarray) -> str:
    """CSV text with a header; numbers in repr (round-trip exact), the columns named in
    ``INTEGER_COLUMNS`` as integers."""
    whole = [c in INTEGER_COLUMNS for c in columns]
    buf = io.StringIO()
    buf.write(",".join(columns) + "\n")
    for row in np.atleast_2d(data):
        buf.write(",".join(str(int(v)) if w else repr(float(v)) for v, w in zip(row, whole)) + "\n")
    return buf.getvalue()


def write_csv(path: str, columns: list[str], data: np.ndarray) -> None:
    atomic_write_text(path, format_csv(columns, data))


def write_records_csv(path: str, columns: list[str], rows: list[list]) -> None:
    """A CSV table of mixed cells - text, integers, numbers (repr: round-trip exact), empty -
    written atomically; text is quoted where CSV needs it."""
    import csv

    buf = io.StringIO()
    out = csv.writer(buf, lineterminator="\n")
    out.writerow(columns)
    for row in rows:
        out.writerow([repr(float(v)) if isinstance(v, float) else v for v in row])
    atomic_write_text(path, buf.getvalue())
