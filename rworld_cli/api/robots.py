"""Robots in and out: URDF import to a cell, and a cell's device out to URDF."""

from __future__ import annotations

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
    stated = read_joint_limits(joint_limits) if joint_limits is not None else None
    name = out.resolve().name
    disabled = []
    if srdf is not None:
        from ..schema.srdf import read_srdf

        disabled = read_srdf(srdf)
    try:
        imported = cell_from_urdf(
            robot, name, base, tip, tcp, device_name, locks, disabled, joint_limits=stated
        )
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
            imported = cell_from_urdf(
                robot,
                name,
                base,
                tip,
                tcp,
                device_name,
                locks,
                disabled,
                allow,
                joint_limits=stated,
            )
            atomic_write_bytes(out / "cell.yaml", imported.cell_text.encode())
            loaded = load_cell(staging)
        imported.warnings.extend(warning for _, _, _, warning, _ in overlaps)
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
    from ..schema.loader import load_cell
    from ..schema.urdf import write_urdf
    from ..schema.urdf_cell import urdf_from_cell

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
