"""A run as a scene to watch: every body's world pose at the run's samples, sensor cells with their
readings over time, collision spans, and what the viewer shows beside the 3D view.

Plain data for the writers: ``schema/gltf.py`` makes it an animated glTF file and
``viewer/page.py`` a self-contained HTML page (docs/viewer.md).

The poses are the simulator's: for each stretch of samples between two affixment changes the
world is restored to the scheduler's snapshot and the frames' poses are computed for all the
stretch's joint states at once (``World.T_world_frames``), so a grasped object follows its
holder from the grasp's sample on, exactly as the events say.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: sensor readings are taken at most this far apart [s] (each reading is an interference
#: check of every sensor cell against every body, about 10 ms on paper_fig9); a reading is
#: also taken at every affixment change and at the last sample
SENSOR_PERIOD = 0.05

AXES_FRAME = 0.05  # triad length of auxiliary frames and TCPs [m]
AXES_BODY = 0.1  # triad length of bodies drawn without geometry [m]
FRUSTUM_DEPTH = 0.25  # how far a camera's field of view is drawn in front of its lens [m]
FRUSTUM_COLOUR = "#e377c2"


@dataclass
class SceneMesh:
    """Triangles in their node's frame [m]; ``colour`` '#rrggbb'."""

    vertices: np.ndarray  # (V, 3)
    faces: np.ndarray  # (F, 3) int
    colour: str


@dataclass
class SceneNode:
    """One frame of the cell, drawn as its mesh and/or axes.

    Attributes
    ----------
    name : str
        The frame's name (unique).
    kind : str
        object | device | link | sensor | frame
    poses : ndarray, shape (K, 4, 4)
        ``T_world_node`` at the scene's times.
    mesh : SceneMesh or None
    axes : float
        Length of an x-y-z triad drawn at the frame [m] (0: none).
    highlight : list of (t0, t1)
        When the node's body is in a collision or clearance violation [s].
    lines : ndarray, shape (L, 2, 3), optional
        Line segments in the node's frame [m]: a camera's field of view
        (:func:`camera_frustum`), drawn in ``line_colour``.
    """

    name: str
    kind: str
    poses: np.ndarray
    mesh: SceneMesh | None = None
    axes: float = 0.0
    highlight: list[tuple[float, float]] = field(default_factory=list)
    lines: np.ndarray | None = None
    line_colour: str = FRUSTUM_COLOUR


def camera_frustum(camera, depth: float = FRUSTUM_DEPTH) -> np.ndarray:
    """A camera's field of view as line segments in its frame (OpenCV's: z along the optical
    axis, x right, y down), shape (8, 2, 3) [m]: the lens to the image's four corners at
    ``depth`` along z, and the rectangle there (the pinhole's, distortion left out)."""
    u = np.array([-0.5, camera.width - 0.5])
    v = np.array([-0.5, camera.height - 0.5])
    x, y = (u - camera.cx) / camera.fx * depth, (v - camera.cy) / camera.fy * depth
    corners = np.array([[x[0], y[0], depth], [x[1], y[0], depth], [x[1], y[1], depth],
                        [x[0], y[1], depth]])  # fmt: skip
    rays = [(np.zeros(3), c) for c in corners]
    rim = [(corners[k], corners[(k + 1) % 4]) for k in range(4)]
    return np.array(rays + rim)


@dataclass
class SensorCells:
    """A sensor's cells (boxes in the sensor frame) and which of them sense, over time.

    Attributes
    ----------
    name : str
        The sensor (its node has the same name).
    boxes : list of (ndarray (4, 4), ndarray (3,))
        ``T_sensor_cell`` and the cell's size [m].
    times : ndarray, shape (M,)
        When the readings were taken [s].
    sensed : ndarray of bool, shape (M, cells)
    """

    name: str
    boxes: list[tuple[np.ndarray, np.ndarray]]
    times: np.ndarray
    sensed: np.ndarray


@dataclass
class RunScene:
    """Everything drawn, and the viewer's side panels (``info``, JSON-ready)."""

    title: str
    times: np.ndarray  # (K,) [s]
    nodes: list[SceneNode]
    sensors: list[SensorCells]
    without_geometry: list[str]
    info: dict


def _frame_nodes(cell) -> list[tuple[str, str, object, float]]:
    """(frame, kind, shape or None, axes length) for everything the scene draws."""
    out = []
    for name, obj in cell.objects.items():
        out.append((name, "object", obj.shape, 0.0 if obj.shape is not None else AXES_BODY))
    for name, dev in cell.devices.items():
        out.append((name, "device", dev.shape, 0.0 if dev.shape is not None else AXES_BODY))
        for link, frame in zip(dev.links, dev.link_frames):
            out.append((frame, "link", link.shape, 0.0 if link.shape is not None else AXES_BODY))
    for name in cell.sensors:
        out.append((name, "sensor", None, 0.0))
    for name, decl in cell.frames.items():
        if decl.kind in ("auxiliary", "tcp", "free"):
            out.append((name, "frame", None, AXES_FRAME))
    return out


def _nodes(cell, poses, highlight=()) -> list[SceneNode]:
    """The scene's nodes: each frame of :func:`_frame_nodes` with its mesh; ``poses(name)``
    gives its (K, 4, 4) world poses; bodies named in ``highlight`` are red for the whole scene
    (one state)."""
    from ..geometry import shape_mesh
    from ..sensing.render import COLORS

    nodes = []
    objects = [name for name, kind, shape, _ in _frame_nodes(cell) if kind == "object"]
    for name, kind, shape, axes in _frame_nodes(cell):
        mesh = None
        if shape is not None:
            raw = shape_mesh(shape)
            colour = (
                COLORS["device"]
                if kind in ("device", "link")
                else OBJECT_COLOURS[objects.index(name) % len(OBJECT_COLOURS)]
                if name in objects
                else COLORS["object"]
            )
            mesh = SceneMesh(
                np.asarray(raw.vertices, dtype=float),
                np.asarray(raw.faces, dtype=np.int64),
                colour,
            )
        spans = [(0.0, 1.0)] if name in highlight else []
        sensor = cell.sensors.get(name) if kind == "sensor" else None
        lines = camera_frustum(sensor.camera) if sensor is not None and sensor.camera else None
        nodes.append(SceneNode(name, kind, poses(name), mesh, axes, spans, lines))
    return nodes


# each object its own colour (a part is not the table it lies on), in the cell's order; muted,
# so that the device's blue and the contact and collision colours stand out
OBJECT_COLOURS = (
    "#9aa5b1",
    "#c9a66b",
    "#8fb996",
    "#b48ead",
    "#d08770",
    "#88c0d0",
    "#a3be8c",
    "#ebcb8b",
)


def _without_geometry(nodes: list[SceneNode]) -> list[str]:
    return [n.name for n in nodes if n.kind in ("object", "device", "link") and n.mesh is None]


def _read_cells(world) -> dict[str, tuple[list, list[bool]]]:
    """Per sensor, in the world's current state: its cells' boxes ``(T_sensor_cell, size)``
    and which of them sense."""
    from ..sensing.render import cell_boxes
    from ..sensing.sensors import read_sensors
    from ..units import SENSING_TOLERANCE

    out = {}
    for reading in read_sensors(world, tolerance=SENSING_TOLERANCE):
        cells = cell_boxes(world.cell.sensors[reading.sensor], reading)
        out[reading.sensor] = ([(T, size) for T, size, _ in cells], [on for *_, on in cells])
    return out


def _stretches(snapshots, times: np.ndarray):
    """(snapshot, first sample, end sample) for each stretch of one tree, as the engine splits
    them (a sample at a snapshot's instant belongs to it)."""
    K = len(times)
    bounds = [int(np.searchsorted(times, t, side="left")) for t, _ in snapshots[1:]] + [K]
    starts = [0] + bounds[:-1]
    return [(snap, a, b) for (_, snap), a, b in zip(snapshots, starts, bounds) if b > a]


def run_scene(cell, result, sensor_period: float = SENSOR_PERIOD, progress=None) -> RunScene:
    """The scene of a simulated run.

    Parameters
    ----------
    cell : CellModel
        The cell the run was simulated on.
    result : SimulationResult
        With its snapshots (``simulate`` keeps them).
    sensor_period : float
        Longest time between two sensor readings [s].
    progress : callable(done, total, what), optional
    """
    from ..world.tree import World

    times = np.asarray(result.times, dtype=float)
    K = len(times)
    joints = {}
    for d, dev in cell.devices.items():
        tl = result.devices.get(d)
        joints[d] = tl.q if tl is not None else np.tile(dev.home, (K, 1))
    world = World(cell)
    names = [name for name, *_ in _frame_nodes(cell)]
    poses = {name: np.empty((K, 4, 4)) for name in names}
    stretches = _stretches(result.snapshots, times)
    for snap, a, b in stretches:
        world.restore(snap)
        frames = world.T_world_frames(names, {d: q[a:b] for d, q in joints.items()})
        for name in names:
            poses[name][a:b] = frames[name]
    nodes = _nodes(cell, poses.__getitem__)
    _highlight(nodes, result)
    sensors = _sensor_readings(world, result, joints, stretches, sensor_period, progress)
    world.restore(result.snapshots[-1][1])
    without = _without_geometry(nodes)
    info = viewer_info(result, without, _labels(cell))
    return RunScene(info["title"], times, nodes, sensors, without, info)


def state_scene(world, title: str, highlight: tuple[str, ...] = ()) -> RunScene:
    """The scene of one state of a world (``rworld render --html``): one sample at t = 0;
    the bodies named in ``highlight`` drawn in the collision colour."""
    cell = world.cell
    nodes = _nodes(cell, lambda name: world.T_world(name)[None], highlight)
    sensors = [
        SensorCells(name, boxes, np.zeros(1), np.array([sensed]))
        for name, (boxes, sensed) in _read_cells(world).items()
    ]
    without = _without_geometry(nodes)
    info = {
        "title": title,
        "t_end": 0.0,
        "devices": {},
        "marks": [],
        "without_geometry": without,
        "labels": _labels(cell),
    }
    return RunScene(title, np.zeros(1), nodes, sensors, without, info)


def _highlight(nodes: list[SceneNode], result) -> None:
    """Collision and clearance spans onto the bodies' nodes (a span of one sample is shown for
    one clock step)."""
    report = result.collisions
    if report is None:
        return
    by_name = {n.name: n for n in nodes}
    for rc in report.contacts:
        c = rc.contact
        for label in (c.a, c.b):
            node = by_name.get(label)
            if node is not None and node.mesh is not None:
                node.highlight.append((c.t_start, max(c.t_end, c.t_start + result.dt)))


def _sensor_readings(world, result, joints, stretches, period, progress):
    """Every sensor's cells, read at samples at most ``period`` apart (and at each stretch's
    first and last sample)."""
    if not world.cell.sensors:
        return []
    every = max(1, int(round(period / result.dt)))
    picks = []
    for snap, a, b in stretches:
        picks += [(snap, k) for k in sorted(set(range(a, b, every)) | {b - 1})]
    readings = []
    for done, (snap, k) in enumerate(picks):
        world.restore(snap)
        for d, q in joints.items():
            world.set_joints(d, q[k])
        readings.append(_read_cells(world))
        if progress:
            progress(done + 1, len(picks), "sensor readings")
    when = np.array([float(result.times[k]) for _, k in picks])
    return [
        SensorCells(
            name, boxes, when, np.array([reading[name][1] for reading in readings], dtype=bool)
        )
        for name, (boxes, _) in readings[0].items()
    ]


def _labels(cell) -> list[dict]:
    """What the label toggle names: devices (at their base) and auxiliary frames and TCPs."""
    labels = [{"node": d, "text": d, "kind": "device"} for d in cell.devices]
    labels += [
        {"node": name, "text": name, "kind": "frame"}
        for name, decl in cell.frames.items()
        if decl.kind in ("auxiliary", "tcp", "free")
    ]
    return labels


def _spans(step: np.ndarray, times: np.ndarray) -> list[list]:
    """[t_start, step index] at every change of the running step (index -1: none)."""
    change = np.flatnonzero(np.diff(step)) + 1
    starts = np.concatenate([[0], change]) if len(step) else np.zeros(0, dtype=int)
    return [[round(float(times[k]), 6), int(step[k])] for k in starts]


def viewer_info(result, without_geometry: list[str], labels: list[dict]) -> dict:
    """What the viewer shows beside the 3D view (JSON-ready): per device its joint values, its
    steps with their ``file:line``, the timeline's marks, and the labels (:func:`_labels`)."""
    times = np.asarray(result.times, dtype=float)
    devices = {}
    for d, tl in result.devices.items():
        devices[d] = {
            "q": np.round(tl.q, 6).T.tolist(),  # per joint, for the plots
            "steps": [
                {"text": text, "where": where}
                for text, where in zip(result.step_texts[d], result.step_where.get(d, []))
            ],
            "spans": _spans(tl.step, times),
            "cycle_time": tl.cycle_time,
        }
    marks = []
    for e in result.events:
        marks.append(
            {
                "t": e.t,
                "kind": e.kind,
                "device": e.device,
                "text": f"{e.device}: {e.kind}: {e.detail}",
            }
        )
    for v in result.violations:
        marks.append(
            {"t": v.t_start, "kind": "violation", "device": v.device, "text": v.describe()}
        )
    report = result.collisions
    if report is not None:
        for rc in report.contacts:
            c = rc.contact
            marks.append(
                {
                    "t": c.t_start,
                    "kind": "collision" if c.collision else "clearance",
                    "device": rc.steps[0].device if rc.steps else "",
                    "text": rc.describe().split(";")[0],
                }
            )
        for h in report.handling:
            marks.append(
                {
                    "t": h.t,
                    "kind": "collision",
                    "device": h.step.device if h.step else "",
                    "text": h.describe().split(";")[0],
                }
            )
    marks.sort(key=lambda m: m["t"])
    contacts = [
        {
            "t": e.t,
            "feature": str(e.reading["feature"]),
            "point": [round(float(x), 7) for x in e.reading["point"]],
        }
        for e in result.events
        if e.kind == "probe" and e.reading and "point" in e.reading
    ]
    return {
        "title": f"{result.cell}: {result.run}",
        "t": np.round(times, 6).tolist(),
        "t_end": float(times[-1]) if len(times) else 0.0,
        "devices": devices,
        "marks": marks,
        "without_geometry": without_geometry,
        "labels": labels,
        "contacts": contacts,
    }
