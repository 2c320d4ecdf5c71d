"""Sensing tasks: read a cell's sensors by interference checking, render the scene."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import UserError
from .cells import load_world

# --------------------------------------------------------------------------- sensing


def sense(
    cell_path: str,
    joints: dict[str, list[float]] | None = None,
    sensors: list[str] | None = None,
    tolerance: float | None = None,
):
    """Load a cell, set joint values, and read its sensors by interference checking.

    Returns
    -------
    (World, list of SensorReading)
    """
    from ..errors import did_you_mean
    from ..geometry import DEFAULT_TOLERANCE
    from ..sensing.sensors import read_sensors

    world, _ = load_world(cell_path, joints)
    for name in sensors or []:
        if name not in world.cell.sensors:
            raise UserError(
                f"unknown sensor '{name}'{did_you_mean(name, world.cell.sensors)}; the cell has: "
                f"{', '.join(world.cell.sensors) or 'none'}"
            )
    tol = DEFAULT_TOLERANCE if tolerance is None else tolerance
    if not (tol >= 0 and np.isfinite(tol)):
        raise UserError(f"the tolerance must be a finite length >= 0 (m), got {tolerance}")
    return world, read_sensors(world, sensors or None, tol)


def describe_reading(reading) -> list[str]:
    """Lines for a terminal: the reading in words, then any text picture (its type says how)."""
    from ..sensing.types import sensor_type

    return sensor_type(reading.type).describe(reading)


def write_sensor_maps(readings, path: str) -> Path:
    """One PNG panel per sensor whose type draws a map (tactile, proximity), in the report's
    Fig. 13 colours.
    """
    from ..sensing.pictures import write_maps_png

    return write_maps_png(readings, path)


def render_scene(
    cell_path: str,
    outputs: str | list[str],
    joints: dict[str, list[float]] | None = None,
    tolerance: float | None = None,
    view: tuple[float, float] = (25.0, -60.0),
    frames: bool = True,
) -> list[Path]:
    """Draw the cell with its sensors' readings into each of ``outputs``: a PNG (matplotlib), a
    glTF binary (.glb) or a self-contained HTML viewer of the one state (.html), by the file's
    suffix.  The cell is loaded and its sensors read once for all of them.
    """
    from ..units import SENSING_TOLERANCE

    outputs = picture_outputs(outputs)
    world, _ = sense(cell_path, joints, None, tolerance)
    tol = SENSING_TOLERANCE if tolerance is None else tolerance
    return draw_world(world, outputs, tol, view, frames, title=world.cell.name)


def picture_outputs(outputs: str | list[str]) -> list[str]:
    """The files to draw, each a .png, .glb or .html (UserError before any work otherwise)."""
    outputs = [outputs] if isinstance(outputs, str) else list(outputs)
    for output in outputs:
        suffix = output.lower().rsplit(".", 1)[-1] if "." in output else ""
        if suffix not in ("png", "glb", "html"):
            raise UserError(
                f"cannot tell the format of '{output}': give a .png, .glb or .html file"
            )
    return outputs


def draw_world(
    world,
    outputs: list[str],
    tolerance: float,
    view: tuple[float, float] = (25.0, -60.0),
    frames: bool = True,
    highlight: tuple[str, ...] = (),
    title: str | None = None,
    marks: list | None = None,
) -> list[Path]:
    """The world's current state into each file of ``outputs`` (checked by
    :func:`picture_outputs`), by suffix; ``highlight``: bodies in the collision colour."""
    from ..sensing.render import render_glb, render_png

    written = []
    for output in outputs:
        suffix = output.lower().rsplit(".", 1)[-1]
        if suffix == "png":
            written.append(
                render_png(world, output, tolerance, view, frames, highlight, title, marks)
            )
        elif suffix == "html":
            written.append(still_page(world, output, title or world.cell.name, highlight))
        else:
            written.append(render_glb(world, output, tolerance, highlight))
    return written


def still_page(world, output: str, title: str, highlight: tuple[str, ...] = ()) -> Path:
    """The viewer page (as ``rworld view`` writes for a run) of the world's current state;
    ``highlight``: bodies drawn in the collision colour."""
    from ..fileio import atomic_write_text
    from ..schema.gltf import scene_glb
    from ..simulate.scene import state_scene
    from ..viewer.page import viewer_page

    scene = state_scene(world, title, highlight)
    atomic_write_text(output, viewer_page(scene_glb(scene), scene.info))
    return Path(output)


def render_camera(
    cell_path: str,
    camera: str,
    output: str,
    joints: dict[str, list[float]] | None = None,
    blur_px: float = 0.6,
    noise: float = 2.0,
    seed: int = 0,
    depth_output: str | None = None,
) -> dict:
    """Write the grey PNG the camera sensor ``camera`` would take in the cell's state: its
    boards, the bodies in front of them, blur and noise (``vision/render.py``); and with
    ``depth_output`` the depth of the boards seen (a 16-bit PNG in mm, 0 where no board is).

    Returns
    -------
    dict
        ``cell``, ``camera``, ``resolution``, ``board_pixels`` (pixels whose centre sees a
        board), ``seconds``, ``written``.
    """
    import time

    from ..errors import did_you_mean
    from ..geometry import shape_mesh
    from ..schema.captures import write_image
    from ..sensing.sensors import sensable_bodies
    from ..vision.render import render_view

    world, _ = load_world(cell_path, joints)
    cameras = [n for n, s in world.cell.sensors.items() if s.type == "camera"]
    if camera not in cameras:
        raise UserError(
            f"'{camera}' is not a camera sensor of {cell_path}{did_you_mean(camera, cameras)}; "
            f"its cameras: {', '.join(cameras) or 'none'}"
        )
    boards = [
        (o.board, world.T_world(name))
        for name, o in world.cell.objects.items()
        if o.board is not None
    ]
    holders = {name for name, o in world.cell.objects.items() if o.board is not None}
    occluders = [
        shape_mesh(b.shape).triangles(b.T_world_owner)
        for b in sensable_bodies(world)
        if b.owner not in holders
    ]
    t0 = time.perf_counter()
    image, depth = render_view(
        world.cell.sensors[camera].camera,
        world.T_world(camera),
        boards,
        occluders,
        blur_px,
        noise,
        seed,
    )
    seconds = time.perf_counter() - t0
    from ..fileio import output_set
    from ..schema.captures import write_depth_image

    written = [str(output)]
    with output_set():
        write_image(output, image)
        if depth_output is not None:
            write_depth_image(depth_output, depth)
            written.append(str(depth_output))
    return {
        "cell": cell_path,
        "camera": camera,
        "resolution": [int(image.shape[1]), int(image.shape[0])],
        "board_pixels": int(np.isfinite(depth).sum()),
        "seconds": seconds,
        "written": written,
    }
