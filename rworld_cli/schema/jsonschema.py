"""JSON Schemas of every file format, generated from the pydantic models (editor completion, CI)."""

from __future__ import annotations

import functools
import importlib
import json

SCHEMA_FILES = {
    "cell.schema.json": ("models", "CellFile"),
    "poses.schema.json": ("models", "PoseFile"),
    "program.schema.json": ("program", "ProgramFile"),
    "run.schema.json": ("program", "RunFile"),
    "path.schema.json": ("program", "PathFile"),
    "measurements.schema.json": ("measurements", "MeasurementFile"),
    "robot-observations.schema.json": ("robotobs", "ObservationFile"),
    "captures.schema.json": ("captures", "CaptureFile"),
    "view.schema.json": ("results", "ViewFile"),
}


def schema_documents() -> dict[str, str]:
    """The JSON Schema text of each file format, keyed by file name."""
    return dict(_documents())


@functools.cache
def _documents() -> dict[str, str]:
    """:func:`schema_documents`, made once a process (0.2 s: pydantic builds each schema;
    the models do not change while it runs)."""
    out = {}
    for filename, (module, model_name) in SCHEMA_FILES.items():
        model = getattr(importlib.import_module(f"{__package__}.{module}"), model_name)
        doc = {
            "$schema": "https://json-schema.org/draft/2020-12/schema",
            "$id": f"rworld/{filename}",
        }
        doc.update(model.model_json_schema(mode="validation"))
        out[filename] = json.dumps(doc, indent=2, ensure_ascii=False) + "\n"
    return out
