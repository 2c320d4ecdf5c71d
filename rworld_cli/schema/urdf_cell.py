"""URDF robots in and out of rworld cells: the mapping between the two formats.

**In** (:func:`cell_from_urdf`): URDF describes a tree of links; an rworld device is a serial
chain.  The chain runs from a base link to a tip link through the moving joints (revolute,
continuous, prismatic).  Every link fixed to a chain link - by fixed joints on the chain, or in
branches off it - is merged into that link: masses and inertias combined (parallel-axis), the
shapes gathered into one geometry (one mesh file when there are several), the link itself kept
as a frame on it whose pose goes to ``poses.yaml``, where calibration can change it.  Moving
joints in branches off the chain (a gripper's fingers) are locked at 0 and merged the same way,
with a warning.  Mimic joints on the chain, floating and planar joints are refused.

**Out** (:func:`urdf_from_cell`): a device becomes one link per rworld link, joined by its
joints; DH rows become joint frames (standard DH: the URDF link frame is DH frame *i-1* turned
by joint *i*, so link data move by the row's constant transform); every frame on the device
(TCPs, auxiliary frames, with the current pose files applied) becomes a massless link on a
fixed joint.  What URDF cannot hold (acceleration limits, motor inertia, asymmetric Coulomb
friction) is listed in a comment.
"""

from __future__ import annotations

import re
import warnings as pywarnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from .. import spatial
from ..errors import Issue, UserError, did_you_mean
from ..model.cell import Inertial
from .loader import inertia_entries
from .models import NAME_PATTERN
from .urdf import MOVING, JointLimitsFile, UrdfGeometry, UrdfJoint, UrdfLink, UrdfRobot
from .urdf_vendors import vendor_conventions
from .yamlio import comment_text

MESH_SUFFIXES = (".stl", ".obj", ".ply")


@dataclass
class ImportedCell:
    """The files of an imported cell, in memory until they are written.

    Attributes
    ----------
    cell_text, poses_text : str
        ``cell.yaml`` and ``poses.yaml``.
    meshes : dict
        Path relative to the cell folder -> file bytes.
    device : str
    chain : list of str
        The URDF joints that became the device's joints, base to tip.
    base, tip, tcp : str
        URDF links.
    merged : dict
        Device link (or the base) -> the URDF links merged into it.
    renamed : dict
        URDF name -> rworld name, for names rworld cannot hold (or reserves: ``world``) that the
        cell shows; a renamed link merged away shows nowhere and is not listed.
    renamed_where : dict
        URDF name -> where its new name shows ("joint ur5.j_2", "frame ur5.world_2").
    warnings : list of Issue
    """

    cell_text: str
    poses_text: str
    meshes: dict[str, bytes]
    device: str
    chain: list[str]
    base: str
    tip: str
    tcp: str
    merged: dict[str, list[str]]
    renamed: dict[str, str]
    warnings: list[Issue] = field(default_factory=list)
    renamed_where: dict[str, str] = field(default_factory=dict)


# links the vendors' packages mark as a tool frame, first taken first (a prefix before them
# allowed: 'left_tool0'): rworld's own export, ROS-Industrial's and UR's flange, Kinova's tool
# and end-effector frames, then common others
TOOL_FRAMES = ("tcp", "tool0", "tool_frame", "end_effector_link", "flange", "ee_link", "tool_link")


def _tool_frame(placed: dict, last: int) -> str | None:
    """The first link of :data:`TOOL_FRAMES` (a prefix allowed) fixed to the chain's last
    moving link, or None."""
    on_last = [name for name, (group, _) in placed.items() if group == last]
    for wanted in TOOL_FRAMES:
        for name in on_last:
            if name == wanted or name.endswith("_" + wanted):
                return name
    return None


def _tcp_words(placed: dict, last: int, head: str, taken: str, named: bool) -> str:
    """What the import says of the TCP it took without --tcp, when the last link carries other
    frames: which it took and why, the others, and --tcp ('' when there is nothing else).
    ``head``: the last moving link itself; ``named``: taken as a tool frame by its name (else it
    is the chain's tip)."""
    others = [
        name for name, (group, _) in placed.items() if group == last and name not in (taken, head)
    ]
    if not others:
        return ""
    if named:
        why = "a tool frame by the vendors' names"
    else:
        why = (
            "the chain's tip: no link on it is named as a tool frame ("
            + ", ".join(TOOL_FRAMES)
            + ")"
        )
    shown = ", ".join(others[:8]) + (f" and {len(others) - 8} more" if len(others) > 8 else "")
    return (
        f"the TCP is '{taken}' ({why}); the last link also carries {shown}: --tcp NAME takes "
        "another"
    )


def _schema_line(schemas: str | None, name: str) -> str:
    """The editor's schema line of a file rworld writes: the schema ``name`` in the folder
    ``schemas`` (``api.installed_schemas``: absolute), or nothing without one."""
    if schemas is None:
        return ""
    return f"# yaml-language-server: $schema={comment_text(str(Path(schemas) / name))}\n"


def _package_of(file: str) -> str | None:
    """The ROS package a robot description's file is in (the nearest folder above it with a
    package.xml, at most four up): its name, or None."""
    folder = Path(file).resolve().parent
    for _ in range(4):
        if (folder / "package.xml").is_file():
            return folder.name
        if folder.parent == folder:
            break
        folder = folder.parent
    return None


def _issue(robot: UrdfRobot, item, location: str, message: str, severity="error") -> Issue:
    return Issue(robot.file, item.line, item.column, location, message, severity)


class _Names:
    """rworld names for URDF names: invalid characters become '_', clashes get a suffix."""

    def __init__(self) -> None:
        self.used: set[str] = {"world"}  # the cell's world frame: no URDF name takes it
        self.renamed: dict[str, str] = {}
        self.of: dict[str, str] = {}

    def fresh(self, name: str) -> str:
        """A new name, not one of the URDF's."""
        candidate, k = name, 2
        while candidate in self.used:
            candidate, k = f"{name}_{k}", k + 1
        self.used.add(candidate)
        return candidate

    def __call__(self, name: str) -> str:
        if name in self.of:
            return self.of[name]
        clean = re.sub(r"[^A-Za-z0-9_\-]", "_", name)
        if not re.match(NAME_PATTERN, clean):
            clean = "_" + clean
        candidate, k = clean, 2
        while candidate in self.used:
            candidate, k = f"{clean}_{k}", k + 1
        self.used.add(candidate)
        self.of[name] = candidate
        if candidate != name:
            self.renamed[name] = candidate
        return candidate


def _default_tip(robot: UrdfRobot, base: str) -> str:
    """Follow the moving joints down from ``base`` while the way is unique."""
    # link -> a moving joint lies below it; children before parents (iterative: a chain of
    # hundreds of fixed links is no recursion)
    memo: dict[str, bool] = {}
    order, stack = [], [base]
    while stack:
        link = stack.pop()
        order.append(link)
        stack.extend(j.child for j in robot.child_joints(link))
    for link in reversed(order):
        memo[link] = any(j.type != "fixed" or memo[j.child] for j in robot.child_joints(link))

    def moves(link: str) -> bool:
        return memo[link]

    node = base
    while True:
        ways = [j for j in robot.child_joints(node) if j.type != "fixed" or moves(j.child)]
        if not ways:
            return node
        if len(ways) > 1:
            leaves = [j.child for j in ways]
            raise UserError(
                f"{robot.file}: the robot branches at link '{node}' into moving chains "
                f"({', '.join(f'{j.name} -> {j.child}' for j in ways)}); choose the chain with "
                f"--tip LINK: '--tip {node}' keeps the branches locked at 0, or name a link "
                f"beyond one of {', '.join(leaves)}"
            )
        node = ways[0].child


def _chain(robot: UrdfRobot, base: str, tip: str) -> list[UrdfJoint]:
    path = []
    node = tip
    while node != base:
        joint = robot.parent_joint(node)
        if joint is None:
            raise UserError(
                f"{robot.file}: link '{tip}' is not below link '{base}': --tip must be a "
                f"descendant of --base"
            )
        path.append(joint)
        node = joint.parent
    return path[::-1]


def _checked_mesh(robot: UrdfRobot, g: UrdfGeometry):
    """The mesh a ``<mesh>`` names, read and checked (:mod:`.meshfile`); a corrupt or empty
    file is refused at the element."""
    from .meshfile import read_mesh

    mesh, problem = read_mesh(str(g.mesh_file))
    if mesh is None:
        raise UserError(
            f"invalid: {robot.file}",
            [Issue(robot.file, g.line, g.column, "mesh", f"{g.mesh_file}: {problem}")],
        )
    return mesh


def _mesh_bytes(robot: UrdfRobot, parts: list[tuple[UrdfGeometry, np.ndarray]]) -> bytes:
    """One binary STL of ``parts`` (shape, ``T_link_shape``) in the link frame [m]."""
    import trimesh

    meshes = []
    for g, T in parts:
        if g.kind == "box":
            m = trimesh.creation.box(extents=g.size)
        elif g.kind == "cylinder":
            m = trimesh.creation.cylinder(radius=g.size[0], height=g.size[1], sections=48)
        elif g.kind == "sphere":
            m = trimesh.creation.icosphere(subdivisions=3, radius=g.size[0])
        else:
            m = _checked_mesh(robot, g).copy()
            m.apply_scale(g.mesh_scale)
        m.apply_transform(T)
        meshes.append(m)
    merged = trimesh.util.concatenate(meshes) if len(meshes) > 1 else meshes[0]
    return bytes(merged.export(file_type="stl"))  # type: ignore[call-arg]


def _closed_or_surface(owner: str, name: str, meshes: dict, entry: dict) -> str | None:
    """A link's mesh file (``meshes[name]``, its ``entry`` in the cell) made closed where
    trimesh can close it (vertices merged, small holes filled, normals made consistent: the
    file replaced by the closed mesh, in the same units), else marked ``surface: true`` (an
    open surface, known: later commands say it in one note).  What was done, in words for the
    import's warning, or None when the mesh is closed as it is."""
    import io

    import trimesh

    data = meshes[name]
    suffix = name.rsplit(".", 1)[-1]
    with pywarnings.catch_warnings():
        pywarnings.simplefilter("ignore")
        mesh: trimesh.Trimesh = trimesh.load(  # type: ignore[assignment]
            io.BytesIO(data), file_type=suffix, force="mesh"
        )
    if mesh.is_watertight:
        return None
    _, uses = np.unique(np.asarray(mesh.edges_sorted), axis=0, return_counts=True)
    flaws = f"{int((uses == 1).sum())} open edges"  # on one face only
    if (uses > 2).any():
        flaws += f", {int((uses > 2).sum())} edges shared by more than two faces"
    repaired = mesh.copy()
    with pywarnings.catch_warnings():
        pywarnings.simplefilter("ignore")
        repaired.merge_vertices()  # seams: corners repeated a rounding apart
        how = "its seams' corners merged"
        if not repaired.is_watertight:
            trimesh.repair.fill_holes(repaired)
            how += " and its holes filled"
        trimesh.repair.fix_normals(repaired)
    if repaired.is_watertight and repaired.is_volume:
        stl = name.rsplit(".", 1)[0] + ".stl"
        del meshes[name]
        meshes[stl] = bytes(repaired.export(file_type="stl"))  # type: ignore[call-arg, arg-type]
        entry["file"] = stl
        return (
            f"the mesh of '{owner}' was no closed surface ({flaws}): closed, {how} "
            f"(trimesh), written as {stl}"
        )
    entry["surface"] = True
    return (
        f"the mesh of '{owner}' is no closed surface ({flaws}) and trimesh cannot close "
        "it: kept as an open surface (a body inside it goes unnoticed), marked 'surface: true' "
        "in cell.yaml, so later commands say it in one note"
    )


def _flow(dumper, data):
    flow = all(isinstance(x, (int, float, str)) for x in data) and len(data) <= 6
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)


class _Dumper(yaml.SafeDumper):
    pass


_Dumper.add_representer(list, _flow)


def _pose(T: np.ndarray) -> dict:
    out: dict = {"xyz": [float(x) + 0.0 for x in T[:3, 3]]}  # + 0.0: no "-0.0" in files
    rpy = spatial.matrix_to_rpy(T[:3, :3])
    if np.any(rpy != 0):
        out["rpy"] = [float(x) + 0.0 for x in rpy]
    return out


def _allowed_from_srdf(disabled, placed: dict, heads: list[str], device: str) -> list[dict]:
    """``allowed_contacts`` entries for an SRDF's disabled pairs: each URDF link stands for the
    moving link it was merged into (``device.link``); a pair in one body, or with a link off the
    imported part, needs none.  Pairs with the base are left out: in ``allowed_contacts`` a
    device's name stands for all its bodies, and the base touches only its first link, which is
    allowed anyway."""
    body = {link: f"{device}.{heads[g]}" for link, (g, _) in placed.items() if g > 0}
    out: dict[tuple[str, str], str] = {}
    for pair in disabled:
        a, b = body.get(pair.link1), body.get(pair.link2)
        if a is None or b is None or a == b:
            continue
        key = (min(a, b), max(a, b))
        out.setdefault(key, f"SRDF: {pair.reason} ({pair.link1} / {pair.link2})")
    return [{"between": list(k), "reason": reason} for k, reason in sorted(out.items())]


def _lock_values(robot: UrdfRobot, on_chain: set[str], texts: dict[str, str]) -> dict[str, float]:
    """``--lock`` values in SI (rad or m), each checked against its joint."""
    from ..units import ANGLE_WORDS, LENGTH_WORDS, parse_quantity

    out = {}
    for name, text in texts.items():
        joint = robot.joints.get(name)
        prismatic = joint is not None and joint.type == "prismatic"
        value = parse_quantity(text, LENGTH_WORDS if prismatic else ANGLE_WORDS, "")
        why = None
        if joint is None:
            why = f"is not a joint of the robot{did_you_mean(name, robot.joints)}"
        elif name in on_chain:
            why = "is on the chain; only joints off it are locked"
        elif joint.type not in MOVING:
            why = f"is a {joint.type} joint; only moving joints are locked"
        elif not np.isfinite(value):
            example = "20mm (a prismatic joint)" if prismatic else "30deg (a revolute joint)"
            why = f"needs a value with its unit, e.g. {example}"
        elif not joint.lower - 1e-12 <= value <= joint.upper + 1e-12:
            unit = "m" if prismatic else "rad"
            why = f"is outside its limits [{joint.lower:g}, {joint.upper:g}] {unit}"
        if why:
            raise UserError(f"{robot.file}: --lock {name}={text}: '{name}' {why}")
        out[name] = value
    return out


def cell_from_urdf(
    robot: UrdfRobot,
    cell_name: str,
    base: str | None = None,
    tip: str | None = None,
    tcp: str | None = None,
    device_name: str | None = None,
    locks: dict[str, str] | None = None,
    disabled=(),
    always=(),
    joint_limits: JointLimitsFile | None = None,
    schemas: str | None = None,
) -> ImportedCell:
    """The cell files for the serial chain ``base`` -> ``tip`` of a URDF robot.

    Parameters
    ----------
    robot : UrdfRobot
    cell_name : str
    base, tip : str, optional
        URDF links; default the root, and the end of the unique chain of moving joints.
    tcp : str, optional
        The URDF link whose frame becomes the device's TCP; default the first of
        :data:`TOOL_FRAMES` fixed to the chain's last link (a prefix allowed), else ``tip``.
    device_name : str, optional
        Default: the robot's name.
    locks : dict, optional
        Moving joints off the chain -> the value they are locked at, with its unit ('20mm',
        '30deg'; default 0): a gripper's fingers open, or closed on the part it grasps.
    disabled : iterable of schema.srdf.DisabledPair
        An SRDF's disabled collision pairs: the pairs of imported bodies they name become the
        cell's ``allowed_contacts`` (pairs inside one merged body, or off the imported part,
        need none).
    always : iterable of (body, body, reason)
        Pairs of the device's link bodies (``device.link``) that overlap at every joint state
        sampled (:func:`rworld_cli.collision.selfoverlap.always_overlapping`): allowed too, as
        MoveIt's setup assistant disables its "Always" pairs.
    joint_limits : JointLimitsFile, optional
        The vendor's limits file as read (:func:`.urdf.read_joint_limits`).
    schemas : str, optional
        The folder of the JSON Schemas the files' editor lines point at (absolute); None: no
        such line.

    Raises
    ------
    UserError
        Located problems: a mimic, floating or planar joint in the way, a missing mesh.
    """
    issues: list[Issue] = []
    warnings: list[Issue] = []
    base = base or robot.root
    for what, given in (("--base", base), ("--tip", tip), ("--tcp", tcp)):
        if given is not None and given not in robot.links:
            raise UserError(
                f"{robot.file}: {what} '{given}' is not a link of the robot"
                f"{did_you_mean(given, robot.links)}"
            )
    tip = tip or _default_tip(robot, base)
    chain = _chain(robot, base, tip)
    on_chain = {j.name for j in chain}
    locked = _lock_values(robot, on_chain, locks or {})
    for j in chain:
        if j.type in ("floating", "planar"):
            issues.append(
                _issue(
                    robot,
                    j,
                    f"joint[{j.name}].type",
                    f"a {j.type} joint cannot be part of a serial chain; "
                    + (
                        f"start the chain below it with --base {j.child}"
                        if j is chain[0]
                        else f"end the chain before it with --tip {j.parent}"
                    ),
                )
            )
        elif j.mimic and j.type in MOVING:
            issues.append(
                _issue(
                    robot,
                    j,
                    f"joint[{j.name}].mimic",
                    "a mimic joint (its value follows another joint's) is not supported on the "
                    "chain; end the chain before it with --tip",
                )
            )
    names = _Names()
    device = names(device_name or robot.name)

    # rigid groups: the base, then one per moving joint on the chain, each with its members
    # (URDF link, T_head_link) and the locked joints merged into it
    groups: list[list[tuple[UrdfLink, np.ndarray]]] = [[(robot.links[base], np.eye(4))]]
    placed: dict[str, tuple[int, np.ndarray]] = {base: (0, np.eye(4))}
    for j in chain:
        g, T_head_parent = placed[j.parent]
        if j.type in MOVING:
            groups.append([(robot.links[j.child], np.eye(4))])
            placed[j.child] = (len(groups) - 1, np.eye(4))
        else:
            T = T_head_parent @ j.origin
            groups[g].append((robot.links[j.child], T))
            placed[j.child] = (g, T)
    chain_links = [base] + [j.child for j in chain]
    stack = [(ln, child) for ln in chain_links for child in robot.child_joints(ln)][::-1]
    while stack:
        hanger, j = stack.pop()
        if j.name in on_chain:
            continue
        if j.type in ("floating", "planar"):
            issues.append(
                _issue(
                    robot,
                    j,
                    f"joint[{j.name}].type",
                    f"a {j.type} joint hangs on the chain at '{hanger}'; rworld devices are serial "
                    "chains with fixed bases",
                )
            )
            continue
        if j.type in MOVING:
            warnings.append(
                _issue(
                    robot,
                    j,
                    f"joint[{j.name}]",
                    f"{j.type} joint '{j.name}' is off the chain {base} -> {tip}: locked at "
                    f"{locked.get(j.name, 0.0):g} (--lock {j.name}=VALUE), and '{j.child}' "
                    "merged into the link it hangs on",
                    "warning",
                )
            )
        g, T_head_parent = placed[hanger]
        T = T_head_parent @ j.origin
        if j.type in MOVING and locked.get(j.name, 0.0) != 0.0:
            T = T @ spatial.joint_frame(np.eye(4), j.axis, locked[j.name], j.type == "prismatic")
        groups[g].append((robot.links[j.child], T))
        placed[j.child] = (g, T)
        stack.extend((j.child, c) for c in reversed(robot.child_joints(j.child)))
    if issues:
        raise UserError(f"invalid: {robot.file}: {len(issues)} error(s)", issues + warnings)

    meshes: dict[str, bytes] = {}
    merged: dict[str, list[str]] = {}
    poses: dict[str, dict] = {device: {"xyz": [0.0, 0.0, 0.0]}}
    moving = [j for j in chain if j.type in MOVING]
    heads = [names(group[0][0].name) for group in groups]
    # the TCP: --tcp, else the link the vendors' packages name as a tool frame (TOOL_FRAMES:
    # 'tcp' as 'rworld export urdf' writes it, ROS-Industrial's and UR's 'tool0', Kinova's
    # 'tool_frame', ...; a prefix before the name allowed), else the tip.  A merged link
    # becomes the TCP itself; a moving link gets a TCP frame 'tcp' on it.
    named = _tool_frame(placed, len(groups) - 1)
    tcp_link = tcp or named or tip
    if tcp is None:
        last = len(groups) - 1
        said = _tcp_words(placed, last, groups[last][0][0].name, tcp_link, named is not None)
        if said:
            warnings.append(Issue(robot.file, 0, 0, "tcp", said, "warning"))
    if tcp_link not in placed:
        raise UserError(
            f"{robot.file}: --tcp '{tcp_link}' is not on the imported part (the chain {base} -> "
            f"{tip} and the links fixed to it)"
        )
    tcp_group, T_head_tcp = placed[tcp_link]
    if tcp_group == 0:
        raise UserError(
            f"{robot.file}: --tcp '{tcp_link}' is fixed to the base; a TCP moves with the chain"
        )
    for name in placed:  # URDF names first: the TCP frame's own name must not take one
        names(name)
    if robot.links[tcp_link] is groups[tcp_group][0][0]:  # a moving link (or the base)
        tcp_doc: dict = {"name": names.fresh("tcp")}
        poses[f"{device}.{tcp_doc['name']}"] = {"xyz": [0.0, 0.0, 0.0]}
    else:
        tcp_doc = {"name": names(tcp_link)}
        poses[f"{device}.{tcp_doc['name']}"] = _pose(T_head_tcp)
    if tcp_group != len(groups) - 1:
        tcp_doc["parent"] = heads[tcp_group]
    link_docs: list[dict] = []
    base_doc: dict = {}
    for k, group in enumerate(groups):
        head = heads[k]
        owner = device if k == 0 else head
        parts = []
        geometry: list[tuple[UrdfGeometry, np.ndarray]] = []
        frames = []
        for link, T in group:
            if link.inertial is not None:
                parts.append((link.inertial, T))
            elif k > 0 and (link.geometry or link is group[0][0]):  # the base's mass is moot
                warnings.append(
                    _issue(
                        robot,
                        link,
                        f"link[{link.name}]",
                        f"link '{link.name}' has no <inertial>: imported massless",
                        "warning",
                    )
                )
            for shape in link.geometry:
                if shape.kind == "mesh" and shape.mesh_file is None:
                    issues.append(_issue(robot, shape, f"link[{link.name}].mesh", shape.problem))
                geometry.append((shape, T @ shape.T_link_geometry))
            if link is not group[0][0] and link.name != tcp_link:
                frame = names(link.name)
                frames.append({"name": frame})
                poses[f"{device}.{frame}"] = _pose(T)
        merged[owner] = [link.name for link, _ in group]
        doc: dict = {}
        if k > 0:
            doc["name"] = head
            inertial = Inertial.combine(parts) if parts else Inertial.zero()
            doc["mass"] = float(inertial.mass)
            doc["com"] = [float(x) for x in inertial.com]
            doc["inertia"] = inertia_entries(inertial.inertia)
        if geometry and not any(g.kind == "mesh" and g.mesh_file is None for g, _ in geometry):
            doc["geometry"] = _geometry_doc(robot, owner, geometry, meshes)
            entry = doc["geometry"].get("mesh")
            repair = _closed_or_surface(owner, entry["file"], meshes, entry) if entry else None
            if repair:  # said once, here; later commands read the repair or the mark
                warnings.append(
                    _issue(
                        robot, geometry[0][0], f"link[{group[0][0].name}].mesh", repair, "warning"
                    )
                )
        if frames:
            doc["frames"] = frames
        if k == 0:
            base_doc = doc
        else:
            link_docs.append(doc)
    if issues:
        raise UserError(f"invalid: {robot.file}: {len(issues)} error(s)", issues + warnings)

    stated = dict(joint_limits.limits) if joint_limits is not None else {}
    # joints the robot does not have (a MoveIt config's gripper joints, another arm's): said
    # where the file names them, and skipped
    for name in [n for n in stated if n not in robot.joints]:
        del stated[name]
        assert joint_limits is not None
        file, line, column = joint_limits.marks[name]
        warnings.append(
            Issue(
                file,
                line,
                column,
                name,
                f"the joint limits name '{name}', a joint the robot does not have"
                f"{did_you_mean(name, robot.joints)}: skipped",
                "warning",
            )
        )
    without = [j for j in moving if "acceleration" not in stated.get(j.name, {})]
    if without:
        first = without[0]
        warnings.append(
            _issue(
                robot,
                first,
                f"joint[{first.name}].limit",
                f"no acceleration limit for {', '.join(j.name for j in without)} (URDF has none, "
                "and the simulator times joint moves with them): give the vendor package's "
                "joint_limits.yaml with --joint-limits, or add 'acceleration' to those joints' "
                "limits in cell.yaml before simulating",
                "warning",
            )
        )
    # joints: each origin from the previous moving link's frame, through the fixed joints between
    joint_docs = []
    for j in moving:
        _, T_head_parent = placed[j.parent]
        doc = {"name": names(j.name), "type": j.type}
        origin = _pose(T_head_parent @ j.origin)
        if np.any(origin["xyz"]) or "rpy" in origin:
            doc["origin"] = origin
        if not np.allclose(j.axis, [0.0, 0.0, 1.0], rtol=0.0, atol=0.0):
            doc["axis"] = [float(x) for x in j.axis]
        limits: dict = {}
        if j.type != "continuous" and np.isfinite(j.lower) and np.isfinite(j.upper):
            limits["position"] = [float(j.lower), float(j.upper)]
        from_file = stated.get(j.name, {})
        if np.isfinite(j.velocity) or "velocity" in from_file:
            limits["velocity"] = float(from_file.get("velocity", j.velocity))
        if "acceleration" in from_file:
            limits["acceleration"] = from_file["acceleration"]
        if np.isfinite(j.effort) or "effort" in from_file:
            limits["effort"] = float(from_file.get("effort", j.effort))
        if limits:
            doc["limits"] = limits
        if j.damping or j.friction:
            doc["friction"] = {"viscous": float(j.damping), "coulomb": float(j.friction)}
        joint_docs.append(doc)
    device_doc: dict = {"name": device, "dof": len(moving), "joints": joint_docs}
    device_doc["links"] = link_docs
    device_doc["tcps"] = [tcp_doc]
    if "geometry" in base_doc:
        device_doc["geometry"] = base_doc["geometry"]
    if "frames" in base_doc:
        device_doc["frames"] = base_doc["frames"]
    # kept for 'export urdf': the URDF's own name of the base link (a URDF link may be 'world')
    base_link = re.sub(r"[^A-Za-z0-9_\-]", "_", base)
    base_link = base_link if re.match(NAME_PATTERN, base_link) else "_" + base_link
    if base_link != device:
        device_doc["base_link"] = base_link
    # the controller's frames, as the vendors' ROS description packages name them: 'tool0' is
    # the flange (ROS-Industrial, ur_description), 'base' the controller's base frame
    controller: dict = {}
    last = len(groups) - 1
    if "tool0" in placed and placed["tool0"][0] == last:
        controller["flange"] = names("tool0")
    if "base" in placed and placed["base"][0] == 0 and base != "base":
        controller["base"] = names("base")
    package = _package_of(robot.file)
    vendor, j23 = vendor_conventions(robot.name, package)
    if vendor is None:
        warnings.append(
            Issue(
                robot.file,
                0,
                0,
                "controller",
                f"no controller vendor recognised from the robot's name '{robot.name}'"
                + (f" or its package '{package}'" if package else "")
                + ": 'export program' then needs --format; or set 'controller: {vendor: ...}' "
                "in cell.yaml (abb, fanuc, kuka, kuka_sunrise, ur, yaskawa, staubli, doosan)",
                "warning",
            )
        )
    if vendor is not None:  # named even where the URDF has no tool0 or base (Doosan's)
        controller = {"vendor": vendor, **controller}
        moving_revolute = [j for j in moving if j.type in ("revolute", "continuous")]
        if j23 and len(moving) == 6 and len(moving_revolute) == 6:
            axes: list[dict] = [{} for _ in moving]
            axes[2] = {"coupling": {"joint": names(moving[1].name), "factor": j23}}
            controller["axes"] = axes
    if controller:
        device_doc["controller"] = controller
        said = " and ".join(
            f"{key} '{value}'" for key, value in controller.items() if key != "axes"
        )
        if "axes" in controller:
            said += (
                f", and axis 3 counting {j23:+g} x joint 2 (the parallel linkage, as "
                "ROS-Industrial's driver for this robot does)"
            )
        if "flange" not in controller:
            said += " (no 'tool0' link: tool data in the last link's frame)"
        if "base" not in controller and base != "base":
            said += " (no 'base' link: targets in the device's natural frame)"
        warnings.append(
            Issue(
                robot.file,
                0,
                0,
                "controller",
                f"assumed the controller's {said}, as the vendors' ROS packages name them "
                "(tool data and targets are exported in them; change 'controller:' in cell.yaml "
                "if this robot's controller differs)",
                "warning",
            )
        )
    # comments carry text from the URDF (its path, link names): one line each, escaped
    source, chain_text = comment_text(robot.file), comment_text(f"{base} -> {tip}")
    head = (
        _schema_line(schemas, "cell.schema.json")
        + f"# Imported by 'rworld import urdf' from {source}: the chain {chain_text}.\n"
        "# Joints are given by their frames (origin, axis) as in the URDF; links fixed to a\n"
        "# moving link are merged into it and kept as frames (their poses are in poses.yaml).\n"
    )
    # where each rworld name shows: a URDF name renamed but merged away shows nowhere
    shows = {device: f"the device {device}"}
    shows |= {doc["name"]: f"joint {device}.{doc['name']}" for doc in joint_docs}
    shows |= {h: f"link {device}.{h}" for h in heads[1:]}  # the base is the device
    shows |= {k.split(".", 1)[1]: f"frame {k}" for k in poses if k.startswith(f"{device}.")}
    renamed_where = {a: shows[b] for a, b in names.renamed.items() if b in shows}
    renamed_shown = {a: b for a, b in names.renamed.items() if a in renamed_where}
    if renamed_shown:
        renamed = ", ".join(f"{a} -> {b}" for a, b in renamed_shown.items())
        head += f"# Renamed: {comment_text(renamed)}\n"
    cell_doc = {
        "name": _Names()(cell_name),  # the folder's name, made a name ('0mm' -> '_0mm')
        "description": f"{robot.name} imported from URDF",
        "units": {"length": "m", "angle": "rad"},
        "pose_files": ["poses.yaml"],
        "devices": [device_doc],
    }
    allowed = _allowed_from_srdf(disabled, placed, heads, device)
    allowed_pairs = {tuple(entry["between"]) for entry in allowed}
    for a, b, reason in always:
        if (min(a, b), max(a, b)) not in allowed_pairs:
            allowed.append({"between": [min(a, b), max(a, b)], "reason": reason})
    if allowed:
        cell_doc["allowed_contacts"] = allowed
    cell_text = head + yaml.dump(cell_doc, Dumper=_Dumper, sort_keys=False, width=100)
    poses_text = (
        _schema_line(schemas, "poses.schema.json")
        + f"# Poses of the frames of '{device}' (imported from {source}); calibration may\n"
        "# change these numbers.\n"
        + yaml.dump(
            {"units": {"length": "m", "angle": "rad"}, "poses": poses},
            Dumper=_Dumper,
            sort_keys=False,
            width=100,
        )
    )
    return ImportedCell(
        cell_text,
        poses_text,
        meshes,
        device,
        [j.name for j in chain],
        base,
        tip,
        tcp_link,
        merged,
        renamed_shown,
        warnings,
        renamed_where,
    )


def _geometry_doc(
    robot: UrdfRobot, owner: str, parts: list[tuple[UrdfGeometry, np.ndarray]], meshes: dict
) -> dict:
    """One geometry entry for the shapes of a merged link (``T_link_shape`` each)."""
    if len(parts) == 1:
        g, T = parts[0]
        origin = _pose(T)
        doc: dict = {}
        if g.kind == "box":
            doc["box"] = [float(x) for x in g.size]
        elif g.kind == "cylinder":
            doc["cylinder"] = {"radius": float(g.size[0]), "length": float(g.size[1])}
        elif g.kind == "sphere":
            doc["sphere"] = {"radius": float(g.size[0])}
        uniform = g.kind == "mesh" and np.allclose(g.mesh_scale, g.mesh_scale[0], rtol=0, atol=0)
        if (
            g.kind == "mesh"
            and uniform
            and g.mesh_scale[0] in (1.0, 0.001)
            and g.mesh_file is not None
            and g.mesh_file.suffix.lower() in MESH_SUFFIXES
        ):
            name = f"meshes/{owner}{g.mesh_file.suffix.lower()}"
            _checked_mesh(robot, g)  # copied as it is, once it reads as a solid's surface
            meshes[name] = g.mesh_file.read_bytes()
            doc["mesh"] = {"file": name, "units": "m" if g.mesh_scale[0] == 1.0 else "mm"}
        elif g.kind == "mesh":
            name = f"meshes/{owner}.stl"
            meshes[name] = _mesh_bytes(robot, [(g, np.eye(4))])
            doc["mesh"] = {"file": name, "units": "m"}
        if np.any(origin["xyz"]) or "rpy" in origin:
            doc["origin"] = origin
        return doc
    name = f"meshes/{owner}.stl"
    meshes[name] = _mesh_bytes(robot, parts)
    return {"mesh": {"file": name, "units": "m"}}


# --------------------------------------------------------------------------- out
