"""A camera's reading: where each calibration board's corners and each point feature fall in
its image, and which of them it sees - in front of the lens, inside the image (within the
distortion's one-to-one range), not hidden by any body of the cell on the line of sight
(``docs/vision.md``)."""

from __future__ import annotations

import numpy as np

from .. import spatial
from ..geometry import segments_hit_triangles, shape_mesh, triangles_in_sight
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
    meshes = {b.label: (b.owner, shape_mesh(b.shape).triangles(b.T_world_owner)) for b in bodies}
    image: dict = {"resolution": [camera.width, camera.height], "boards": {}, "points": {}}
    seen_any: list[str] = []
    for kind, target, owner, points in _targets(world):
        pc = transform_points(T_camera_world, points)
        uv = project(camera.intrinsics, pc)
        behind = pc[:, 2] <= 0
        inside = visible(camera, pc)
        seen = inside.copy()
        hidden: dict[str, int] = {}
        for label, (body_owner, triangles) in meshes.items():
            if body_owner == owner or not seen.any():
                continue
            idx = np.nonzero(seen)[0]
            near = triangles[triangles_in_sight(origin, points[idx], triangles)]
            if not len(near):
                continue
            hit = segments_hit_triangles(np.broadcast_to(origin, (len(idx), 3)), points[idx], near)
            if hit.any():
                hidden[label] = int(hit.sum())
                seen[idx[hit]] = False
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
