"""Sensor readings by interference checking (the report's section 7).

Each sensor type (``types/``: touch, tactile, proximity, presence, force)
splits its box into cells; here every cell is checked for interference with
every sensable shape, and the type turns the cells into its reading.

What a sensor can sense: the shapes of objects and of devices' links and
bases, except the primitive the sensor is mounted on (a pad does not feel
the finger it sits on, a load cell the table).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import spatial
from ..collision.bodies import ball_body, make_body, pair_distance
from ..geometry import DEFAULT_TOLERANCE, grid_interference, obb_overlap, shape_mesh
from ..model.cell import WORLD
from .readings import SensorReading
from .types import sensor_type


@dataclass
class Body:
    """A sensable shape in world: who owns it, its mesh, its bounding box."""

    owner: str  # primitive name
    label: str  # object name, or device.link
    T_world_owner: np.ndarray
    shape: object  # model.cell.Shape


def _sensable(cell) -> list[tuple[str, str, object]]:
    """Every shape of the cell as (owner primitive, frame: the label, shape)."""
    out = []
    for name, obj in cell.objects.items():
        if obj.shape is not None:
            out.append((name, name, obj.shape))
    for name, dev in cell.devices.items():
        if dev.shape is not None:
            out.append((name, name, dev.shape))
        for link, frame in zip(dev.links, dev.link_frames):
            if link.shape is not None:
                out.append((name, frame, link.shape))
    return out


def sensable_bodies(world) -> list[Body]:
    """Every shape in the world with its owner and world pose."""
    return [
        Body(owner, frame, world.T_world(frame), shape)
        for owner, frame, shape in _sensable(world.cell)
    ]


MAY_TOUCH = 1e-7  # m: a ball farther than this from every shape (by the collision room's
# distances, exact to about 1e-12 m, or below the exact ones for a mesh's hulls) touches none


def ball_may_touch(world, name: str, joints: dict[str, np.ndarray]) -> np.ndarray:
    """Whether ball sensor ``name`` may touch anything at each of N joint states, all states
    at once: its ball reaches some sensable shape's bounding box (:func:`_near_ball`) and
    comes within :data:`MAY_TOUCH` of the shape (the collision room's batched distances).

    Where this is False, :func:`read_sensors` reads the sensor inactive, so a guarded move
    reads only the other states.

    Parameters
    ----------
    world : World
        Its current affixments; the devices not in ``joints`` where they are.
    name : str
        A sensor with a ``ball``.
    joints : dict
        Device name -> joint values (N, n).

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    sensor = world.cell.sensors[name]
    radius = float(sensor.ball)
    mount = _mount_owner(world, name)
    shapes = [(frame, shape) for owner, frame, shape in _sensable(world.cell) if owner != mount]
    frames = world.T_world_frames([name] + [frame for frame, _ in shapes], joints)
    centre = frames[name][:, :3, 3]  # (N, 3)
    T_ball = frames[name].copy()
    T_ball[:, :3, :3] = np.eye(3)
    ball = ball_body("probe ball", radius)
    may = np.zeros(len(centre), dtype=bool)
    for frame, shape in shapes:
        box = shape.bounding_box
        T = frames[frame] @ box.T_owner_box  # (N, 4, 4)
        local = np.abs(np.einsum("nji,nj->ni", T[:, :3, :3], centre - T[:, :3, 3]))
        rows = np.flatnonzero(np.all(local <= box.half_extents + radius, axis=1) & ~may)
        if len(rows):
            res = pair_distance(
                ball,
                _collision_body(frame, shape),
                T_ball[rows],
                frames[frame][rows],
                within=0.0,
                deep_enough=0.0,
            )
            may[rows] |= res.overlap | (res.distance <= MAY_TOUCH)
    return may


def _collision_body(label: str, shape):
    """The collision room's body of a sensable shape, made once per shape (its trees and
    convex parts with it)."""
    cached = shape.__dict__.get("_sensing_body")
    if cached is None:
        cached = make_body(label, label, label, shape)
        object.__setattr__(shape, "_sensing_body", cached)  # a cache, not a field
    return cached


def _mount_owner(world, sensor: str) -> str | None:
    parent = world.parent(sensor)
    if parent is None or parent == WORLD:
        return None
    decl = world.cell.frames[parent]
    return None if decl.kind in ("world", "free") else decl.owner


def read_sensors(
    world, names: list[str] | None = None, tolerance: float = DEFAULT_TOLERANCE
) -> list[SensorReading]:
    """Readings of the named sensors (default all) in the world's current state.

    Parameters
    ----------
    world : World
    names : list of str, optional
    tolerance : float
        Surfaces within this distance of a sensor cell touch it [m].
    """
    cell = world.cell
    names = list(cell.sensors) if names is None else names
    bodies = sensable_bodies(world)
    readings = []
    for name in names:
        sensor = cell.sensors[name]
        if sensor.type == "camera":
            from .camera import camera_reading

            readings.append(camera_reading(world, name, sensor, bodies))
            continue
        T_world_sensor = world.T_world(name)
        mount = _mount_owner(world, name)
        candidates = [b for b in bodies if b.owner != mount]
        kind = sensor_type(sensor.type)
        counts = kind.counts(sensor)
        grid = np.zeros(counts, dtype=bool)
        touched: list[str] = []
        if sensor.ball is not None:
            touched = [b.label for b in ball_contacts(T_world_sensor, sensor.ball, candidates)]
            grid[:] = bool(touched)
        elif candidates:
            box = sensor.box
            Tb = np.stack([b.T_world_owner @ b.shape.bounding_box.T_owner_box for b in candidates])
            hb = np.stack([b.shape.bounding_box.half_extents for b in candidates])
            Ta = np.broadcast_to(T_world_sensor @ box.T_owner_box, Tb.shape)
            ha = np.broadcast_to(box.half_extents, hb.shape)
            near = obb_overlap(
                np.ascontiguousarray(Ta), np.ascontiguousarray(ha), Tb, hb, tolerance
            )
            T_sensor_world = spatial.invert_transform(T_world_sensor)
            for body in (b for b, ok in zip(candidates, near) if ok):
                tri = shape_mesh(body.shape).triangles(T_sensor_world @ body.T_world_owner)
                hit = grid_interference(sensor.size, counts, tri, tolerance)
                if hit.any():
                    grid |= hit
                    if body.label not in touched:
                        touched.append(body.label)

        def overlap(sensor=sensor, T=T_world_sensor, touched=touched, candidates=candidates):
            return overlap_volume(sensor, T, [b for b in candidates if b.label in touched])

        readings.append(kind.reading(name, sensor, grid, touched, overlap))
    return readings


def ball_gaps(centre: np.ndarray, radius: float, bodies: list[Body]) -> np.ndarray:
    """Each body's distance from a ball of ``radius`` [m] at ``centre`` (world) [m]: exact
    (the collision room's sphere distances; a mesh's by point-to-triangle distance and, for a
    closed mesh, the inside test), 0 where the ball touches or overlaps it."""
    from ..collision.bodies import ball_body, make_body, point_triangle_distance
    from ..geometry import winding_number

    ball = ball_body("probe ball", radius)
    T_ball = spatial.make_transform(np.eye(3), centre)[None]
    out = np.empty(len(bodies))
    for k, b in enumerate(bodies):
        if b.shape.kind == "mesh":
            local = (centre - b.T_world_owner[:3, 3]) @ b.T_world_owner[:3, :3]
            tri, lo, hi, lo_all, hi_all = _triangle_boxes(b.shape)
            # the nearest triangle is among those whose box is no farther than the nearest
            # vertex: exact distances on those alone
            below = np.linalg.norm(np.maximum(np.maximum(lo - local, local - hi), 0.0), axis=1)
            above = np.linalg.norm(tri[:, 0] - local, axis=1).min()
            gap = point_triangle_distance(local, tri[below <= above]).min() - radius
            if gap <= 0.0:
                out[k] = 0.0
            else:  # clear of the surface: inside the solid (only within its box), or outside
                inside = (
                    b.shape.closed
                    and bool(np.all((local >= lo_all) & (local <= hi_all)))
                    and winding_number(local[None], tri)[0] > 0.5
                )
                out[k] = 0.0 if inside else gap
        else:
            other = make_body(b.label, b.owner, b.label, b.shape)
            out[k] = pair_distance(ball, other, T_ball, b.T_world_owner[None]).distance[0]
    return out


def _triangle_boxes(shape) -> tuple[np.ndarray, ...]:
    """A shape's triangles (F, 3, 3) in its owner's frame, their bounding boxes' corners (F, 3)
    each, and the whole mesh's box corners (3,) each, computed once per shape (a guarded move
    asks at every clock sample)."""
    cached = shape.__dict__.get("_triangle_boxes")
    if cached is None:
        tri = shape_mesh(shape).triangles()
        lo, hi = tri.min(axis=1), tri.max(axis=1)
        cached = (tri, lo, hi, lo.min(axis=0), hi.max(axis=0))
        object.__setattr__(shape, "_triangle_boxes", cached)  # a cache, not a field
    return cached


def _near_ball(centre: np.ndarray, radius: float, bodies: list[Body]) -> list[Body]:
    """The bodies whose bounding box the ball reaches."""
    near = []
    for b in bodies:
        box = b.shape.bounding_box
        T = b.T_world_owner @ box.T_owner_box
        local = np.abs((centre - T[:3, 3]) @ T[:3, :3])
        if np.all(local <= box.half_extents + radius):
            near.append(b)
    return near


def ball_contacts(T_world_sensor: np.ndarray, radius: float, bodies: list[Body]) -> list[Body]:
    """The bodies a ball tip of ``radius`` [m] centred on the sensor's origin touches or
    overlaps (a gap of 0 counts as contact)."""
    centre = T_world_sensor[:3, 3]
    near = _near_ball(centre, radius, bodies)
    if not near:
        return []
    gaps = ball_gaps(centre, radius, near)
    return [b for b, gap in zip(near, gaps) if gap <= 0.0]


def ball_first_contact(
    start: np.ndarray, end: np.ndarray, radius: float, bodies: list[Body], tolerance: float = 1e-10
) -> tuple[float, list[str]] | None:
    """Where a ball moving straight from ``start`` to ``end`` (world) first touches a body:
    the fraction of the way, and what it touches; None when it touches nothing.

    Conservative advancement: the ball moves by its exact distance to the nearest body, which
    cannot pass through anything (distance is 1-Lipschitz in the centre), until the gap is
    below ``tolerance`` [m].
    """
    length = float(np.linalg.norm(end - start))
    if length == 0.0:
        return None
    direction = (end - start) / length
    travelled = 0.0
    for _ in range(10_000):
        centre = start + travelled * direction
        gaps = ball_gaps(centre, radius, bodies)
        gap = float(gaps.min()) if len(gaps) else np.inf
        if gap <= tolerance:
            return travelled / length, [b.label for b, g in zip(bodies, gaps) if g <= tolerance]
        travelled += gap
        if travelled > length:
            return None
    return None


def overlap_volume(sensor, T_world_sensor: np.ndarray, bodies: list[Body]) -> float:
    """Volume [m^3] of the sensor box that lies inside the bodies (exact boolean intersection,
    manifold3d).
    """
    import manifold3d as m3

    box = m3.Manifold.cube(sensor.size.tolist(), center=True).translate(
        [0.0, 0.0, float(sensor.size[2] / 2)]
    )
    T_sensor_world = spatial.invert_transform(T_world_sensor)
    union = None
    for body in bodies:
        mesh = shape_mesh(body.shape)
        T = T_sensor_world @ body.T_world_owner
        solid = m3.Manifold(
            m3.Mesh(
                vert_properties=np.asarray(mesh.vertices, dtype=np.float32),
                tri_verts=np.asarray(mesh.faces, dtype=np.uint32),
            )
        ).transform(T[:3, :].tolist())
        union = solid if union is None else union + solid
    return float((box ^ union).volume()) if union is not None else 0.0
