"""A cell's device out to URDF (``rworld export urdf``): its joint frames with the calibrated
poses applied, links with their inertials and shapes, for ROS, MoveIt or Pinocchio; the way in
is :mod:`.urdf_cell`."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..model.cell import CellModel, Inertial
from .urdf import UrdfGeometry, UrdfJoint, UrdfLink, UrdfRobot


def _shape_geometry(shape, T_urdf_owner: np.ndarray) -> UrdfGeometry:
    T = T_urdf_owner @ shape.T_owner_shape
    size = np.asarray(shape.size, dtype=float)
    if shape.kind == "box":
        return UrdfGeometry("box", T, tuple(float(x) for x in size))
    if shape.kind == "cylinder":
        return UrdfGeometry("cylinder", T, (float(size[0]) / 2, float(size[2])))
    if shape.kind == "sphere":
        return UrdfGeometry("sphere", T, (float(size[0]) / 2,))
    return UrdfGeometry(
        "mesh", T, mesh_file=shape.mesh_file, mesh_scale=np.full(3, float(shape.mesh_scale))
    )


def urdf_from_cell(
    cell: CellModel, device: str, output: str | Path, carried=()
) -> tuple[UrdfRobot, dict]:
    """A device of a loaded cell (its current pose files applied) as a URDF robot.

    ``carried``: what rides on the device's links, [(primitive name, link index 1..n,
    [(Inertial, T_link_body)])] (``World.carried``): each body a fixed link with its mass
    properties on the link that carries it, so the URDF's dynamics include the held tool.

    Returns
    -------
    robot : UrdfRobot
    mesh_names : dict
        Mesh file -> its ``filename`` in the URDF, relative to ``output``'s folder.
    """
    dev = cell.devices[device]
    taken = {link.name for link in dev.links} | {
        name.split(".", 1)[1]
        for name, d in cell.frames.items()
        if d.owner == device and "." in name
    }
    base = dev.base_link or device
    base = base if base not in taken else f"{base}_base"
    links: dict[str, UrdfLink] = {}
    joints: dict[str, UrdfJoint] = {}
    urdf_of = {device: (base, np.eye(4))}  # rworld frame -> (URDF link, T_urdflink_frame)
    base_shapes = (_shape_geometry(dev.shape, np.eye(4)),) if dev.shape is not None else ()
    links[base] = UrdfLink(base, None, base_shapes, base_shapes)
    parent = base
    notes: dict[str, list[str]] = {}  # what URDF cannot hold, by kind

    def note(kind: str, item: str) -> None:
        notes.setdefault(kind, []).append(item)

    for joint, link, (origin, axis, T_urdf_link), frame in zip(
        dev.joints, dev.links, dev.joint_frames(), dev.link_frames
    ):
        R = T_urdf_link[:3, :3]
        inertial = Inertial(
            link.inertial.mass,
            R @ link.inertial.com + T_urdf_link[:3, 3],
            R @ link.inertial.inertia @ R.T,
        )
        shapes = (_shape_geometry(link.shape, T_urdf_link),) if link.shape is not None else ()
        links[link.name] = UrdfLink(link.name, inertial, shapes, shapes)
        lim = joint.limits
        revolute = joint.kind == "revolute"
        limited = np.isfinite(lim.lower) and np.isfinite(lim.upper)
        kind = "prismatic" if not revolute else ("revolute" if limited else "continuous")
        if not revolute and not limited:
            note("no position limits, written as +-1e9 m", joint.name)
        coulomb = joint.coulomb_positive
        if joint.coulomb_positive != joint.coulomb_negative:
            coulomb = (joint.coulomb_positive + joint.coulomb_negative) / 2
            note(
                "Coulomb friction that differs by direction, written as its mean",
                f"{joint.name} +{joint.coulomb_positive:g}/-{joint.coulomb_negative:g}",
            )
        if np.isfinite(lim.acceleration):
            note("acceleration limits, dropped", f"{joint.name} {lim.acceleration:g}")
        if joint.armature:
            note("motor inertia (armature, kg m^2), dropped", f"{joint.name} {joint.armature:g}")
        joints[joint.name] = UrdfJoint(
            joint.name,
            kind,
            parent,
            link.name,
            origin,
            axis,
            lim.lower if limited else -1e9,
            lim.upper if limited else 1e9,
            lim.velocity,
            lim.effort,
            joint.viscous,
            coulomb,
        )
        urdf_of[frame] = (link.name, T_urdf_link)
        parent = link.name
    # every other frame of the device, parents first
    pending = [
        name
        for name, d in cell.frames.items()
        if d.owner == device and d.kind in ("auxiliary", "tcp")
    ]
    while pending:
        rest = []
        for name in pending:
            decl = cell.frames[name]
            if decl.parent not in urdf_of:
                rest.append(name)
                continue
            link_name = name.split(".", 1)[1]
            parent_link, T_parent = urdf_of[decl.parent]
            links[link_name] = UrdfLink(link_name)
            joints[link_name + "_joint"] = UrdfJoint(
                link_name + "_joint",
                "fixed",
                parent_link,
                link_name,
                T_parent @ cell.poses[name],
                np.array([1.0, 0.0, 0.0]),
            )
            urdf_of[name] = (link_name, np.eye(4))
        if len(rest) == len(pending):
            break
        pending = rest
    for name, k, bodies in carried:  # the held tool and parts, as fixed links with their mass
        link_name, T_urdf_link = urdf_of[dev.link_frames[k - 1]]
        for j, (inertial, T_link_body) in enumerate(bodies):
            body = f"carried_{name}" + (f"_{j + 1}" if len(bodies) > 1 else "")
            links[body] = UrdfLink(body, inertial)
            joints[body + "_joint"] = UrdfJoint(
                body + "_joint",
                "fixed",
                link_name,
                body,
                T_urdf_link @ T_link_body,
                np.array([1.0, 0.0, 0.0]),
            )

    comment = (
        f"Written by 'rworld export urdf' from {cell.path}, device '{device}'"
        + (
            " (standard DH: each URDF link frame is DH frame i-1 turned by joint i)"
            if dev.convention == "standard"
            else ""
        )
        + "."
        + (
            " Not in URDF: "
            + "; ".join(f"{kind}: {', '.join(items)}" for kind, items in notes.items())
            + "."
            if notes
            else ""
        )
        + (
            " Carried in the cell's state, as fixed links with their mass: "
            + ", ".join(name for name, _, _ in carried)
            + "."
            if carried
            else ""
        )
    )
    folder = Path(output).resolve().parent
    mesh_names = {}
    for urdf_link in links.values():
        for g in urdf_link.collisions:
            if g.mesh_file is not None:
                mesh_names[g.mesh_file] = os.path.relpath(Path(g.mesh_file).resolve(), folder)
    return UrdfRobot(device, str(output), links, joints, base, comment), mesh_names
