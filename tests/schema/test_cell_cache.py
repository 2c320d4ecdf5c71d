"""Loaded cells kept on disk (``schema/cellcache.py``): an unchanged cell loads again without
pydantic or YAML and gives the same model and warnings; a changed byte in the cell, a pose file
or a mesh loads it afresh; bad input is never kept; a damaged entry is a miss."""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import shutil
import subprocess
import sys

import numpy as np
import pytest

from rworld_cli import cache as kept_entries
from rworld_cli.errors import UserError
from rworld_cli.schema import cellcache
from rworld_cli.schema.loader import load_cell
from tests.conftest import WORKCELLS

PROBE = """
import json, sys
from rworld_cli.schema.loader import load_cell
loaded = load_cell(sys.argv[1])
cell = loaded.cell
print(json.dumps({
    "pydantic": "pydantic" in sys.modules, "yaml": "yaml" in sys.modules,
    "warnings": [str(w) for w in loaded.warnings],
    "poses": {k: v.tolist() for k, v in sorted(cell.poses.items())},
}))
"""


def _load(cell, cache, **env) -> dict:
    run_env = os.environ | {"RWORLD_CACHE_DIR": str(cache)} | env
    out = subprocess.run(
        [sys.executable, "-c", PROBE, str(cell)], env=run_env, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_an_unchanged_cell_loads_without_pydantic_and_the_same(tmp_path):
    cell = tmp_path / "puma560"
    shutil.copytree(WORKCELLS / "puma560", cell)
    cache = tmp_path / "cache"
    first = _load(cell, cache)
    assert first["pydantic"] and first["yaml"] and first["warnings"]  # the Puma's two
    assert len(list((cache / "cells").glob("*.pickle"))) == 1
    second = _load(cell, cache)
    assert not second["pydantic"] and not second["yaml"]
    assert second["warnings"] == first["warnings"] and second["poses"] == first["poses"]
    # switched off: checked afresh
    off = _load(cell, cache, RWORLD_CELL_CACHE="0")
    assert off["pydantic"] and off["poses"] == first["poses"]


def _entry_count(cache) -> int:
    return len(list((cache / "cells").glob("*.pickle")))


def test_a_changed_pose_file_or_mesh_loads_afresh(tmp_path, monkeypatch):
    monkeypatch.setenv("RWORLD_CACHE_DIR", str(tmp_path / "cache"))
    cell = tmp_path / "panda"
    shutil.copytree(WORKCELLS / "panda", cell)
    first = load_cell(cell).cell
    kept = load_cell(cell).cell
    assert kept is not first and set(kept.poses) == set(first.poses)
    for name, T in first.poses.items():
        np.testing.assert_array_equal(kept.poses[name], T)
    # a pose file is read again when its bytes change: the new number is seen
    poses = cell / "poses.yaml"
    text = poses.read_text()
    assert "  panda:\n    xyz: [0.0, 0.0, 0.0]\n" in text
    poses.write_text(
        text.replace("  panda:\n    xyz: [0.0, 0.0, 0.0]\n", "  panda:\n    xyz: [0, 0, 0.25]\n")
    )
    moved = load_cell(cell).cell
    assert moved.poses["panda"][2, 3] == pytest.approx(0.25)
    # a mesh too: its facts are part of the model (a scaled copy of a link mesh)
    mesh = next((cell / "meshes").rglob("*.stl"))
    data = mesh.read_bytes()
    mesh.write_bytes(b"changed".ljust(80) + data[80:])  # the same triangles, other bytes
    load_cell(cell)  # a miss: loaded afresh, and the entry now holds the new bytes' digest
    (entry,) = (tmp_path / "cache" / "cells").glob("*.pickle")
    read = dict(pickle.loads(kept_entries.read("cells", entry.name))["read"])
    assert read[str(mesh.resolve())] == hashlib.sha256(mesh.read_bytes()).hexdigest()
    assert read[str(poses.resolve())] == hashlib.sha256(poses.read_bytes()).hexdigest()


def test_bad_input_is_never_kept_and_a_damaged_entry_is_a_miss(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("RWORLD_CACHE_DIR", str(cache))
    cell = tmp_path / "puma560"
    shutil.copytree(WORKCELLS / "puma560", cell)
    text = (cell / "cell.yaml").read_text()
    (cell / "cell.yaml").write_text(text.replace("mass: 17.4", "mass: -17.4"))
    for _ in range(2):
        with pytest.raises(UserError) as err:
            load_cell(cell)
        assert any("mass" in i.message or "mass" in i.location for i in err.value.issues)
    assert _entry_count(cache) == 0
    (cell / "cell.yaml").write_text(text)
    good = load_cell(cell).cell
    (entry,) = (cache / "cells").glob("*.pickle")
    entry.write_bytes(b"not a pickle")
    again = load_cell(cell).cell  # loaded afresh, and kept again
    assert set(again.devices) == set(good.devices)
    assert pickle.loads(kept_entries.read("cells", entry.name))["loaded"].cell.name == good.name
    # an entry naming a file that is gone is a miss, not an error
    data = pickle.loads(kept_entries.read("cells", entry.name))
    data["read"].append((str(tmp_path / "gone.yaml"), "0" * 64))
    kept_entries.write("cells", entry.name, pickle.dumps(data))
    from rworld_cli.schema.loader import resolve_cell_path

    assert cellcache.lookup(cellcache.entry(*resolve_cell_path(cell), None)) is None
    assert load_cell(cell).cell.name == good.name


def test_the_folder_keeps_the_most_recently_used_entries(tmp_path, monkeypatch):
    from rworld_cli.schema.loader import resolve_cell_path

    monkeypatch.setenv("RWORLD_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(cellcache, "MAX_ENTRIES", 2)
    cells, entries = [], []
    for k in range(3):
        cell = tmp_path / f"cell{k}"
        shutil.copytree(WORKCELLS / "puma560", cell)
        cells.append(cell)
        name, _ = cellcache.entry(*resolve_cell_path(cell), None)
        entries.append(tmp_path / "cache" / "cells" / name)
    load_cell(cells[0])
    load_cell(cells[1])
    os.utime(entries[0], ns=(1, 1))  # the first long unused, the second less long
    os.utime(entries[1], ns=(2, 2))
    load_cell(cells[0])  # used again now
    load_cell(cells[2])  # a third entry: the least recently used (the second) goes
    assert entries[0].exists() and entries[2].exists() and not entries[1].exists()


def _table_x(loaded) -> float:
    from rworld_cli.world.tree import World

    return float(World(loaded.cell).T_world("table")[0, 3])


def test_a_file_rewritten_while_the_cell_loads_is_never_kept_as_the_new_bytes(
    tmp_path, monkeypatch
):
    """The outside report's race (issue 58): a pose file saved while a command loads the cell
    stored the model of the old bytes under the new bytes' digest; every later command used
    poses 100 mm out.  Each file's digest is now taken when it is read."""
    monkeypatch.setenv("RWORLD_CACHE_DIR", str(tmp_path / "cache"))
    cell = tmp_path / "cell"
    shutil.copytree(WORKCELLS / "puma560", cell)
    poses = cell / "poses.yaml"
    new = poses.read_text().replace("[0.7, 0, 0.4]", "[0.8, 0, 0.4]")
    store = cellcache.store

    def save_in_the_window(*args):  # the editor saves after the load read the file
        poses.write_text(new)
        store(*args)

    monkeypatch.setattr(cellcache, "store", save_in_the_window)
    assert _table_x(load_cell(cell)) == pytest.approx(0.7)  # this load read the old bytes
    monkeypatch.setattr(cellcache, "store", store)
    assert _table_x(load_cell(cell)) == pytest.approx(0.8)  # never the old model
    assert _table_x(load_cell(cell)) == pytest.approx(0.8)  # now from the cache
    # the cell file itself changed between naming the entry and parsing it
    text = (cell / "cell.yaml").read_text()
    entry = cellcache.entry

    def edit_after_naming(*args):
        key = entry(*args)
        (cell / "cell.yaml").write_text(text.replace("mass: 17.4", "mass: 18.4"))
        return key

    monkeypatch.setattr(cellcache, "entry", edit_after_naming)
    load_cell(cell)
    monkeypatch.setattr(cellcache, "entry", entry)
    (cell / "cell.yaml").write_text(text)  # back to the bytes the entry was named by
    masses = [link.inertial.mass for d in load_cell(cell).cell.devices.values() for link in d.links]
    assert 17.4 in masses and 18.4 not in masses


def test_fifty_rounds_of_the_race_load_nothing_stale(tmp_path, monkeypatch):
    import threading

    from rworld_cli.fileio import atomic_write_text

    monkeypatch.setenv("RWORLD_CACHE_DIR", str(tmp_path / "cache"))
    cell = tmp_path / "cell"
    shutil.copytree(WORKCELLS / "puma560", cell)
    poses = cell / "poses.yaml"
    texts = {x: poses.read_text().replace("[0.7, 0, 0.4]", f"[{x}, 0, 0.4]") for x in (0.7, 0.8)}
    rng = np.random.default_rng(58)
    stale = 0
    for _ in range(50):
        stop = threading.Event()

        def flip():
            k = 0
            while not stop.is_set():  # saved as editors and calibrate -o save: by rename
                atomic_write_text(poses, texts[(0.7, 0.8)[k % 2]])
                k += 1

        writer = threading.Thread(target=flip)
        writer.start()
        load_cell(cell)  # races the writer
        stop.set()
        writer.join()
        final = float(rng.choice([0.7, 0.8]))
        poses.write_text(texts[final])
        stale += abs(_table_x(load_cell(cell)) - final) > 1e-12
    assert stale == 0
