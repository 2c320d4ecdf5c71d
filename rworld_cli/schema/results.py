"""Result files of a run: CSV tables and JSON documents, each written atomically."""

from __future__ import annotations

import json
from pathlib import Path

from ..fileio import atomic_write_text
from .tables import format_csv


def write_results(directory: str | Path, tables: dict, documents: dict) -> list[Path]:
    """Write ``tables`` ({name: (columns, rows)}) as CSV and ``documents`` ({name: payload}) as
    JSON into ``directory``.
    """
    out = Path(directory)
    written = []
    for name, (columns, rows) in tables.items():
        atomic_write_text(out / name, format_csv(columns, rows))
        written.append(out / name)
    for name, payload in documents.items():
        atomic_write_text(out / name, json.dumps(payload, indent=2, allow_nan=False) + "\n")
        written.append(out / name)
    return written
