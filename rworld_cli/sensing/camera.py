"""A camera's reading: where each calibration board's corners and each point feature fall in
its image, and which of them it sees - in front of the lens, inside the image (within the
distortion's one-to-one range), not hidden by any body of the cell on the line of sight
(``docs/vision.md``)."""

from __future__ import annotations

import numpy as np

from .. import spatial
from ..geometry import (
    shape_mesh,
    sight_cone,
    sight_lines_hit_triangles,
    spheres_in_sight,
    triangle_spheres,
)
from ..vision.camera import project, transform_points, visible
from .readings import SensorReading


def _targets(world) -> list[tuple[str, str, str, np.ndarray]]:
    """(kind, name, owner, points in world (M, 3)) for every board and point feature."""
    cell = world.cell
    out = []
    for name, obj in cell.objects.items():
        if obj.board is not None:
            points = transform_points(world.T_world(name), obj.board.points)
            out.append(("boards", name, name, points))
    for name, feature in cell.features.items():
        if feature.kind == "point":
            T = world.T_world(feature.owner)
            out.append(
                ("points", name, feature.owner, (T[:3, :3] @ feature.point + T[:3, 3])[None])
            )
    return out


_SIGHT: dict[int, tuple] = {}  # id(shape) -> (shape, its sight data): a cell's shapes, read once


def _sight_data(shape) -> tuple:
    """A shape's mesh in its owner's frame, each triangle's bounding sphere and the whole
    mesh's (centre, radius) [m] - computed once a shape (the camera reading culls with them at
    every sample of a plan)."""
    got = _SIGHT.get(id(shape))
    if got is not None and got[0] is shape:
        return got[1]
    mesh = shape_mesh(shape)
    centres, radii = triangle_spheres(mesh.triangles())
    middle = 0.5 * (mesh.vertices.min(axis=0) + mesh.vertices.max(axis=0))
    radius = float(np.linalg.norm(mesh.vertices - middle, axis=1).max(initial=0.0))
    if len(_SIGHT) > 4096:  # shapes of cells long gone
        _SIGHT.clear()
    _SIGHT[id(shape)] = (shape, (mesh, centres, radii, middle, radius))
    return _SIGHT[id(shape)][1]


def camera_reading(world, name: str, sensor, bodies) -> SensorReading:
    """The reading of camera sensor ``name`` in the world's current state.

    Parameters
    ----------
    bodies : list of Body
        The cell's sensable shapes in world (``sensors.sensable_bodies``): what may hide a
        point; a board or a feature is not hidden by its own owner.
    """
    camera = sensor.camera
    T_world_camera = world.T_world(name)
    T_camera_world = spatial.invert_transform(T_world_camera)
    origin = T_world_camera[:3, 3]
    meshes = {b.label: (b.owner, _sight_data(b.shape), b.T_world_owner) for b in bodies}
    image: dict = {"resolution": [camera.width, camera.height], "boards": {}, "points": {}}
    seen_any: list[str] = []
    for kind, target, owner, points in _targets(world):
        pc = transform_points(T_camera_world, points)
        uv = project(camera.intrinsics, pc)
        behind = pc[:, 2] <= 0
        inside = visible(camera, pc)
        seen = inside.copy()
        hidden: dict[str, int] = {}
        idx = None  # the sight lines still clear and their cone, made again when one is hidden
        for label, (body_owner, sight, T) in meshes.items():
            if body_owner == owner or not seen.any():
                continue
            if idx is None:
                idx = np.nonzero(seen)[0]
                cone = sight_cone(origin, points[idx])
            mesh, centres, radii, middle, radius = sight
            if cone is not None:  # the body's sphere first, then its triangles'
                if not spheres_in_sight(origin, cone, T[:3, :3] @ middle + T[:3, 3], radius)[0]:
                    continue
                kept = spheres_in_sight(origin, cone, centres @ T[:3, :3].T + T[:3, 3], radii)
                faces = mesh.faces[kept]
            else:
                faces = mesh.faces
            if not len(faces):
                continue
            near = (mesh.vertices @ T[:3, :3].T + T[:3, 3])[faces]
            hit = sight_lines_hit_triangles(origin, points[idx], near)
            if hit.any():
                hidden[label] = int(hit.sum())
                seen[idx[hit]] = False
                idx = None
        if kind == "boards" and seen.any():  # the pattern is on the -z face: seen from -z
            T_board_world = spatial.invert_transform(world.T_world(target))
            if (T_board_world[:3, :3] @ origin + T_board_world[:3, 3])[2] >= 0:
                hidden[f"{target} (seen from its back)"] = int(seen.sum())
                seen[:] = False
        pixels = [[float(u), float(v)] if ok else None for (u, v), ok in zip(uv, seen, strict=True)]
        image[kind][target] = {
            "pixels": pixels,
            "seen": int(seen.sum()),
            "total": len(points),
            "behind": int(behind.sum()),
            "outside": int((~behind & ~inside).sum()),
            "hidden_by": hidden,
        }
        if seen.any():
            seen_any.append(target)
    return SensorReading(name, "camera", bool(seen_any), seen_any, value=len(seen_any), image=image)
