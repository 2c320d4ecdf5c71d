"""Robots in and out: URDF import to a cell, and a cell's device out to URDF."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import Issue, UserError, did_you_mean


@dataclass
class UrdfImport:
    """What ``rworld import urdf`` wrote.

    Attributes
    ----------
    cell : str
        The new cell folder.
    files : list of str
        Files written, relative to ``cell``.
    device : str
    dof : int
    chain : list of str
        URDF joints along the chain, base to tip (fixed ones included).
    base, tip, tcp : str
        URDF links.
    merged : dict
        Device link (or the device itself, for the base) -> URDF links merged into it.
    renamed : dict
        URDF name -> rworld name.
    warnings : list of Issue
        From the URDF and from loading the written cell.
    """

    cell: str
    files: list[str]
    device: str
    dof: int
    chain: list[str]
    base: str
    tip: str
    tcp: str
    merged: dict[str, list[str]]
    renamed: dict[str, str]
    warnings: list[Issue] = field(default_factory=list)
    renamed_where: dict[str, str] = field(default_factory=dict)  # where each new name shows

    def as_dict(self) -> dict:
        return {
            "cell": self.cell,
            "files": self.files,
            "device": self.device,
            "dof": self.dof,
            "chain": self.chain,
            "base": self.base,
            "tip": self.tip,
            "tcp": self.tcp,
            "merged": self.merged,
            "renamed": self.renamed,
            "renamed_where": self.renamed_where,
            "warnings": [w.as_dict() for w in self.warnings],
        }


def import_urdf(
    urdf: str,
    output: str,
    package_paths: list[str] | None = None,
    base: str | None = None,
    tip: str | None = None,
    tcp: str | None = None,
    device_name: str | None = None,
    force: bool = False,
    locks: dict[str, str] | None = None,
    srdf: str | None = None,
    overlap_states: int = 8,
    xacro_args: dict[str, str] | None = None,
    joint_limits: str | None = None,
) -> UrdfImport:
    """Write a cell (``cell.yaml``, ``poses.yaml``, ``meshes/``) for a URDF robot's chain.

    Everything is read and checked first; the files are written to a temporary folder, loaded
    back as a cell, and only then moved to ``output``.  On any error nothing is written.

    Parameters
    ----------
    urdf : str
        The URDF file, or a xacro file (expanded with ``$(find PKG)`` from ``package_paths`` and
        ``$(arg NAME)`` from ``xacro_args``).
    output : str
        The cell folder to create (``--force``: or to overwrite the files of).
    package_paths : list of str
        Folders holding ROS packages, for ``package://`` mesh names.
    base, tip, tcp, device_name : str, optional
    locks : dict, optional
        See :func:`rworld_cli.schema.urdf_cell.cell_from_urdf`.
    srdf : str, optional
        A MoveIt SRDF whose disabled collision pairs become the cell's ``allowed_contacts``.
    joint_limits : str, optional
        A ROS ``joint_limits.yaml`` (the vendor's MoveIt or ros2_control config): its velocity,
        acceleration and effort limits replace or complete the URDF's.
    overlap_states : int
        Link pairs that overlap at the home and at ``overlap_states - 1`` seeded joint states
        (meshes drawn into each other at a joint) become ``allowed_contacts`` too, each with a
        warning; 0 skips the check.

    Raises
    ------
    UserError
        Bad URDF (located), bad options, or an existing cell at ``output`` without ``force``.
    """
    from ..fileio import atomic_write_bytes, output_set
    from ..schema.loader import load_cell
    from ..schema.urdf import read_joint_limits, read_urdf
    from ..schema.urdf_cell import cell_from_urdf

    out = Path(output)
    if out.exists() and not out.is_dir():
        raise UserError(f"{output} exists and is not a folder")
    if out.is_dir() and (out / "cell.yaml").exists() and not force:
        raise UserError(
            f"{output} already holds a cell (cell.yaml); choose another folder or pass --force "
            "to overwrite its cell.yaml, poses.yaml and meshes"
        )
    robot, warnings = read_urdf(urdf, package_paths, xacro_args)
    stated = read_joint_limits(joint_limits, xacro_args) if joint_limits is not None else None
    from .cells import installed_schemas

    found = installed_schemas()  # the editor's schemas, wherever the cell is written
    schemas = None if found is None else str(found)
    name = out.resolve().name
    disabled = []
    if srdf is not None:
        from ..schema.srdf import read_srdf

        disabled = read_srdf(srdf)
    import functools

    build = functools.partial(  # the import's cell, with the pairs always overlapping allowed
        cell_from_urdf,
        robot,
        name,
        base,
        tip,
        tcp,
        device_name,
        locks,
        disabled,
        joint_limits=stated,
        schemas=schemas,
    )
    try:
        imported = build()
    except UserError as exc:  # a xacro's robot: each problem at the vendor's file and line
        raise UserError(str(exc), robot.located(exc.issues)) from None
    files = {"cell.yaml": imported.cell_text.encode(), "poses.yaml": imported.poses_text.encode()}
    files.update(imported.meshes)
    # the cell is written as a unit: the folder is swapped whole (its other files, programs and
    # runs, carried over), so no instant shows a cell.yaml of one import with another's poses
    with output_set() as outputs:
        staging = outputs.claim_folder(out, keep_others=True)
        for rel, data in files.items():
            atomic_write_bytes(out / rel, data)
        try:
            loaded = load_cell(staging)
        except UserError as exc:  # what we wrote must load: anything else is our bug
            raise RuntimeError(
                "the imported cell does not load: " + "; ".join(exc.lines()[:5])
            ) from exc
        overlaps = _always_overlapping(
            loaded.cell, imported.device, overlap_states, str(out / "cell.yaml")
        )
        allow = [(a, b, reason) for a, b, reason, _, allowed in overlaps if allowed]
        if allow:  # written as allowed contacts, the cell written and loaded again
            imported = build(allow)
            atomic_write_bytes(out / "cell.yaml", imported.cell_text.encode())
            loaded = load_cell(staging)
        imported.warnings.extend(warning for _, _, _, warning, _ in overlaps)
        imported.warnings.extend(_implausible_dynamics(robot, loaded.cell, imported.device))
        _warm_caches(loaded.cell, imported.device)
        load_warnings = [
            Issue(
                w.file.replace(str(staging), str(out)),
                w.line,
                w.column,
                w.location,
                w.message,
                w.severity,
            )
            for w in loaded.warnings
        ]
    return UrdfImport(
        str(out),
        sorted(files),
        imported.device,
        loaded.cell.devices[imported.device].dof,
        imported.chain,
        imported.base,
        imported.tip,
        imported.tcp,
        imported.merged,
        imported.renamed,
        warnings + robot.located(imported.warnings) + load_warnings,
        imported.renamed_where,
    )


def _always_overlapping(
    cell, device: str, states: int, file: str
) -> list[tuple[str, str, str, Issue, bool]]:
    """(body, body, reason, warning, to allow) of the pairs of ``device``'s bodies that overlap
    at every one of ``states`` joint states; pairs with the base are only warned about (in
    ``allowed_contacts`` a device's name stands for all its bodies).  Bodies that are no closed
    solid get one warning (None as reason)."""
    if states <= 0:
        return []
    from ..collision.selfoverlap import always_overlapping

    found = always_overlapping(cell, device, states)
    out = []
    for o in found.overlaps:
        amount = f"{o.volume * 1e6:.3g} cm^3"
        reason = f"overlap at all {states} joint states sampled at import (at least {amount})"
        with_base = device in (o.a, o.b)
        what = (
            "check them with care: a pair with the base cannot be allowed alone"
            if with_base
            else "written to allowed_contacts, as MoveIt disables its 'Always' pairs; remove "
            "the entry to have them checked"
        )
        message = (
            f"'{o.a}' and '{o.b}' overlap at all {states} joint states sampled (by at least "
            f"{amount}): their meshes are drawn into each other; {what}"
        )
        out.append(
            (o.a, o.b, reason, Issue(file, 0, 0, "collision", message, "warning"), not with_base)
        )
    if found.unchecked:
        message = (
            f"not checked for overlapping links: {', '.join(found.unchecked)} (no closed solid)"
        )
        out.append(("", "", "", Issue(file, 0, 0, "collision", message, "warning"), False))
    return out


def _warm_caches(cell, device: str) -> None:
    """What the first command on the new robot would build, built now and kept in the cache
    (issue 62: a first ``check`` took 5-24 times the second): the links' convex parts, trees
    and walk tables, and the compiled collision kernels (a configuration check and a segment
    check of the device's home), and its kinematics.  A cache that cannot be written costs
    only the time."""
    import numpy as np

    from ..collision.bodies import collision_model
    from ..collision.configurations import ConfigurationChecker
    from ..world.tree import World

    world = World(cell)
    checker = ConfigurationChecker(world, collision_model(cell), device)
    home = np.asarray(cell.devices[device].home, dtype=float)
    lower, upper = (
        cell.devices[device].limit_array("lower"),
        cell.devices[device].limit_array("upper"),
    )
    other = np.clip(home + 0.1, lower, upper)
    checker.check(np.stack([home, other]))
    checker.check(np.stack([home, other]), nearest=False)
    checker.free(np.stack([home, other]))  # the planner's: the chain's mounted frames compiled
    checker.check_segment(home, other)
    # the device's own kernels, generated for its geometry: the TCP's pose (the simulator's
    # and the exports' forward kinematics) and the inverse dynamics (the overload checks)
    from ..dynamics import DeviceDynamics
    from ..kinematics.jacobian import ToolMount, tool_pose

    dev = cell.devices[device]
    states = np.stack([home, other])
    for tcp in dev.tcps:
        tool_pose(dev, states, ToolMount(*world.mount_of(device, tcp)))
    DeviceDynamics(dev).inverse(states, np.zeros_like(states), np.zeros_like(states))


def _warning_at(robot, element, location: str, message: str) -> Issue:
    """A warning at a URDF element's line (a link's, a joint's; the file when None)."""
    line, column = (element.line, element.column) if element is not None else (0, 0)
    return Issue(robot.file, line, column, location, message, "warning")


def _implausible_dynamics(robot, cell, device: str) -> list[Issue]:
    """Warnings for mass properties and effort limits no real robot has
    (:mod:`rworld_cli.dynamics.plausible`): links whose inertia is beyond what their mass
    and size allow, joints whose efforts cannot hold the arm against gravity - each a line,
    at the first such link's or joint's element of the URDF."""
    import numpy as np

    from ..dynamics.plausible import efforts_below_gravity, inertia_beyond_size
    from ..geometry import shape_mesh

    dev = cell.devices[device]
    out = []
    beyond = []
    for link in dev.links:
        inertial = link.inertial
        if inertial is None or inertial.mass <= 0 or link.shape is None:
            continue
        vertices = np.asarray(shape_mesh(link.shape).vertices, dtype=float)
        reach = float(np.linalg.norm(vertices - inertial.com, axis=1).max())
        found = inertia_beyond_size(inertial.mass, inertial.inertia, reach)
        if found is not None:
            beyond.append((link.name, inertial.mass, reach, *found))
    if beyond:
        first = robot.links.get(beyond[0][0])
        said = "; ".join(
            f"{name} {largest:.3g} kg m^2 (a {mass:.3g} kg body within {reach * 1000:.0f} mm of "
            f"its centre of mass: at most {most:.3g})"
            for name, mass, reach, largest, most in beyond[:4]
        ) + (f"; and {len(beyond) - 4} more" if len(beyond) > 4 else "")
        out.append(
            _warning_at(
                robot,
                first,
                "inertial",
                f"the inertia of {len(beyond)} link(s) is more than their mass and size allow "
                f"({said}): placeholder dynamics? torques, overload checks and dynamics fits use "
                "them; give the links' real mass properties in cell.yaml",
            )
        )
    weak = efforts_below_gravity(dev)
    if weak:
        joint = dev.joints[weak[0][0]]
        first = robot.joints.get(joint.name)
        effort = dev.limit_array("effort")
        said = "; ".join(
            f"{dev.joints[j].name} needs up to {need:.3g} (limit {effort[j]:.3g})"
            for j, need, _ in weak
        )
        out.append(
            _warning_at(
                robot,
                first,
                "limit",
                f"the effort limits of {len(weak)} joint(s) cannot hold the arm against gravity "
                f"({said}; N m or N, at states within the limits): placeholder limits? every "
                "move would overload; give the real 'effort' in cell.yaml, or remove it",
            )
        )
    return out


@dataclass
class UrdfExport:
    """What ``rworld export urdf`` wrote: the file, its links and joints, and what URDF could
    not hold."""

    path: str
    device: str
    links: list[str]
    joints: list[str]
    note: str

    def as_dict(self) -> dict:
        return {
            "path": self.path,
            "device": self.device,
            "links": self.links,
            "joints": self.joints,
            "note": self.note,
        }


def export_urdf(cell_path: str, output: str, device: str | None = None) -> UrdfExport:
    """Write a device of a cell as URDF, with the cell's current pose files (calibrated overlay
    included) applied to its frames.

    Parameters
    ----------
    cell_path : str
    output : str
        The ``.urdf`` file to write (atomically); meshes are referenced relative to its folder.
    device : str, optional
        Needed when the cell has more than one device.
    """
    from ..schema.cell_to_urdf import urdf_from_cell
    from ..schema.loader import load_cell
    from ..schema.urdf import write_urdf

    cell = load_cell(cell_path).cell
    if device is None:
        if len(cell.devices) != 1:
            raise UserError(
                f"{cell_path} has {len(cell.devices)} devices ({', '.join(cell.devices)}); "
                "choose one with --device"
            )
        device = next(iter(cell.devices))
    if device not in cell.devices:
        raise UserError(f"no device '{device}' in {cell_path}{did_you_mean(device, cell.devices)}")
    from ..world.tree import World

    # what the cell's state has the device carry (a hand, a grasped part), at its home
    carried = [
        (name, link, bodies) for name, link, bodies in World(cell).carried(device) if link > 0
    ]
    robot, mesh_names = urdf_from_cell(cell, device, output, carried)
    write_urdf(output, robot, mesh_names)
    return UrdfExport(output, device, list(robot.links), list(robot.joints), robot.comment)


# --------------------------------------------------------------------------- UR factory calibration

UR_JOINT_TOLERANCE = (0.02, math.radians(5.0))  # a calibrated UR joint within this of nominal


def import_ur_calibration(
    calibration: str, cell_path: str, output: str, device: str | None = None
) -> dict:
    """A UR robot's factory calibration (``ur_calibration``'s ``kinematics:`` file) as a
    pose-file overlay of the cell's joint frames (``rworld import ur-calibration``).

    The cell's UR is imported from ``ur_description`` (joint frames): each calibration group is
    its joint's ``origin`` in ``ur_macro.xacro``.  What ``rworld import urdf`` merged before a
    joint stays: before the shoulder, the fixed joints from the device's base to
    ``base_link_inertia`` (``base_link`` turned by pi about z), found from the cell's joint 1
    frame - a turn about z and a height, as the default kinematics' shoulder is on the base's
    axis; before the other joints nothing (their parents are the previous joints' links), which
    is checked: each frame within 20 mm and 5 deg of the calibration's.

    Returns
    -------
    dict
        ``written``, ``device``, ``hash`` and per joint how far the calibration moves its frame
        from the cell's (``moved_mm``, ``turned_deg``).

    Raises
    ------
    UserError
        A malformed file (located), no 6-joint joint-frame device, a cell whose frames are not
        ur_description's.
    """
    import numpy as np

    from .. import spatial
    from ..schema.loader import load_cell
    from ..schema.urcal import read_ur_calibration, write_joint_overlay
    from .calibration import overlay_output

    origins, label = read_ur_calibration(calibration)
    cell = load_cell(cell_path).cell
    candidates = [
        d
        for d in cell.devices.values()
        if d.convention == "frames" and d.dof == 6 and all(j.kind == "revolute" for j in d.joints)
    ]
    if device is not None:
        candidates = [d for d in candidates if d.name == device]
    if len(candidates) != 1:
        raise UserError(
            f"{cell_path}: "
            + (
                f"no 6-axis arm given by joint frames{f' named {device}' if device else ''} (a UR "
                "imported from ur_description)"
                if not candidates
                else "several 6-axis arms: choose one with --device"
            )
        )
    dev = candidates[0]
    out = overlay_output(cell_path, cell, output, "ur_calibration.yaml", "the UR calibration")
    nominal = [np.asarray(j.origin) for j in dev.joints]
    # before the shoulder: the merged fixed joints, a turn about z (and the shoulder's height)
    first = nominal[0]
    R = first[:3, :3]
    about_z = abs(R[2, 2] - 1.0) < 1e-9 and np.abs(R[:2, 2]).max() < 1e-9
    if not about_z or np.abs(first[:2, 3]).max() > 1e-9:
        raise UserError(
            f"{dev.name}.{dev.joints[0].name}'s frame is not ur_description's (a turn about z "
            "and a height above the base): import the robot from ur_description with its base "
            "at base_link or base"
        )
    before_shoulder = spatial.make_transform(R, np.zeros(3))
    calibrated = {dev.joints[0].name: before_shoulder @ origins[0]}
    report = []
    for i, (j, T_nom) in enumerate(zip(dev.joints, nominal)):
        T_cal = calibrated[j.name] if i == 0 else origins[i]
        if i > 0:
            calibrated[j.name] = T_cal
        moved = np.linalg.solve(T_nom, T_cal)
        shift = float(np.linalg.norm(moved[:3, 3]))
        turn = float(np.arccos(np.clip((np.trace(moved[:3, :3]) - 1) / 2, -1.0, 1.0)))
        if shift > UR_JOINT_TOLERANCE[0] or turn > UR_JOINT_TOLERANCE[1]:
            raise UserError(
                f"{calibration}: the '{j.name}' frame of the calibration is {shift * 1000:.1f} mm "
                f"and {np.degrees(turn):.2f} deg from {dev.name}'s: not this robot's calibration, "
                "or a cell not imported from ur_description (joints in its order: "
                "shoulder_pan, shoulder_lift, elbow, wrist_1, wrist_2, wrist_3)"
            )
        report.append(
            {"joint": j.name, "moved_mm": shift * 1000, "turned_deg": float(np.degrees(turn))}
        )
    write_joint_overlay(
        out,
        dev.name,
        calibrated,
        [
            f"UR factory calibration of '{dev.name}' (rworld import ur-calibration), from "
            f"{calibration}" + (f", hash {label}" if label else ""),
            "List it last in the cell's pose_files; the nominal joint frames stay where they are.",
        ],
    )
    return {"written": str(out), "device": dev.name, "hash": label, "joints": report}
