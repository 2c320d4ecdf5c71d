"""Result files of a run: CSV tables and JSON documents, each written atomically."""

from __future__ import annotations

import json
from pathlib import Path

from ..fileio import atomic_write_text
from ..jsonvalues import finite
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
        text = json.dumps(finite(payload), indent=2, allow_nan=False)
        atomic_write_text(out / name, text + "\n")
        written.append(out / name)
    return written


# the files of a run's scene in its output directory (rworld view DIR reads them back)
SCENE_FILE = "run.glb"
VIEW_FILE = "view.json"
_VIEW_KEYS = {
    "title": str,
    "t": list,
    "t_end": (int, float),
    "devices": dict,
    "marks": list,
    "labels": list,
    "without_geometry": list,
}


def write_scene_files(directory: str | Path, glb: bytes, info: dict) -> list[Path]:
    """The run's animated scene and the viewer's panel data, each written atomically."""
    from ..fileio import atomic_write_bytes

    out = Path(directory)
    atomic_write_bytes(out / SCENE_FILE, glb)
    atomic_write_text(out / VIEW_FILE, json.dumps(finite(info), allow_nan=False) + "\n")
    return [out / SCENE_FILE, out / VIEW_FILE]


def read_scene_files(directory: str | Path) -> tuple[bytes, dict]:
    """(scene .glb bytes, panel data) of a run output directory; UserError naming the file and
    what is wrong when one is missing or damaged."""
    from ..errors import UserError
    from .gltf import read_glb

    folder = Path(directory)
    if not folder.is_dir():
        raise UserError(f"{folder}: no such directory (give the -o DIR of 'rworld simulate')")
    paths = {name: folder / name for name in (SCENE_FILE, VIEW_FILE)}
    for name, path in paths.items():
        if not path.is_file():
            raise UserError(
                f"{path}: missing; {folder} is not a run output directory of this rworld "
                f"(write one with 'rworld simulate CELL RUN -o {folder}')"
            )
    glb = paths[SCENE_FILE].read_bytes()
    gltf, _ = read_glb(glb, str(paths[SCENE_FILE]))
    if not gltf.get("nodes"):
        raise UserError(f"{paths[SCENE_FILE]}: a glTF file without nodes: not a run's scene")
    try:
        info = json.loads(paths[VIEW_FILE].read_text("utf-8"))
    except UnicodeDecodeError as exc:
        raise UserError(f"{paths[VIEW_FILE]}: not UTF-8 text ({exc.reason})") from None
    except json.JSONDecodeError as exc:
        raise UserError(
            f"{paths[VIEW_FILE]}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}"
        ) from None
    if not isinstance(info, dict):
        raise UserError(f"{paths[VIEW_FILE]}: expected a JSON object, got {type(info).__name__}")
    for key, kind in _VIEW_KEYS.items():
        if key not in info:
            raise UserError(f"{paths[VIEW_FILE]}: no '{key}' entry")
        if not isinstance(info[key], kind):
            raise UserError(f"{paths[VIEW_FILE]}: '{key}' has the wrong type")
    return glb, info
