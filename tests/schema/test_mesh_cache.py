"""The meshes' facts (oriented box, extents, watertightness) cached on disk beside the compiled
kernels: a meshed cell loads without importing trimesh the second time, with the same model;
a damaged entry is computed again; a changed mesh gets its own entry."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

from tests.conftest import WORKCELLS

PROBE = """
import json, sys
from rworld_cli.schema.loader import load_cell
cell = load_cell(sys.argv[1]).cell
shapes = {b: l.shape for d in cell.devices.values() for b, l in zip(d.link_frames, d.links)
          if l.shape is not None}
print(json.dumps({"trimesh": "trimesh" in sys.modules,
                  "boxes": {k: s.bounding_box.half_extents.tolist() for k, s in shapes.items()}}))
"""


def _load(cell, cache) -> dict:
    # the meshes' own cache: the whole loaded cell's (schema.cellcache) would skip them
    env = os.environ | {"RWORLD_CACHE_DIR": str(cache), "RWORLD_CELL_CACHE": "0"}
    out = subprocess.run(
        [sys.executable, "-c", PROBE, str(cell)], env=env, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_a_meshed_cell_loads_from_the_cache_without_trimesh(tmp_path):
    cell = tmp_path / "panda"
    shutil.copytree(WORKCELLS / "panda", cell)
    cache = tmp_path / "cache"
    first = _load(cell, cache)
    assert first["trimesh"] and first["boxes"]
    entries = sorted((cache / "meshes").glob("*.json"))
    assert len(entries) >= 7  # the Panda's link meshes
    second = _load(cell, cache)
    assert not second["trimesh"]
    assert second["boxes"] == first["boxes"]
    # a damaged entry is read as missing and written again
    entries[0].write_text("{not json")
    third = _load(cell, cache)
    assert third["boxes"] == first["boxes"]
    from rworld_cli import cache as kept

    os.environ["RWORLD_CACHE_DIR"] = str(cache)
    try:
        assert json.loads(kept.read("meshes", entries[0].name))["extents"]
    finally:
        del os.environ["RWORLD_CACHE_DIR"]
    # the key is the file's content, not its name or time: a changed file is a new entry
    mesh = next((cell / "meshes").rglob("*.stl"))
    before = set((cache / "meshes").glob("*.json"))
    data = mesh.read_bytes()
    assert not data.startswith(b"solid")  # binary STL: the 80-byte header is free text
    mesh.write_bytes(b"changed".ljust(80) + data[80:])
    again = _load(cell, cache)
    after = set((cache / "meshes").glob("*.json"))
    assert len(after - before) == 1
    assert again["boxes"] == first["boxes"]  # the same triangles
