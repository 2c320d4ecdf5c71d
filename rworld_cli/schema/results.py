"""Result files of a run: CSV tables and JSON documents, each written atomically."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

from pydantic import AfterValidator, Field, ValidationError, model_validator

from ..fileio import atomic_write_text
from ..jsonvalues import finite
from .models import Strict
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
# everything 'simulate -o DIR' (and 'rworld view DIR') writes in DIR: a new run replaces all of
# them, so none of an earlier run's stays beside it; other files in DIR are the user's and stay
SCENE_OUTPUTS = (SCENE_FILE, VIEW_FILE, "view.html")
RUN_OUTPUTS = (
    "timeline_*.csv",
    "timeline.json",
    "events.json",
    "summary.json",
    "collisions.json",
    "plot_*.png",
    *SCENE_OUTPUTS,
)


def _text(value: str) -> str:
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise ValueError("holds a lone surrogate: not text any file can carry") from None
    return value


Text = Annotated[str, AfterValidator(_text)]


class ViewStep(Strict):
    text: Text
    where: Text = Field(description="file:line of the step")


class ViewDevice(Strict):
    q: list[list[float]] = Field(description="Per joint, its value at each instant of 't'.")
    steps: list[ViewStep]
    spans: list[tuple[float, int]] = Field(
        description="[t_start, step index] at each change of the running step (-1: none)."
    )
    cycle_time: Annotated[float, Field(ge=0)]


class ViewMark(Strict):
    t: float
    kind: Text
    device: Text
    text: Text


class ViewLabel(Strict):
    node: Text
    text: Text
    kind: Text


class ViewContact(Strict):
    """A contact a probe step recorded: drawn from its instant on."""

    t: float
    feature: Text
    point: tuple[float, float, float] = Field(description="The ball centre [m], world (z up).")


class ViewFile(Strict):
    """The viewer's panel data beside a run's scene (``view.json``, written by ``rworld
    simulate -o``): times, joint values, steps, marks, labels."""

    title: Text
    t: Annotated[list[float], Field(min_length=1)] = Field(description="Instants [s], rising.")
    t_end: Annotated[float, Field(ge=0)]
    devices: dict[Text, ViewDevice]
    marks: list[ViewMark]
    without_geometry: list[Text]
    labels: list[ViewLabel]
    contacts: list[ViewContact] = Field(
        default_factory=list, description="Recorded probe contacts, in time order."
    )

    @model_validator(mode="after")
    def _consistent(self):
        if any(b < a for a, b in zip(self.t, self.t[1:])):
            raise ValueError("'t' goes back in time")
        if self.t_end < self.t[-1] - 1e-6:  # the instants are written to 1 us
            raise ValueError(f"t_end {self.t_end} is before the last instant {self.t[-1]}")
        for name, device in self.devices.items():
            for j, row in enumerate(device.q):
                if len(row) != len(self.t):
                    raise ValueError(
                        f"device '{name}' joint {j + 1} has {len(row)} values for "
                        f"{len(self.t)} instants"
                    )
            for start, step in device.spans:
                if not -1 <= step < len(device.steps):
                    raise ValueError(f"device '{name}' has a span of step {step}, not one of its")
        return self


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
    where = paths[VIEW_FILE]
    try:
        text = where.read_text("utf-8")
        json.loads(text, parse_constant=_no_constant)  # positions for syntax errors
        ViewFile.model_validate_json(text)
    except UnicodeDecodeError as exc:
        raise UserError(f"{where}: not UTF-8 text ({exc.reason})") from None
    except json.JSONDecodeError as exc:
        raise UserError(f"{where}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}") from None
    except RecursionError:
        raise UserError(f"{where}: not the viewer's data: it nests too deep") from None
    except ValidationError as exc:
        first = exc.errors()[0]
        at = ".".join(str(p) for p in first["loc"]) or "(root)"
        more = f" (and {exc.error_count() - 1} more)" if exc.error_count() > 1 else ""
        raise UserError(
            f"{where}: not the viewer's data (schemas/view.schema.json): {at}: {first['msg']}{more}"
        ) from None
    info = json.loads(text)
    # the two files of one run: the devices and labels of the panel are nodes of the scene
    devices = {
        node.get("name")
        for node in gltf["nodes"]
        if isinstance(node.get("extras"), dict) and node["extras"].get("kind") == "device"
    }
    names = {node.get("name") for node in gltf["nodes"]}
    if set(info["devices"]) != devices:
        raise UserError(
            f"{where}: its devices ({', '.join(sorted(info['devices'])) or 'none'}) are not the "
            f"scene's ({', '.join(sorted(devices)) or 'none'}): the two files are not of one run"
        )
    missing = sorted({label["node"] for label in info["labels"]} - names)
    if missing:
        raise UserError(f"{where}: labels name nodes the scene lacks: {', '.join(missing[:5])}")
    return glb, info


def _no_constant(name: str):
    raise json.JSONDecodeError(f"{name} is not a JSON number", name, 0)
