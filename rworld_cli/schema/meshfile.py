"""Mesh files (STL, OBJ, PLY, ...) read and checked in one place, for cells and URDFs.

trimesh reads what it can and is lenient with what it cannot: a truncated STL may give no
triangles, a corrupt one NaN corners, and numpy warnings on the way.  Here any of those is a
plain reason the caller reports at its location; a mesh that comes back is usable: triangles,
every corner finite and within 1e6 units (1 km in mm) of its origin.
"""

from __future__ import annotations

import warnings

import numpy as np

LARGEST_COORDINATE = 1e6  # in the file's units (1 km in mm): beyond, a corrupt number


def _stl_problem(file: str) -> str | None:
    """A binary STL's size must be its header's triangle count times 50 bytes plus 84: a
    truncated or padded file is corrupt (trimesh would read what it finds)."""
    import struct
    from pathlib import Path

    path = Path(file)
    if path.suffix.lower() != ".stl":
        return None
    size = path.stat().st_size
    with open(path, "rb") as f:
        head = f.read(84)
        if len(head) < 84:
            return None if head.lstrip().lower().startswith(b"solid") else "the STL is truncated"
        count = struct.unpack("<I", head[80:84])[0]
        if size == 84 + 50 * count:
            return None
        f.seek(0)
        start = f.read(512).lstrip().lower()
    if (
        start.startswith(b"solid")
        and b"facet" in start
        or size < 84 + 50
        and start.startswith(b"solid")
    ):
        return None  # ASCII STL
    return (
        f"the binary STL's header counts {count} triangles ({84 + 50 * count} bytes) but the "
        f"file has {size} bytes: truncated or corrupt"
    )


def read_mesh(file: str):
    """``(trimesh.Trimesh, None)``, or ``(None, why)`` when the file cannot serve as a solid's
    surface."""
    import trimesh  # heavy: only when there are meshes

    try:
        problem = _stl_problem(file)
    except OSError as exc:
        return None, f"cannot read mesh: {exc}"
    if problem:
        return None, problem
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a cast or overflow warning: a corrupt file
            with np.errstate(invalid="raise", over="raise"):
                # unprocessed: processing drops faces with NaN corners, hiding the damage
                mesh = trimesh.load(file, force="mesh", process=False)
    except Exception as exc:  # trimesh (and numpy under it) raise many kinds
        return None, f"cannot read mesh: {exc}"
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        return None, "the mesh file holds no triangles"
    vertices = np.asarray(mesh.vertices, dtype=float)
    if not np.isfinite(vertices).all():
        return None, "the mesh holds corners that are not finite numbers (a corrupt file)"
    if np.abs(vertices).max() > LARGEST_COORDINATE:
        return None, (
            f"the mesh reaches {np.abs(vertices).max():.3g} units from its origin (a corrupt "
            "file, or a unit far too small)"
        )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh.process()  # merged vertices, as every other reader of the file sees it
    return mesh, None
