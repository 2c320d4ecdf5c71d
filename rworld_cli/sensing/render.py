"""Draw a cell: PNG (matplotlib, headless) or glTF binary (.glb, trimesh) for any 3D viewer.

Objects, device bases and links as their polyhedral models; sensors as
their boxes split into cells, each cell red when it senses something and
green when free (the report's Fig. 13); auxiliary frames and TCPs as small
x-y-z triads (red, green, blue).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..geometry import shape_mesh
from .sensors import read_sensors, sensable_bodies
from .types import sensor_type

COLORS = {
    "object": "#9aa5b1",
    "device": "#4c78a8",
    "contact": "#d62728",
    "free": "#3a9d5d",
    "colliding": "#ff7f0e",  # bodies in a collision (rworld render --run)
}


def cell_boxes(sensor, reading):
    """(T_sensor_cell, size, sensed) for every cell of a sensor."""
    kind = sensor_type(sensor.type)
    counts = kind.counts(sensor)
    d = sensor.size / np.array(counts)
    lo = sensor.box.T_owner_box[:3, 3] - sensor.size / 2
    grid = kind.cell_grid(reading)
    out = []
    for idx in np.ndindex(*counts):
        T = np.eye(4)
        T[:3, 3] = lo + (np.array(idx) + 0.5) * d
        out.append((T, d, bool(grid[idx])))
    return out


def _scene_meshes(world, tolerance, highlight=()):
    """(name, vertices (V, 3) world, faces, colour) of everything to draw; bodies named in
    ``highlight`` in the collision colour."""
    import trimesh

    items = []
    for body in sensable_bodies(world):
        mesh = shape_mesh(body.shape)
        v = mesh.vertices @ body.T_world_owner[:3, :3].T + body.T_world_owner[:3, 3]
        kind = world.cell.primitive_kind(body.owner)
        colour = COLORS["device" if kind == "device" else "object"]
        items.append(
            (body.label, v, mesh.faces, COLORS["colliding"] if body.label in highlight else colour)
        )
    readings = {r.sensor: r for r in read_sensors(world, tolerance=tolerance)}
    for name, sensor in world.cell.sensors.items():
        T_ws = world.T_world(name)
        for k, (T, size, sensed) in enumerate(cell_boxes(sensor, readings[name])):
            box = trimesh.creation.box(extents=size * 0.96)  # a small gap shows the cells apart
            T_world = T_ws @ T
            v = np.asarray(box.vertices) @ T_world[:3, :3].T + T_world[:3, 3]
            items.append(
                (f"{name}[{k}]", v, np.asarray(box.faces), COLORS["contact" if sensed else "free"])
            )
    return items, readings


def render_png(
    world,
    path: str | Path,
    tolerance: float,
    view: tuple[float, float] = (25.0, -60.0),
    triads: bool = True,
    highlight: tuple[str, ...] = (),
    title: str | None = None,
    marks: list | None = None,
) -> Path:
    """A 3D picture of the cell in its current state (``highlight``: bodies drawn in the
    collision colour; ``marks``: world points [m] drawn as red dots, e.g. contact points)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    items, readings = _scene_meshes(world, tolerance, highlight)
    fig = plt.figure(figsize=(10, 8), constrained_layout=True)
    ax = fig.add_subplot(projection="3d")
    all_v = []
    for name, v, f, color in items:
        alpha = 0.95 if "[" in name else (0.5 if name in highlight else 0.35)
        ax.add_collection3d(
            Poly3DCollection(
                v[f], facecolor=color, edgecolor=(0, 0, 0, 0.08), linewidths=0.2, alpha=alpha
            )
        )
        all_v.append(v)
    for point in marks or []:
        ax.scatter(*np.asarray(point, dtype=float), color="red", s=60, depthshade=False, zorder=10)
    if triads:
        scale = 0.05
        for frame, decl in world.cell.frames.items():
            if decl.kind in ("auxiliary", "tcp", "free"):
                T = world.T_world(frame)
                for axis, color in zip(range(3), ("red", "green", "blue")):
                    end = T[:3, 3] + scale * T[:3, axis]
                    ax.plot(*np.stack([T[:3, 3], end]).T, color=color, linewidth=1)
                all_v.append(T[:3, 3][None])
    pts = np.concatenate(all_v)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    center, radius = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(center[0] - radius, center[0] + radius)
    ax.set_ylim(center[1] - radius, center[1] + radius)
    ax.set_zlim(center[2] - radius, center[2] + radius)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(*view)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    sensing = [f"{r.sensor}: {'on' if r.active else 'off'}" for r in readings.values()]
    ax.set_title(
        (title or f"{world.cell.name}") + (f"\nsensors - {', '.join(sensing)}" if sensing else ""),
        fontsize=9,
    )
    from ..fileio import save_figure

    return save_figure(fig, path)


def render_glb(world, path: str | Path, tolerance: float, highlight: tuple[str, ...] = ()) -> Path:
    """The cell as a glTF binary scene, one node per shape and sensor cell, coloured."""
    import trimesh

    items, _ = _scene_meshes(world, tolerance, highlight)
    scene = trimesh.Scene()
    for name, v, f, color in items:
        mesh = trimesh.Trimesh(v, f, process=False)
        rgba = np.array([int(color[i : i + 2], 16) for i in (1, 3, 5)] + [255], dtype=np.uint8)
        mesh.visual.face_colors = np.tile(rgba, (len(f), 1))
        scene.add_geometry(mesh, node_name=name, geom_name=name)
    from ..fileio import atomic_write_bytes

    return atomic_write_bytes(path, scene.export(file_type="glb"))
