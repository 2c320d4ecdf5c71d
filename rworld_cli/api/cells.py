"""Cells and files: validate, show, the JSON Schemas."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import Issue, UserError

# --------------------------------------------------------------------------- validate


@dataclass
class FileReport:
    """The outcome of validating one file."""

    file: str
    kind: str  # "cell" | "poses" | "program" | "run"
    errors: list[Issue] = field(default_factory=list)
    warnings: list[Issue] = field(default_factory=list)
    summary: str = ""

    @property
    def valid(self) -> bool:
        return not self.errors

    def as_dict(self) -> dict:
        return {
            "file": self.file,
            "kind": self.kind,
            "valid": self.valid,
            "summary": self.summary,
            "errors": [i.as_dict() for i in self.errors],
            "warnings": [i.as_dict() for i in self.warnings],
        }


def _file_kind(path: Path):
    """(kind, parsed document or None): 'cell', 'poses', 'program' or 'run', from the top-level
    keys.

    A directory means its cell.yaml.  A file that cannot be read or parsed is
    treated as a cell, so the cell loader reports the problem with its location.
    """
    if path.is_dir():
        return "cell", None
    from ..schema.yamlio import read_yaml

    try:
        doc = read_yaml(path)
    except UserError:
        return "cell", None
    if isinstance(doc.data, dict) and "name" not in doc.data:
        for key, kind in (
            ("poses", "poses"),
            ("steps", "program"),
            ("programs", "run"),
            ("waypoints", "path"),
            ("features", "measurements"),
        ):
            if key in doc.data:
                return kind, doc
    return "cell", doc


def _cell_of(path: Path, cell: str | None) -> str | None:
    """The cell a path file is checked against: ``cell``, else the cell whose ``paths/`` folder
    holds it.
    """
    if cell is not None:
        return cell
    home = path.resolve().parent
    if home.name == "paths" and (home.parent / "cell.yaml").is_file():
        return os.path.relpath(home.parent / "cell.yaml")
    return None


def _validate_path_file(raw: str, doc, cell: str | None) -> str:
    """Check a path file (and against its cell, when one is known); returns the summary."""
    from ..errors import did_you_mean
    from ..schema.loader import load_cell, validate_document
    from ..schema.program import PathFile

    pf = validate_document(doc, PathFile)
    cell_path = _cell_of(Path(raw), cell)
    if cell_path is None:
        return (
            f"{len(pf.waypoints)} waypoint(s); checked against a cell with --cell CELL "
            "(or when the file is in the cell's paths/ folder)"
        )
    devices = load_cell(cell_path).cell.devices
    name = pf.device or (next(iter(devices)) if len(devices) == 1 else None)
    if name is None:
        raise UserError(
            f"{raw}: name the device",
            [
                doc.issue(
                    (),
                    f"the cell has {len(devices)} devices ({', '.join(devices)}): "
                    "say which one the path is for with 'device:'",
                )
            ],
        )
    if name not in devices:
        raise UserError(
            f"{raw}: unknown device",
            [
                doc.issue(
                    ("device",),
                    f"'{name}' is not a device of {cell_path}{did_you_mean(name, devices)}",
                )
            ],
        )
    from .paths import path_file_issues

    issues = path_file_issues(raw, devices[name])
    if issues:
        raise UserError(
            f"{raw}: the path leaves a joint's position range between waypoints", issues
        )
    return (
        f"{len(pf.waypoints)} waypoint(s) for {name}, within its position range all along "
        f"(checked against {cell_path})"
    )


def _validate_measurement_file(raw: str, doc, cell: str | None) -> str:
    """Check a measurement file's form, and against ``cell`` (its features, point counts) when
    given.
    """
    from ..schema.loader import load_cell, validate_document
    from ..schema.measurements import MeasurementFile, load_measurements

    mf = validate_document(doc, MeasurementFile)
    points = sum(len(f.points) for f in mf.features.values())
    if cell is None:
        return (
            f"{len(mf.features)} feature(s), {points} point(s); checked against a cell with "
            "--cell CELL (or by 'rworld calibrate')"
        )
    load_measurements([raw], load_cell(cell).cell)
    return (
        f"{len(mf.features)} feature(s), {points} point(s), every one a feature of {cell} with "
        "enough points"
    )


def validate_files(paths: list[str], cell: str | None = None) -> list[FileReport]:
    """Validate cell files (with the pose files and meshes they name), pose, program, run and path
    files.

    Parameters
    ----------
    paths : list of str
        Cell files, cell directories, pose, program, run or path files, as the user named them.
    cell : str, optional
        The cell that path files are checked against (default: the cell whose ``paths/``
        folder holds the file).

    Returns
    -------
    list of FileReport
        One per path, in order; ``valid`` is False when a file has errors.
    """
    from ..schema.loader import load_cell, resolve_cell_path, validate_document

    reports = []
    for raw in paths:
        kind, doc = _file_kind(Path(raw))
        shown = resolve_cell_path(raw)[1] if kind == "cell" else raw
        report = FileReport(shown, kind)
        try:
            if kind == "cell":
                loaded = load_cell(raw, doc)
                report.warnings = loaded.warnings + _leftovers(shown)
                c = loaded.cell
                report.summary = (
                    f"{len(c.devices)} device(s), {len(c.objects)} object(s), {len(c.sensors)} "
                    "sensor(s), "
                    f"{len(c.frames) - 1} frame(s), {len(c.features)} feature(s), "
                    f"{len(c.conditions)} condition(s)"
                )
            elif kind == "path":
                report.summary = _validate_path_file(raw, doc, cell)
            elif kind == "measurements":
                report.summary = _validate_measurement_file(raw, doc, cell)
            elif kind == "poses":
                from ..schema.models import PoseFile

                pf = validate_document(doc, PoseFile)
                report.summary = (
                    f"{len(pf.poses)} pose(s); frame names are checked when a cell uses this file"
                )
            else:
                from ..schema import program as sp  # program models: built only when needed

                model = sp.ProgramFile if kind == "program" else sp.RunFile
                parsed = validate_document(doc, model)
                count = (
                    f"{len(parsed.steps)} step(s) for {parsed.device}"
                    if kind == "program"
                    else f"{len(parsed.programs)} program(s)"
                )
                report.summary = (
                    f"{count}; names are checked against the cell by 'rworld "
                    "simulate' and 'rworld check'"
                )
        except UserError as exc:
            report.errors = [i for i in exc.issues if i.severity == "error"] or [
                Issue(shown, 0, 0, "(file)", exc.message)
            ]
            report.warnings = [i for i in exc.issues if i.severity == "warning"]
        reports.append(report)
    return reports


def _leftovers(cell_file: str) -> list[Issue]:
    """Warnings for what killed rworld runs left in a cell's folder or beside it (staging
    folders, temporaries, journals); the next command that writes there finishes or removes
    them (docs/architecture.md, "Writes that survive a kill")."""
    from ..fileio import debris_in

    folder = Path(cell_file).parent
    found = debris_in(folder) + [
        p for p in debris_in(folder.parent) if p.name.startswith(f".{folder.name}.rworld-")
    ]
    return [
        Issue(
            str(p),
            0,
            0,
            "(file)",
            "left by a killed rworld run; the next command that writes here finishes or "
            "removes it (or delete it)",
            "warning",
        )
        for p in found
    ]


# --------------------------------------------------------------------------- show


def load_world(cell_path: str, joints: dict[str, list[float]] | None = None):
    """Load a cell and build its runtime :class:`~rworld_cli.world.tree.World`.

    Parameters
    ----------
    cell_path : str
        Cell file or directory.
    joints : dict, optional
        Device name -> joint values (SI) to set instead of the devices' home.

    Returns
    -------
    (World, list of Issue)
        The world and the load warnings.
    """
    from ..schema.loader import load_cell
    from ..world.tree import World

    loaded = load_cell(cell_path)
    world = World(loaded.cell)
    for device, q in (joints or {}).items():
        world.set_joints(device, q)
    return world, loaded.warnings


@dataclass
class FrameNode:
    """One frame of the tree as ``rworld show`` reports it (SI)."""

    name: str
    kind: str  # world | natural | auxiliary | free | link | tcp
    owner: str
    parent: str | None
    primitive: str | None  # object | sensor | device for natural frames
    affixment: dict | None  # {"type", "kind"} for affixed primitives
    T_world: np.ndarray
    mass: float | None = None
    detail: str = ""
    children: list[FrameNode] = field(default_factory=list)

    @property
    def rpy(self) -> np.ndarray:
        """Fixed-axis roll, pitch, yaw of the world pose [rad]."""
        from ..spatial import matrix_to_rpy

        return matrix_to_rpy(self.T_world[:3, :3])

    def as_dict(self) -> dict:
        return {
            "name": self.name,
            "kind": self.kind,
            "owner": self.owner,
            "parent": self.parent,
            "primitive": self.primitive,
            "affixment": self.affixment,
            "xyz": self.T_world[:3, 3].tolist(),
            "rpy": self.rpy.tolist(),
            "T_world": self.T_world.tolist(),
            "mass": self.mass,
            "detail": self.detail,
        }


@dataclass
class CellSummary:
    """What ``rworld show`` prints: the tree with world poses, and per-primitive facts."""

    name: str
    description: str | None
    root: FrameNode
    joints: dict[str, list[float]]
    active_tcps: dict[str, str]
    warnings: list[Issue]
    conditions: list[dict]

    def nodes(self) -> list[FrameNode]:
        out, stack = [], [self.root]
        while stack:
            node = stack.pop()
            out.append(node)
            stack.extend(reversed(node.children))
        return out

    def as_dict(self) -> dict:
        return {
            "cell": self.name,
            "description": self.description,
            "units": {"length": "m", "angle": "rad"},
            "joints": self.joints,
            "active_tcps": self.active_tcps,
            "frames": [n.as_dict() for n in self.nodes()],
            "conditions": self.conditions,
            "warnings": [w.as_dict() for w in self.warnings],
        }


def _detail(cell, name: str) -> tuple[str | None, float | None, str]:
    kind = cell.primitive_kind(name)
    if kind == "object":
        o = cell.objects[name]
        shape = o.shape.kind if o.shape else "no shape"
        return kind, o.inertial.mass, shape
    if kind == "sensor":
        s = cell.sensors[name]
        seg = {"tactile": f" {s.rows}x{s.cols} cells", "proximity": f" {s.slices} slices"}.get(
            s.type, ""
        )
        return kind, None, f"{s.type}{seg}"
    if kind == "device":
        d = cell.devices[name]
        kinds = "".join("R" if j.kind == "revolute" else "P" for j in d.joints)
        given = "joint frames" if d.convention == "frames" else f"{d.convention} DH"
        return kind, d.total_mass, f"{d.dof} DOF {kinds}, {given}"
    return None, None, ""


def summarize_cell(cell_path: str, joints: dict[str, list[float]] | None = None) -> CellSummary:
    """Load a cell and describe its frame tree with world poses (SI).

    Parameters
    ----------
    cell_path : str
        Cell file or directory.
    joints : dict, optional
        Device name -> joint values (SI); default the devices' home values.
    """
    world, warnings = load_world(cell_path, joints)
    cell = world.cell
    poses = world.world_poses()

    def node_of(name: str) -> FrameNode:
        decl = cell.frames[name]
        primitive, mass, detail = (
            _detail(cell, name) if decl.kind == "natural" else (None, None, "")
        )
        aff = world.affixment(name)
        node = FrameNode(
            name=name,
            kind=decl.kind,
            owner=decl.owner,
            parent=world.parent(name),
            primitive=primitive,
            affixment={"type": aff.type, "kind": aff.kind} if aff else None,
            T_world=poses[name],
            mass=mass,
            detail=detail,
        )
        return node

    def build(top: str) -> FrameNode:
        """The tree under ``top``, parents before children (no recursion on its depth)."""
        root = node_of(top)
        stack = [(root, top)]
        while stack:
            node, name = stack.pop()
            node.children = [node_of(c) for c in world.children(name)]
            stack.extend(zip(node.children, world.children(name)))
        return root

    return CellSummary(
        name=cell.name,
        description=cell.description,
        root=build("world"),
        joints={d: world.joints(d).tolist() for d in cell.devices},
        active_tcps={d: world.active_tcp(d) for d in cell.devices},
        warnings=warnings,
        conditions=[
            {"frame": c.frame, "code": c.code, "type": c.name, "features": list(c.features)}
            for c in cell.conditions
        ],
    )


# --------------------------------------------------------------------------- schemas


def schema_documents() -> dict[str, str]:
    """The JSON Schema text of each file format, keyed by file name."""
    from ..schema.jsonschema import schema_documents as documents

    return documents()


def installed_schemas() -> Path | None:
    """A folder that holds this rworld's JSON Schemas, wherever it is installed: the files
    written once into the user's cache (``$RWORLD_CACHE_DIR``, ``~/.cache/rworld``:
    ``schemas/<digest>/``, named by their content, so another version's are beside them).
    What files rworld writes outside the repository point their editor schema at (an imported
    cell, a planned program): right on any machine the files are written on, in any folder.
    None when the cache folder is refused or cannot be written (the files then carry no
    schema line).  Only editors read these files; rworld never reads them back."""
    import hashlib

    from .. import cache
    from ..fileio import atomic_write_text

    documents = schema_documents()
    digest = hashlib.sha256("".join(documents.values()).encode()).hexdigest()[:16]
    top = cache.folder("schemas")
    if top is None:
        return None
    folder = top / digest
    try:
        folder.mkdir(mode=0o700, exist_ok=True)
        for filename, text in documents.items():
            path = folder / filename
            if not path.is_file() or path.read_text(encoding="utf-8") != text:
                atomic_write_text(path, text)
    except OSError:
        return None
    return folder


def write_schemas(directory: str | Path) -> list[Path]:
    """Write every schema into ``directory`` atomically; return the paths written."""
    from ..fileio import atomic_write_text

    written = []
    for filename, text in schema_documents().items():
        path = Path(directory) / filename
        atomic_write_text(path, text)
        written.append(path)
    return written


def stale_schemas(directory: str | Path) -> list[str]:
    """Names of schema files in ``directory`` that are missing or differ from the models."""
    stale = []
    for filename, text in schema_documents().items():
        path = Path(directory) / filename
        if not path.is_file() or path.read_text(encoding="utf-8") != text:
            stale.append(filename)
    return stale


def clearance(cell_path: str, joints: dict[str, list[float]] | None = None):
    """Exact distances of every body pair of a cell in one state (home unless ``joints``).

    Returns
    -------
    (list of PairClearance nearest first, CollisionModel)
    """
    from ..collision.bodies import collision_model
    from ..collision.static import pair_clearances

    world, _ = load_world(cell_path, joints)
    model = collision_model(world.cell)
    return pair_clearances(world, model), model
