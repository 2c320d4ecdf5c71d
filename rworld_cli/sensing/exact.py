"""Ground truth for interference: exact overlap volumes of cell boxes and solids (manifold3d,
double precision).
"""

from __future__ import annotations

import manifold3d as m3
import numpy as np
import trimesh


def manifold_of(vertices: np.ndarray, faces: np.ndarray) -> m3.Manifold:
    return m3.Manifold(
        m3.Mesh(
            vert_properties=np.asarray(vertices, np.float32), tri_verts=np.asarray(faces, np.uint32)
        )
    )


def holed_box() -> tuple[np.ndarray, np.ndarray, m3.Manifold]:
    """A 100 x 100 x 60 mm box with a 40 mm through-hole along y: non-convex."""
    solid = m3.Manifold.cube([0.1, 0.1, 0.06], center=True) - m3.Manifold.cylinder(
        0.2, 0.02, 0.02, 48, center=True
    ).rotate([90, 0, 0])
    mesh = solid.to_mesh()
    return (
        np.asarray(mesh.vert_properties[:, :3], float),
        np.asarray(mesh.tri_verts, np.int64),
        solid,
    )


def icosphere() -> tuple[np.ndarray, np.ndarray, m3.Manifold]:
    tm = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
    return np.asarray(tm.vertices), np.asarray(tm.faces), manifold_of(tm.vertices, tm.faces)


def truth_grid(size, counts, solid_in_sensor: m3.Manifold) -> np.ndarray:
    """Cells whose overlap volume with the solid exceeds 1e-12 of the cell's volume."""
    counts = tuple(counts)
    lo = np.array([-size[0] / 2, -size[1] / 2, 0.0])
    d = np.asarray(size, float) / np.array(counts)
    eps = 1e-12 * float(np.prod(d))
    out = np.zeros(counts, dtype=bool)
    for idx in np.ndindex(*counts):
        c = lo + (np.array(idx) + 0.5) * d
        cell = m3.Manifold.cube(d.tolist(), center=True).translate(c.tolist())
        out[idx] = (cell ^ solid_in_sensor).volume() > eps
    return out
