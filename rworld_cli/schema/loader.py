"""Load a cell: YAML -> pydantic -> semantic checks -> :class:`CellModel` in SI.

All problems of all files are collected and raised together as one
:class:`~rworld_cli.errors.UserError` whose issues carry ``file:line:col``.
Warnings (suspicious but usable data) ride along in :attr:`LoadedCell.warnings`.

The checks here are the report's rules (sections 2-4 of the world-modelling
paper, section 2 and 5 of the calibration report): unique names, a tree
without cycles, devices may hold objects but objects may not hold devices,
free frames hold only frames, a frame conditioned by a feature belongs to
the feature's owner, plus physical sanity (masses, inertias, limits).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import spatial
from ..errors import Issue, UserError, did_you_mean
from ..model import cell as wm
from ..model import rules
from ..units import ANGLE, LENGTH

if TYPE_CHECKING:  # pydantic, the file models and YAML load when a file is checked
    from pydantic import BaseModel  # (a cell read back from schema.cellcache needs none)

    from . import models as sm
    from .yamlio import Marked

# Which feature kinds each condition accepts (calibration report, section 5).
CONDITION_FEATURE_KINDS = {
    "C1": {"point", "line", "plane", "circle"},
    "C2": {"point", "line", "plane"},
    "C3": {"line", "plane"},
    "C4": {"plane"},
    "C5": {"plane"},
    "C6": {"plane"},
    "C7": {"line", "plane"},
    "C8": {"line", "plane"},
    "C9": {"line", "plane"},
    "C10": {"plane"},
    "C11": {"plane"},
    "C12": {"plane"},
    "C13": {"circle"},
}


@dataclass
class LoadedCell:
    """A loaded cell with the warnings found on the way."""

    cell: wm.CellModel
    warnings: list[Issue] = field(default_factory=list)


def resolve_cell_path(path: str | Path) -> tuple[Path, str]:
    """Accept a cell file or its directory; return (real path, display name)."""
    p = Path(path)
    if p.is_dir():
        p = p / "cell.yaml"
        shown = str(Path(path) / "cell.yaml")
    else:
        shown = str(path)
    return p, shown


MAX_MAGNITUDE = 1e12


def _implausible_numbers(doc: Marked) -> list[Issue]:
    """Numbers beyond +-1e12 in any unit: typos (a missing decimal point), never data.

    Why: derived quantities (G^2, lengths^3, inertias) would overflow or lose
    all precision; refusing them at the edge keeps the math finite.
    """
    found = []
    stack = [((), doc.data)]
    while stack:
        path, value = stack.pop()
        if isinstance(value, dict):
            stack.extend((path + (k,), v) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((path + (i,), v) for i, v in enumerate(value))
        elif (
            isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        ):
            if abs(value) > MAX_MAGNITUDE:
                found.append(
                    doc.issue(
                        path,
                        f"{value!r} is implausibly large (rworld accepts magnitudes up to 1e12)",
                    )
                )
    return found


def validate_document(doc: Marked, model: type[BaseModel]):
    """Validate parsed YAML against a file model; raise UserError with located issues."""
    if not isinstance(doc.data, dict):
        from .messages import describe

        raise UserError(
            "not a mapping",
            [
                doc.issue(
                    (),
                    f"expected a mapping of keys at the top of the file, got {describe(doc.data)}",
                )
            ],
        )
    from pydantic import ValidationError

    from .messages import pydantic_issues

    issues = _implausible_numbers(doc)
    try:
        result = model.model_validate(doc.data)
    except ValidationError as exc:
        issues += pydantic_issues(exc, doc, model)
        result = None
    if issues:
        raise UserError(
            f"{doc.file}: invalid", sorted(set(issues), key=lambda i: (i.line, i.column, i.message))
        )
    return result


def load_cell(
    path: str | Path, doc: Marked | None = None, pose_files: list[str] | None = None
) -> LoadedCell:
    """Load, check and convert a cell file (and the pose files it names).

    Parameters
    ----------
    path : str or Path
        ``cell.yaml`` or the directory holding it.
    doc : Marked, optional
        The file already parsed (``validate`` reads it once to tell its kind).
    pose_files : list of str, optional
        Pose files to read instead of the cell's ``pose_files`` (e.g. the nominal ones, to
        compare with a calibrated overlay); relative to the current folder.

    Returns
    -------
    LoadedCell

    Raises
    ------
    UserError
        With every error (and the warnings) of the cell and its pose files.
    """
    from . import cellcache

    real, shown = resolve_cell_path(path)
    given = None if pose_files is None else [str(Path(f).resolve()) for f in pose_files]
    where = cellcache.entry(real, shown, given)
    kept = cellcache.lookup(where)
    if kept is not None:
        return kept
    from . import models as sm
    from .yamlio import read_yaml

    if doc is None:
        doc = read_yaml(real, shown)
    cell_file = validate_document(doc, sm.CellFile)
    if given is not None:
        cell_file = cell_file.model_copy(update={"pose_files": given})
    builder = _Builder(doc, cell_file, real.parent, Path(shown).parent)
    builder.issues.extend(implausible_values(doc, cell_file.units))
    cell = builder.build(real)
    errors = [i for i in builder.issues if i.severity == "error"]
    ordered = sorted(builder.issues, key=lambda i: (i.file != shown, i.file, i.line, i.column))
    if errors:
        raise UserError(f"{shown}: {len(errors)} error(s)", ordered)
    loaded = LoadedCell(cell, [i for i in ordered if i.severity == "warning"])
    cellcache.store(where, loaded, [(real, doc.digest), *builder.read])
    return loaded


def _file_digest(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


PULSES_PER_DEGREE = (10.0, 100_000.0)  # Yaskawa encoders: a GP7's axes about 1 000 to 2 000
ANGLE_KEYS = {"alpha", "theta", "rpy"}  # keys whose numbers are angles in the file's unit
LENGTH_KEYS = {"a", "d", "xyz", "box", "radius", "length", "point", "center", "size", "com"}
LARGEST_LENGTH = 100.0  # m: a cell is a room; longer is a unit read wrongly


def implausible_values(doc: Marked, units: sm.Units) -> list[Issue]:
    """Warnings for numbers that make sense only in another unit: an angle above a full turn
    in a radian file (``alpha: 90``), a length above 100 m (a link 400 m long)."""
    out: list[Issue] = []
    L = LENGTH[units.length]

    def walk(node, path: tuple, key: str | None) -> None:
        if isinstance(node, dict):
            for k, v in node.items():
                walk(v, path + (k,), k if isinstance(k, str) else key)
            return
        if isinstance(node, list):
            for i, v in enumerate(node):
                walk(v, path + (i,), key)
            return
        if isinstance(node, bool) or not isinstance(node, (int, float)):
            return
        value = float(node)
        if key in ANGLE_KEYS and units.angle == "rad" and abs(value) > 2 * np.pi + 1e-9:
            out.append(
                doc.issue(
                    path,
                    f"{value:g} rad is {abs(value) / (2 * np.pi):.1f} turns: the file's angles "
                    "are in rad (units.angle); is it in deg?",
                    severity="warning",
                )
            )
        elif key in LENGTH_KEYS and abs(value) * L > LARGEST_LENGTH:
            out.append(
                doc.issue(
                    path,
                    f"{value:g} {units.length} is {abs(value) * L:g} m, more than a cell holds "
                    f"({LARGEST_LENGTH:g} m): is the file's length unit (units.length) right?",
                    severity="warning",
                )
            )

    walk(doc.data, (), None)
    return out


def load_pose_file_doc(path: str | Path, display: str | None = None) -> tuple[Marked, sm.PoseFile]:
    """Read and schema-check a pose file on its own (``rworld validate poses.yaml``)."""
    from . import models as sm
    from .yamlio import read_yaml

    doc = read_yaml(path, display)
    return doc, validate_document(doc, sm.PoseFile)


def joint_values(
    device, values, length: float | None, angle: float | None, limits: bool = True
) -> tuple[np.ndarray | None, str | None]:
    """A file's joint values of ``device`` in SI: (q, None), or (None, why not) - the count,
    the file's units (never guessed), finite numbers, within the limits (``limits``)."""
    if len(values) != device.dof:
        return None, f"{len(values)} value(s) for the {device.dof} joint(s) of '{device.name}'"
    scale = [angle if j.kind == "revolute" else length for j in device.joints]
    if any(x is None for x in scale):
        return None, (
            "joint values need the file's units, and rworld never guesses them: add "
            "'units: {length: mm, angle: deg}'"
        )
    q = np.array([float(v) * float(x) for v, x in zip(values, scale)])  # type: ignore[arg-type]
    if not np.all(np.isfinite(q)):
        return None, "a value is not a finite number"
    if limits:
        lower, upper = device.limit_array("lower"), device.limit_array("upper")
        outside = [
            f"{j.name} {q[i]:.6g} outside [{lower[i]:.6g}, {upper[i]:.6g}] (SI)"
            for i, j in enumerate(device.joints)
            if not (lower[i] - 1e-9 <= q[i] <= upper[i] + 1e-9)
        ]
        if outside:
            return None, "beyond the joint limits (a value in the wrong unit?): " + "; ".join(
                outside
            )
    return q, None


def robot_pose_files(cell, device: str) -> list[Path]:
    """The cell's pose files that set ``device``'s joints (``joints:``, ``corrections:`` or
    ``compliance:``: a robot calibration), in order."""
    out = []
    for path in cell.pose_files:
        _, pf = load_pose_file_doc(path)
        names = list(pf.joints) + list(pf.corrections) + list(pf.compliance)
        if any(name.startswith(f"{device}.") for name in names):
            out.append(Path(path))
    return out


def pose_to_matrix(
    pose: sm.Pose, length: float, angle: float
) -> tuple[np.ndarray, str | None, str | None]:
    """Convert a pose spec to ``T`` (SI).  Returns (T, error, warning)."""
    if pose.matrix is not None:
        M = np.array(pose.matrix, dtype=float)
        if not np.allclose(M[3], [0, 0, 0, 1], atol=1e-9):
            return (
                np.eye(4),
                f"the last row of a pose matrix must be [0, 0, 0, 1], got {M[3].tolist()}",
                None,
            )
        err = float(spatial.rotation_error(M[:3, :3]))
        if err > 1e-6:
            return (
                np.eye(4),
                "the matrix's rotation part is not a rotation (|R^T R - I| or |det R - 1| = "
                f"{err:.3g})",
                None,
            )
        T = M.copy()
        T[:3, 3] *= length
        return T, None, None
    p = np.array(pose.xyz if pose.xyz is not None else [0.0, 0.0, 0.0]) * length
    warning = None
    if pose.quaternion_wxyz is not None:
        q = np.array(pose.quaternion_wxyz, dtype=float)
        norm = float(np.linalg.norm(q))
        if norm < 1e-9:
            return (
                np.eye(4),
                "the quaternion is zero; a rotation needs a unit quaternion",
                None,
            )
        if abs(norm - 1.0) > 1e-3:
            warning = f"quaternion norm is {norm:.6g}, not 1; normalised"
        R = spatial.quat_to_matrix(q)
    elif pose.rpy is not None:
        R = spatial.rpy_to_matrix(np.array(pose.rpy) * angle)
    else:
        R = np.eye(3)
    return spatial.make_transform(R, p), None, warning


MESH_FACTS_FORMAT = 1  # bump when the facts change: old cache files are then never looked up


@functools.lru_cache(maxsize=64)
def _mesh_facts(file: str, mtime_ns: int, size: int):
    """(T_mesh_obb, obb extents, extents, watertight) of a mesh file in its own units, or an error
    text.

    Cached in the process on (path, mtime, size): cells are reloaded often (validate,
    simulate).  Cached on disk, beside the compiled kernels, on the file's content: a command
    on a meshed cell then neither imports trimesh nor parses a mesh (the Panda's seven meshes
    cost a second of every command's start otherwise).
    """
    import hashlib
    import json

    from .. import cache

    content = Path(file).read_bytes()
    name = hashlib.sha256(f"{MESH_FACTS_FORMAT}|".encode() + content).hexdigest()[:40] + ".json"
    stored = cache.read("meshes", name)  # authenticated (rworld_cli.cache) before it is parsed
    try:
        if stored is None:
            raise ValueError("not cached")
        data = json.loads(stored)
        if isinstance(data, str):
            return data
        return (
            np.array(data["T_mesh_obb"], dtype=float).reshape(4, 4),
            np.array(data["obb_extents"], dtype=float).reshape(3),
            np.array(data["extents"], dtype=float).reshape(3),
            bool(data["watertight"]),
        )
    except (ValueError, KeyError, TypeError):
        pass  # not cached yet, or of another layout: computed again
    from .meshfile import read_mesh

    tm, problem = read_mesh(file)
    if tm is None:
        facts: object = problem
        data = problem
    else:
        obb = tm.bounding_box_oriented.primitive
        facts = (
            np.array(obb.transform, dtype=float),
            np.array(obb.extents, dtype=float),
            np.array(tm.extents, dtype=float),
            bool(tm.is_watertight),
        )
        data = {
            "T_mesh_obb": facts[0].tolist(),
            "obb_extents": facts[1].tolist(),
            "extents": facts[2].tolist(),
            "watertight": facts[3],
        }
    cache.write("meshes", name, json.dumps(data).encode())  # a read-only cache: still right
    return facts


class _Builder:
    """One pass over a validated cell file: checks, unit conversion, model."""

    def __init__(self, doc: Marked, cf: sm.CellFile, base_dir: Path, display_dir: Path):
        self.doc = doc
        self.cf = cf
        self.base_dir = base_dir
        self.display_dir = display_dir
        self.L = LENGTH[cf.units.length]
        self.A = ANGLE[cf.units.angle]
        self.issues: list[Issue] = []
        self.frames: dict[str, wm.FrameDecl] = {}
        self.frame_paths: dict[
            str, tuple
        ] = {}  # frame -> path of its declaration (its 'name' value)
        self.primitives: dict[str, tuple[str, tuple]] = {}  # name -> (kind, path)
        self.features: dict[str, wm.Feature] = {}
        self.feature_paths: dict[str, tuple] = {}
        self.fixed_poses: dict[str, np.ndarray] = {}  # frames of fixed joints' links: T_parent
        # files read besides the cell file (pose files, meshes), each with the digest of its
        # bytes when read: what the cell cache records (cellcache.store)
        self.read: list[tuple[Path, str]] = []

    # ------------------------------------------------------------------ helpers
    def err(self, path, message, prefer="value", doc: Marked | None = None):
        self.issues.append((doc or self.doc).issue(path, message, prefer=prefer))

    def warn(self, path, message, prefer="value", doc: Marked | None = None):
        self.issues.append(
            (doc or self.doc).issue(path, message, prefer=prefer, severity="warning")
        )

    def _line(self, path) -> int:
        return self.doc.position(path)[0]

    def _add_frame(self, decl: wm.FrameDecl, path: tuple) -> bool:
        if decl.name in self.frames:
            self.err(
                path,
                f"duplicate frame name '{decl.name}' (first declared at line "
                f"{self._line(self.frame_paths[decl.name])})",
            )
            return False
        self.frames[decl.name] = decl
        self.frame_paths[decl.name] = path
        return True

    def _vec(self, values, scale=1.0) -> np.ndarray:
        return np.array(values, dtype=float) * scale

    def _unit(self, path, values, what: str) -> np.ndarray | None:
        v = np.array(values, dtype=float)
        n = float(np.linalg.norm(v))
        if n < 1e-12:
            self.err(path, f"{what} is zero; it needs a direction")
            return None
        return v / n

    # ------------------------------------------------------------------ build
    def build(self, cell_path: Path) -> wm.CellModel:
        cf = self.cf
        self.frames[wm.WORLD] = wm.FrameDecl(wm.WORLD, "world", wm.WORLD, None)
        self.frame_paths[wm.WORLD] = ()
        self._register_primitives()
        objects = {
            o.name: self._object(i, o)
            for i, o in enumerate(cf.objects)
            if self._owns(o.name, ("objects", i))
        }
        sensors = {
            s.name: self._sensor(i, s)
            for i, s in enumerate(cf.sensors)
            if self._owns(s.name, ("sensors", i))
        }
        devices = {}
        for i, d in enumerate(cf.devices):
            if self._owns(d.name, ("devices", i)):
                dev = self._device(i, d)
                if dev is not None:
                    devices[d.name] = dev
        self._free_frames()
        self._check_owned_parents()
        affixments = self._affixments()
        conditions = self._conditions()
        poses, sources, files, origins, compliances = self._poses(devices)
        for name, replaced in origins.items():  # joint frames, or DH rows' corrections
            dev = devices[name]
            key = "origin" if dev.convention == "frames" else "correction"
            joints = tuple(
                dataclasses.replace(j, **{key: replaced[j.name]}) if j.name in replaced else j
                for j in dev.joints
            )
            devices[name] = dataclasses.replace(dev, joints=joints)
        for name, values in compliances.items():  # the joints' compliance under load
            dev = devices[name]
            joints = tuple(
                dataclasses.replace(j, compliance=values[j.name]) if j.name in values else j
                for j in dev.joints
            )
            devices[name] = dataclasses.replace(dev, joints=joints)
        self._check_cycles(affixments)
        allowed = self._allowed_contacts(objects, devices)
        return wm.CellModel(
            name=cf.name,
            path=cell_path,
            gravity=np.array(cf.gravity, dtype=float),
            frames=self.frames,
            objects=objects,
            sensors=sensors,
            devices=devices,
            features=self.features,
            conditions=conditions,
            affixments=affixments,
            poses=poses,
            pose_files=files,
            pose_sources=sources,
            description=cf.description,
            allowed_contacts=allowed,
        )

    def _allowed_contacts(self, objects, devices) -> tuple[wm.AllowedContactDecl, ...]:
        bodies = body_names(objects, devices)
        out = []
        for i, group in enumerate(self.cf.allowed_contacts):
            ok = True
            for k, name in enumerate(group.between):
                if name not in bodies:
                    self.err(
                        ("allowed_contacts", i, "between", k),
                        f"unknown object, device or link '{name}'{did_you_mean(name, bodies)}",
                    )
                    ok = False
            if ok:
                out.append(wm.AllowedContactDecl(tuple(group.between), group.reason))
        return tuple(out)

    def _owns(self, name, path) -> bool:
        return self.primitives.get(name, (None, None))[1] == path

    def _register_primitives(self):
        groups = (
            ("objects", "object"),
            ("sensors", "sensor"),
            ("devices", "device"),
            ("frames", "free"),
        )
        for key, kind in groups:
            for i, item in enumerate(getattr(self.cf, key)):
                path = (key, i, "name")
                if item.name == wm.WORLD:
                    self.err(path, "'world' is the name of the world frame; choose another name")
                    continue
                if item.name in self.primitives:
                    _, first = self.primitives[item.name]
                    self.err(
                        path,
                        f"duplicate name '{item.name}' "
                        f"(first declared at line {self._line(first)})",
                    )
                    continue
                self.primitives[item.name] = (kind, (key, i))
                if kind != "free":
                    self._add_frame(wm.FrameDecl(item.name, "natural", item.name, None), path)

    # ------------------------------------------------------------------ mass, shape
    def _inertial(self, path, mass, com, inertia: sm.Inertia | None) -> wm.Inertial:
        I = np.zeros((3, 3))
        if inertia is not None:
            I = inertia_matrix(inertia.model_dump())
            ipath = path + ("inertia",)
            problem = inertia_problem(I)
            moments = np.linalg.eigvalsh(I)
            scale = max(1.0, float(np.abs(moments).max()))
            if problem is not None:
                self.err(ipath, problem)
            elif moments[2] > moments[0] + moments[1] + 1e-9 * scale:
                self.warn(
                    ipath,
                    f"principal moments {', '.join(f'{m:.6g}' for m in moments)} kg m^2 break the "
                    "triangle inequality "
                    "(largest <= sum of the others): no rigid body has this inertia",
                )
        return wm.Inertial(float(mass), self._vec(com, self.L), I)

    def _shape(self, path, g: sm.Geometry | None) -> wm.Shape | None:
        if g is None:
            return None
        T = np.eye(4)
        if g.origin is not None:
            T, error, warning = pose_to_matrix(g.origin, self.L, self.A)
            if error:
                self.err(path + ("origin",), error)
            if warning:
                self.warn(path + ("origin",), warning)
        if g.box is not None:
            size = self._vec(g.box, self.L)
            return wm.Shape("box", T, size, wm.Box(T, size / 2))
        if g.cylinder is not None:
            r, h = g.cylinder.radius * self.L, g.cylinder.length * self.L
            size = np.array([2 * r, 2 * r, h])
            return wm.Shape("cylinder", T, size, wm.Box(T, size / 2))
        if g.sphere is not None:
            size = np.full(3, 2 * g.sphere.radius * self.L)
            return wm.Shape("sphere", T, size, wm.Box(T, size / 2))
        return self._mesh_shape(path + ("mesh",), g.mesh, T)

    def _mesh_shape(self, path, mesh: sm.Mesh, T: np.ndarray) -> wm.Shape | None:
        file = self.base_dir / mesh.file
        if not file.is_file():
            self.err(path + ("file",), f"no such mesh file: {self.display_dir / mesh.file}")
            return None
        if file.suffix.lower() not in (".stl", ".obj", ".ply"):
            self.err(
                path + ("file",), f"unsupported mesh format '{file.suffix}'; use .stl, .obj or .ply"
            )
            return None
        stat = file.stat()
        self.read.append((file, _file_digest(file)))  # before the facts are read: a later
        # change of the file then never matches, and the entry is not used
        facts = _mesh_facts(str(file.resolve()), stat.st_mtime_ns, stat.st_size)
        if isinstance(facts, str):
            self.err(path + ("file",), facts)
            return None
        T_mesh_box, extents, size, watertight = facts
        scale = LENGTH[mesh.units or self.cf.units.length]
        if not watertight:
            self.warn(
                path + ("file",),
                f"the mesh of '{self._body_name(path)}' is not closed (watertight): sensing and "
                "collision checks treat it as a surface, so a body inside it goes unnoticed",
            )
        T_mesh_box = T_mesh_box.copy()
        T_mesh_box[:3, 3] *= scale
        box = wm.Box(T @ T_mesh_box, extents * scale / 2)
        return wm.Shape(
            "mesh", T, size * scale, box, mesh_file=file, mesh_scale=scale, closed=watertight
        )

    def _body_name(self, path: tuple) -> str:
        """'table' or 'robot.link3' for a geometry entry's path."""
        if path[0] == "objects":
            return self.cf.objects[path[1]].name
        device = self.cf.devices[path[1]]
        if len(path) > 3 and path[2] == "links":
            return f"{device.name}.{device.links[path[3]].name}"
        return device.name

    def _aux_frames(
        self,
        owner: str,
        frames: list[sm.AuxFrame],
        path: tuple,
        default_parent: str,
        kind="auxiliary",
    ):
        for j, f in enumerate(frames):
            parent = f"{owner}.{f.parent}" if f.parent else default_parent
            self._add_frame(
                wm.FrameDecl(f"{owner}.{f.name}", kind, owner, parent), path + (j, "name")
            )

    def _features(self, owner: str, features: list[sm.Feature], path: tuple):
        for j, f in enumerate(features):
            fpath = path + (j,)
            qname = f"{owner}.{f.name}"
            if qname in self.features:
                self.err(
                    fpath + ("name",),
                    f"duplicate feature name '{f.name}' in '{owner}' (first at line "
                    f"{self._line(self.feature_paths[qname])})",
                )
                continue
            if f.point is not None:
                feat = wm.Feature(qname, owner, "point", self._vec(f.point, self.L))
            elif f.line is not None:
                u = self._unit(
                    fpath + ("line", "direction"), f.line.direction, "the line's direction"
                )
                feat = wm.Feature(qname, owner, "line", self._vec(f.line.point, self.L), u)
            elif f.plane is not None:
                u = self._unit(fpath + ("plane", "normal"), f.plane.normal, "the plane's normal")
                feat = wm.Feature(qname, owner, "plane", self._vec(f.plane.point, self.L), u)
            else:
                c = f.circle
                u = self._unit(fpath + ("circle", "normal"), c.normal, "the circle's normal")
                feat = wm.Feature(
                    qname, owner, "circle", self._vec(c.center, self.L), u, c.radius * self.L
                )
            self.features[qname] = feat
            self.feature_paths[qname] = fpath + ("name",)

    # ------------------------------------------------------------------ primitives
    def _object(self, i: int, o: sm.RigidObject) -> wm.ObjectModel:
        path = ("objects", i)
        self._aux_frames(o.name, o.frames, path + ("frames",), o.name)
        self._features(o.name, o.features, path + ("features",))
        return wm.ObjectModel(
            o.name,
            self._inertial(path, o.mass, o.com, o.inertia),
            self._shape(path + ("geometry",), o.geometry),
        )

    def _sensor(self, i: int, s: sm.Sensor) -> wm.SensorModel:
        path = ("sensors", i)
        self._aux_frames(s.name, s.frames, path + ("frames",), s.name)
        needs = {"tactile": "segments", "proximity": "slices", "force": "force_curve"}
        for key in ("segments", "slices", "force_curve"):
            given = getattr(s, key) is not None
            wanted = needs.get(s.type) == key
            if given and not wanted:
                self.err(
                    path + (key,),
                    f"'{key}' applies to {next(t for t, k in needs.items() if k == key)} sensors, "
                    f"not to a {s.type} sensor",
                    prefer="key",
                )
            if wanted and not given:
                self.err(path, f"a {s.type} sensor needs '{key}'")
        curve = None
        if s.force_curve is not None:
            curve = np.array(s.force_curve, dtype=float)
            cpath = path + ("force_curve",)
            if len(curve) < 2:
                self.err(
                    cpath,
                    f"a force curve needs at least 2 [volume, force] points, got {len(curve)}",
                )
            elif np.any(curve[:, 0] < 0) or np.any(np.diff(curve[:, 0]) <= 0):
                self.err(cpath, "overlap volumes must be >= 0 and strictly increasing")
            elif np.any(curve[:, 1] < 0):
                self.err(cpath, "forces must be >= 0")
            curve = curve * np.array([self.L**3, 1.0])
        ball = None
        if s.ball is not None:
            if s.type != "touch":
                self.err(path + ("ball",), f"a ball tip is for touch sensors, not {s.type} sensors")
            if s.size is not None:
                self.err(
                    path + ("size",),
                    "a ball-tip probe has no box: give 'ball' (its radius) or 'size', not both",
                    prefer="key",
                )
            ball = float(s.ball) * self.L
            size = np.full(3, 2 * ball)
        elif s.size is None:
            self.err(
                path,
                f"a {s.type} sensor needs 'size' (its box)"
                + (" or 'ball' (a ball tip's radius)" if s.type == "touch" else ""),
            )
            size = np.ones(3)
        else:
            size = self._vec(s.size, self.L)
        return wm.SensorModel(
            name=s.name,
            type=s.type,
            size=size,
            ball=ball,
            rows=s.segments.rows if s.segments else 1,
            cols=s.segments.cols if s.segments else 1,
            slices=s.slices or 1,
            force_curve=curve,
        )

    def _device(self, i: int, d: sm.Device) -> wm.DeviceModel | None:
        from . import models as sm

        path = ("devices", i)
        ok = True
        by_frames = d.dh is None
        moving = [j for j, row in enumerate(d.joints) if row.type != "fixed"]
        if len(moving) != d.dof:
            what = (
                f"the DH table has {len(d.joints)} row(s)"
                if not by_frames
                else f"{len(moving)} of the {len(d.joints)} joint(s) move"
            )
            self.err(path + ("joints",), f"{what} but dof is {d.dof}")
            ok = False
        if d.links is not None and len(d.links) != len(d.joints):
            has = f"dof is {d.dof}" if not by_frames else f"the device has {len(d.joints)} joint(s)"
            self.err(
                path + ("links",),
                f"{len(d.links)} link(s) given but {has}; give one link per joint",
            )
            ok = False
        rows = [
            self._joint(path + ("joints", j), moving.index(j) if j in moving else j, row, by_frames)
            for j, row in enumerate(d.joints)
        ]
        link_specs = (
            d.links
            if (d.links is not None and len(d.links) == len(d.joints))
            else [sm.Link() for _ in d.joints]
        )
        local_names: dict[str, tuple] = {}

        def local(name: str, p: tuple) -> bool:
            if name in local_names:
                self.err(
                    p,
                    f"duplicate name '{name}' in device '{d.name}' (first at line "
                    f"{self._line(local_names[name])})",
                )
                return False
            local_names[name] = p
            return True

        # Walk the chain from the base: a moving joint starts a link; a fixed joint's link is
        # merged into the current one (mass properties combined) and kept as a frame on it.
        joints: list[wm.Joint] = []
        links: list[wm.Link] = []
        parts: list[list[tuple[wm.Inertial, np.ndarray]]] = []
        base_shape = self._shape(path + ("geometry",), d.geometry)
        current, T_current_end = d.name, np.eye(4)  # frame of the current link; its chain end
        for j, (row, spec) in enumerate(zip(rows, link_specs)):
            lname = spec.name or f"link{j + 1}"
            lpath = path + ("links", j) if d.links is not None else path + ("joints", j)
            qname = f"{d.name}.{lname}"
            inertial = self._inertial(lpath, spec.mass, spec.com, spec.inertia)
            shape = self._shape(lpath + ("geometry",), spec.geometry)
            if row is None:  # a bad joint row, reported
                continue
            if d.joints[j].type == "fixed":
                T_current_end = T_current_end @ row.origin
                if local(lname, lpath + (("name",) if spec.name else ())):
                    self._add_frame(
                        wm.FrameDecl(qname, "auxiliary", d.name, current), lpath + ("name",)
                    )
                    self.fixed_poses[qname] = T_current_end
                if links:
                    parts[-1].append((inertial, T_current_end))
                if shape is not None:
                    shape = _moved_shape(shape, T_current_end)
                    if links and links[-1].shape is None:
                        links[-1] = dataclasses.replace(links[-1], shape=shape)
                    elif not links and base_shape is None:
                        base_shape = shape
                    else:
                        self.err(
                            lpath + ("geometry",),
                            f"link '{lname}' is fixed to '{current}', which has geometry already; "
                            "a link holds one shape: merge the two into one mesh ('rworld import "
                            "urdf' does)",
                        )
                continue
            if row.origin is not None:  # a joint frame: fixed offsets before it fold into it
                row = dataclasses.replace(row, origin=T_current_end @ row.origin)
            joints.append(row)
            if local(lname, lpath + (("name",) if spec.name else ())):
                self._add_frame(wm.FrameDecl(qname, "link", d.name, current), lpath + ("name",))
            links.append(wm.Link(lname, inertial, shape))
            parts.append([(inertial, np.eye(4))])
            current, T_current_end = qname, np.eye(4)
        links = [
            dataclasses.replace(link, inertial=wm.Inertial.combine(part)) if len(part) > 1 else link
            for link, part in zip(links, parts)
        ]
        for j, f in enumerate(d.frames):
            if local(f.name, path + ("frames", j, "name")):
                parent = f"{d.name}.{f.parent}" if f.parent else d.name
                self._add_frame(
                    wm.FrameDecl(f"{d.name}.{f.name}", "auxiliary", d.name, parent),
                    path + ("frames", j, "name"),
                )
        for j, spec in enumerate(link_specs):
            lname = spec.name or f"link{j + 1}"
            for k, f in enumerate(spec.frames):
                fpath = path + ("links", j, "frames", k, "name")
                if local(f.name, fpath):
                    parent = f"{d.name}.{f.parent}" if f.parent else f"{d.name}.{lname}"
                    self._add_frame(
                        wm.FrameDecl(f"{d.name}.{f.name}", "auxiliary", d.name, parent), fpath
                    )
        tcps = []
        last = f"{d.name}.{links[-1].name}" if links else d.name
        for j, t in enumerate(d.tcps):
            tpath = path + ("tcps", j, "name")
            if local(t.name, tpath):
                parent = f"{d.name}.{t.parent}" if t.parent else last
                self._add_frame(wm.FrameDecl(f"{d.name}.{t.name}", "tcp", d.name, parent), tpath)
                tcps.append(f"{d.name}.{t.name}")
        self._features(d.name, d.features, path + ("features",))
        if len(joints) != len(moving):
            ok = False
        moving_rows = [d.joints[j] for j in moving]
        home = self._home(path, d, joints, moving_rows) if ok else np.zeros(len(joints))
        positions = self._positions(path, d, joints, local_names) if ok else {}
        controller = self._controller(path, d, joints, last) if d.controller else None
        if not ok:
            return None
        return wm.DeviceModel(
            d.name,
            d.dh or "frames",
            tuple(joints),
            tuple(links),
            tuple(tcps),
            home,
            base_shape,
            positions,
            controller,
            d.base_link,
        )

    def _controller(
        self, path: tuple, d: sm.Device, joints: list[wm.Joint], last: str
    ) -> wm.ControllerProfile:
        """The controller profile: its flange on the last link, its base fixed to the base."""
        spec = d.controller
        assert spec is not None
        path = path + ("controller",)

        def link_of(frame: str) -> str | None:
            node: str | None = frame
            while node is not None and node in self.frames:
                decl = self.frames[node]
                if decl.kind == "link" or node == d.name:
                    return node
                node = decl.parent
            return None

        found = {}
        for key, wanted, where in (
            ("flange", last, "on the last link"),
            ("base", d.name, "fixed to the device's base"),
        ):
            name = getattr(spec, key)
            if name is None:
                continue
            qualified = f"{d.name}.{name}"
            frames = [f for f in self.frames if f.startswith(d.name + ".")]
            if qualified not in self.frames:
                self.err(
                    path + (key,),
                    f"'{name}' is no frame of '{d.name}'{did_you_mean(qualified, frames)}",
                )
                continue
            if link_of(qualified) != wanted:
                self.err(path + (key,), f"the {key} '{name}' must be a frame {where}")
                continue
            found[key] = qualified
        n = len(joints)
        sign, offset, coupling = np.ones(n), np.zeros(n), np.zeros((n, n))
        if spec.axes is not None:
            if len(spec.axes) != n:
                self.err(path + ("axes",), f"{len(spec.axes)} axis map(s) for {n} joint(s)")
            else:
                sign = np.array([float(a.sign) for a in spec.axes])
                offset = np.array(
                    [
                        a.offset * (self.A if j.kind == "revolute" else self.L)
                        for a, j in zip(spec.axes, joints)
                    ]
                )
                index = {j.name: k for k, j in enumerate(joints)}
                for i, (a, j) in enumerate(zip(spec.axes, joints)):
                    if a.coupling is None:
                        continue
                    at = path + ("axes", i, "coupling", "joint")
                    other = index.get(a.coupling.joint)
                    if other is None:
                        self.err(
                            at,
                            f"'{a.coupling.joint}' is no joint of '{d.name}'"
                            f"{did_you_mean(a.coupling.joint, list(index))}",
                        )
                    elif other == i:
                        self.err(at, f"axis {i + 1} cannot be coupled to its own joint")
                    elif joints[other].kind != j.kind:
                        self.err(at, "a coupling joins two revolute or two prismatic joints")
                    else:
                        coupling[i, other] = a.coupling.factor
        for key in ("pulses_per_degree", "zero_pulse"):
            values = getattr(spec, key)
            if values is not None and len(values) != n:
                self.err(path + (key,), f"{len(values)} value(s) for {n} joint(s): one per axis")
        if spec.zero_pulse is not None and spec.pulses_per_degree is None:
            self.err(path + ("zero_pulse",), "zero_pulse goes with pulses_per_degree")
        for k, value in enumerate(spec.pulses_per_degree or []):
            if not PULSES_PER_DEGREE[0] <= value <= PULSES_PER_DEGREE[1]:  # NaN fails too
                self.err(
                    path + ("pulses_per_degree", k),
                    f"{value:g} pulses per degree is not "
                    f"an encoder's (Yaskawa's lie within {PULSES_PER_DEGREE[0]:g} to "
                    f"{PULSES_PER_DEGREE[1]:g}); read it off the robot parameters",
                )
        for k, value in enumerate(spec.zero_pulse or []):
            if not abs(value) < 2**31:
                self.err(path + ("zero_pulse", k), f"{value} is not a pulse count (32 bits)")
        return wm.ControllerProfile(
            found.get("flange"),
            found.get("base"),
            sign,
            offset,
            coupling,
            spec.vendor,
            spec.pulses_per_degree,
            spec.zero_pulse,
        )

    def _positions(self, path, d: sm.Device, joints: list[wm.Joint], local_names: dict) -> dict:
        """Named joint configurations, SI; checked for length, limits and clashes with frame
        names.
        """
        from . import models as sm

        out = {}
        scale = np.array([self.A if j.kind == "revolute" else self.L for j in joints])
        lower = np.array([j.limits.lower for j in joints])
        upper = np.array([j.limits.upper for j in joints])
        for name, values in d.positions.items():
            ppath = path + ("positions", name)
            if not re.match(sm.NAME_PATTERN, name) or name == "home":
                self.err(
                    ppath,
                    f"invalid position name '{name}': use a name (letters, digits, '_', '-'), not "
                    "'home'",
                    prefer="key",
                )
                continue
            if name in local_names:
                self.err(
                    ppath,
                    f"'{name}' is already a frame of '{d.name}'; a position needs its own name",
                    prefer="key",
                )
                continue
            if len(values) != len(joints):
                self.err(
                    ppath,
                    f"position '{name}' has {len(values)} value(s) but the device has "
                    f"{len(joints)} joint(s)",
                )
                continue
            q = np.array(values, dtype=float) * scale
            for k in np.nonzero((q < lower) | (q > upper))[0]:
                self.err(
                    ppath + (int(k),),
                    f"value {values[k]} of joint {joints[k].name} is outside its position limits",
                )
            out[name] = q
        return out

    def _joint(self, path, j: int, row: sm.Joint, by_frames: bool) -> wm.Joint | None:
        """One joint row in SI (``None`` when its form does not fit the device's)."""
        from . import models as sm

        dh_given = [k for k in ("a", "alpha", "d", "theta") if getattr(row, k) is not None]
        frame_given = [k for k in ("origin", "axis") if getattr(row, k) is not None]
        if by_frames and dh_given:
            self.err(
                path + (dh_given[0],),
                f"'{dh_given[0]}' is a DH parameter, but the device has no 'dh': its joints are "
                "given by their frames ('origin', 'axis'); add 'dh: standard' or 'dh: modified' "
                "for a DH table",
                prefer="key",
            )
            return None
        if not by_frames and frame_given:
            self.err(
                path + (frame_given[0],),
                f"'{frame_given[0]}' belongs to a joint frame, but the device has a DH table "
                "('dh'); give a, alpha, d, theta, or remove 'dh' to give every joint by its frame",
                prefer="key",
            )
            return None
        if not by_frames and row.type == "fixed":
            self.err(
                path + ("type",),
                "a DH table has no fixed joints; put the fixed offset into the next row or a "
                "frame on the link, or give the device by joint frames",
            )
            return None
        origin = axis = None
        if by_frames:
            origin = np.eye(4)
            if row.origin is not None:
                origin, error, warning = pose_to_matrix(row.origin, self.L, self.A)
                if error:
                    self.err(path + ("origin",), error)
                    return None
                if warning:
                    self.warn(path + ("origin",), warning)
            axis = np.array([0.0, 0.0, 1.0])
            if row.axis is not None:
                axis = self._unit(path + ("axis",), row.axis, "joint axis")
                if axis is None:
                    return None
        if row.type == "fixed":
            return wm.Joint(
                row.name or "", "revolute", 0.0, 0.0, 0.0, 0.0, wm.JointLimits(), origin
            )
        kind = "prismatic" if row.type == "prismatic" else "revolute"
        scale = self.A if kind == "revolute" else self.L
        lim = row.limits or sm.JointLimits()
        lower, upper = -np.inf, np.inf
        if lim.position is not None and row.type == "continuous":
            self.err(
                path + ("limits", "position"),
                "a continuous joint has no position limits; make it 'revolute' to limit it",
            )
        elif lim.position is not None:
            lower, upper = lim.position[0] * scale, lim.position[1] * scale
            if not lower < upper:
                self.err(
                    path + ("limits", "position"),
                    f"limits out of order: lower {lim.position[0]} must be below upper "
                    f"{lim.position[1]}",
                )
        limits = wm.JointLimits(
            lower=lower,
            upper=upper,
            velocity=lim.velocity * scale if lim.velocity else np.inf,
            acceleration=lim.acceleration * scale if lim.acceleration else np.inf,
            effort=lim.effort if lim.effort else np.inf,
        )
        Jm, G = (row.motor.inertia, row.motor.gear_ratio) if row.motor else (0.0, 1.0)
        viscous = coulomb_pos = coulomb_neg = 0.0
        if row.friction is not None:
            fr = row.friction
            coulomb_neg_raw = fr.coulomb if fr.coulomb_negative is None else fr.coulomb_negative
            if fr.at == "motor":
                if row.motor is None:
                    self.err(
                        path + ("friction", "at"),
                        "motor-side friction needs the joint's 'motor' (its gear_ratio) to refer "
                        "it to the joint",
                    )
                viscous, coulomb_pos, coulomb_neg = (
                    fr.viscous * G**2,
                    fr.coulomb * abs(G),
                    coulomb_neg_raw * abs(G),
                )
            else:
                viscous, coulomb_pos, coulomb_neg = fr.viscous, fr.coulomb, coulomb_neg_raw
        return wm.Joint(
            name=row.name or f"j{j + 1}",
            kind=kind,
            a=(row.a or 0.0) * self.L,
            alpha=(row.alpha or 0.0) * self.A,
            d=(row.d or 0.0) * self.L,
            theta=(row.theta or 0.0) * self.A,
            limits=limits,
            origin=origin,
            axis=axis,
            motor_inertia=Jm,
            gear_ratio=G,
            viscous=viscous,
            coulomb_positive=coulomb_pos,
            coulomb_negative=coulomb_neg,
        )

    def _home(self, path, d: sm.Device, joints: list[wm.Joint], rows: list[sm.Joint]) -> np.ndarray:
        lower = np.array([j.limits.lower for j in joints])
        upper = np.array([j.limits.upper for j in joints])
        if d.home is None:
            return np.clip(np.zeros(len(joints)), lower, upper)
        scale = np.array([self.A if j.kind == "revolute" else self.L for j in joints])
        if len(d.home) != len(joints):
            self.err(
                path + ("home",),
                f"home has {len(d.home)} value(s) but the device has {len(joints)} joint(s)",
            )
            return np.clip(np.zeros(len(joints)), lower, upper)
        home = np.array(d.home, dtype=float) * scale
        for k in np.nonzero((home < lower) | (home > upper))[0]:
            lim = rows[k].limits.position if rows[k].limits else None
            self.err(
                path + ("home", int(k)),
                f"home value {d.home[k]} of joint {joints[k].name} is outside its position limits "
                f"{lim}",
            )
        return home

    def _free_frames(self):
        for i, f in enumerate(self.cf.frames):
            if self.primitives.get(f.name, (None, None))[1] != ("frames", i):
                continue
            self._add_frame(
                wm.FrameDecl(f.name, "free", wm.WORLD, f.parent or wm.WORLD), ("frames", i, "name")
            )

    def _check_owned_parents(self):
        """Owned frames' parents exist and belong to the same owner; free frames hang on free
        frames.
        """
        for name, decl in list(self.frames.items()):
            if decl.parent is None or decl.kind == "link":
                continue
            path = self.frame_paths[name][:-1] + ("parent",)
            parent = self.frames.get(decl.parent)
            if decl.kind == "free":
                if parent is None:
                    self.err(
                        path,
                        f"unknown frame '{decl.parent}'{did_you_mean(decl.parent, self.frames)}",
                    )
                elif parent.kind not in ("free", "world"):
                    self.err(
                        path,
                        "a free frame hangs on 'world' or another free frame, not on "
                        f"'{decl.parent}'; declare it as an auxiliary frame of '{parent.owner}' "
                        "instead",
                    )
                continue
            if parent is None:
                local = decl.parent.split(".", 1)[1]
                siblings = [
                    f.split(".", 1)[1]
                    for f, d in self.frames.items()
                    if d.owner == decl.owner and "." in f
                ]
                self.err(
                    path, f"'{decl.owner}' has no frame '{local}'{did_you_mean(local, siblings)}"
                )
            elif decl.parent == name:
                self.err(path, f"frame '{name}' cannot be its own parent")

    # ------------------------------------------------------------------ affixments
    def _owner_kind(self, frame: str) -> str:
        decl = self.frames[frame]
        if decl.kind in ("world", "free"):
            return decl.kind
        return self.primitives[decl.owner][0]

    def _affixments(self) -> list[wm.AffixmentDecl]:
        out = []
        seen_child: dict[str, tuple] = {}
        for i, a in enumerate(self.cf.affixments):
            path = ("affixments", i)
            bad = False
            if a.parent not in self.frames:
                self.err(
                    path + ("parent",),
                    f"unknown frame '{a.parent}'{did_you_mean(a.parent, self.frames)}",
                )
                bad = True
            child_kind = self.primitives.get(a.child, (None,))[0]
            if child_kind is None:
                frame_hint = (
                    " (auxiliary frames belong to their owner and cannot be affixed)"
                    if a.child in self.frames
                    else ""
                )
                names = [n for n, (k, _) in self.primitives.items() if k != "free"]
                self.err(
                    path + ("child",),
                    "unknown object, sensor or device "
                    f"'{a.child}'{did_you_mean(a.child, names)}{frame_hint}",
                )
                bad = True
            elif child_kind == "free":
                self.err(
                    path + ("child",),
                    f"'{a.child}' is a free frame; give it a 'parent' in 'frames' instead of an "
                    "affixment",
                )
                bad = True
            if a.child in seen_child:
                self.err(
                    path + ("child",),
                    f"'{a.child}' is already affixed at line {self._line(seen_child[a.child])}; a "
                    "primitive has one parent (the affixments form a tree)",
                )
                bad = True
            if bad:
                continue
            seen_child[a.child] = path + ("child",)
            owner_kind = self._owner_kind(a.parent)
            parent_owner = self.frames[a.parent].owner
            problem = rules.hierarchy_problem(
                a.child, child_kind, a.parent, parent_owner, owner_kind
            )
            if problem:
                self.err(path + (problem[0],), problem[1])
                continue
            problem = rules.kind_problem(a.type, a.kind, child_kind, owner_kind)
            if problem:
                self.err(path + ("kind",), problem)
            out.append(wm.AffixmentDecl(a.parent, a.child, a.type, a.kind))
        return out

    def _check_cycles(self, affixments: list[wm.AffixmentDecl]):
        """Follow parents from every frame; report each cycle once, at an affixment that closes
        it.
        """
        parent = {n: d.parent for n, d in self.frames.items()}
        via: dict[str, int] = {}
        for i, a in enumerate(affixments):
            parent[a.child] = a.parent
            via[a.child] = i
        reported: set[frozenset] = set()
        for start in parent:
            path, node = [], start
            while node is not None and node not in path:
                path.append(node)
                node = parent.get(node)
            if node is None:
                continue
            cycle = path[path.index(node) :]
            key = frozenset(cycle)
            if key in reported:
                continue
            reported.add(key)
            chain = " -> ".join(cycle + [cycle[0]])
            closing = [n for n in cycle if n in via]
            if closing:
                idx = self.cf.affixments.index(
                    next(a for a in self.cf.affixments if a.child == closing[-1])
                )
                self.err(
                    ("affixments", idx, "parent"),
                    f"the affixments form a cycle: {chain} (each frame must lead to world)",
                )
            else:
                self.err(
                    self.frame_paths[cycle[0]][:-1] + ("parent",), f"frames form a cycle: {chain}"
                )

    # ------------------------------------------------------------------ conditions
    def _conditions(self) -> list[wm.Condition]:
        out = []
        seen: dict[str, tuple] = {}
        for i, c in enumerate(self.cf.conditions):
            path = ("conditions", i)
            decl = self.frames.get(c.frame)
            if decl is None:
                self.err(
                    path + ("frame",),
                    f"unknown frame '{c.frame}'{did_you_mean(c.frame, self.frames)}",
                )
                continue
            if c.frame in seen:
                self.err(
                    path + ("frame",),
                    f"frame '{c.frame}' is already conditioned at line "
                    f"{self._line(seen[c.frame])}; a frame takes one condition",
                )
                continue
            seen[c.frame] = path + ("frame",)
            code = c.code
            natural = code in ("C1", "C2")
            if decl.kind in ("world", "free", "link"):
                what = {
                    "world": "the world frame",
                    "free": "a free frame",
                    "link": "a link frame (placed by the DH table)",
                }[decl.kind]
                self.err(
                    path + ("frame",),
                    f"'{c.frame}' is {what}; only frames owned by an object or device can be "
                    "conditioned by features",
                )
                continue
            if natural and decl.kind != "natural":
                self.err(
                    path + ("type",),
                    f"{c.type} ({code}) locates a natural frame; '{c.frame}' is an auxiliary "
                    "frame (use C3-C13)",
                )
                continue
            if not natural and decl.kind == "natural":
                self.err(
                    path + ("type",),
                    f"{c.type} ({code}) conditions an auxiliary frame; '{c.frame}' is a natural "
                    "frame (use C1 or C2)",
                )
                continue
            if self.primitives.get(decl.owner, ("",))[0] == "sensor":
                self.err(
                    path + ("frame",),
                    f"'{c.frame}' belongs to a sensor; features belong to objects and devices",
                )
                continue
            names = c.feature_names
            fpath = path + ("feature",) if c.feature is not None else path + ("features",)
            if not natural and len(names) != 1:
                self.err(
                    fpath,
                    f"an auxiliary frame is conditioned by exactly one feature, got {len(names)}",
                )
                continue
            if natural and not names:
                self.err(fpath, "give the features that locate this frame")
                continue
            resolved = []
            for k, fname in enumerate(names):
                p = fpath if c.feature is not None else fpath + (k,)
                qname = fname if "." in fname else f"{decl.owner}.{fname}"
                feat = self.features.get(qname)
                if feat is None:
                    own = [
                        f.split(".", 1)[1] for f in self.features if f.startswith(decl.owner + ".")
                    ]
                    self.err(
                        p,
                        f"'{decl.owner}' has no feature "
                        f"'{fname}'{did_you_mean(fname.split('.')[-1], own)}",
                    )
                    continue
                if feat.owner != decl.owner:
                    self.err(
                        p,
                        f"feature '{qname}' belongs to '{feat.owner}' but frame '{c.frame}' "
                        f"belongs to '{decl.owner}'; "
                        "a frame is conditioned only by features of its own object or device",
                    )
                    continue
                if feat.kind not in CONDITION_FEATURE_KINDS[code]:
                    allowed = " or ".join(sorted(CONDITION_FEATURE_KINDS[code]))
                    self.err(
                        p,
                        f"{c.type} ({code}) needs a {allowed} feature; '{qname}' is a {feat.kind}",
                    )
                    continue
                resolved.append(qname)
            if len(resolved) == len(names):
                out.append(wm.Condition(c.frame, code, c.type, tuple(resolved)))
        return out

    # ------------------------------------------------------------------ poses
    def _poses(self, devices):
        poses: dict[str, np.ndarray] = dict(self.fixed_poses)
        origins: dict[str, dict[str, np.ndarray]] = {}  # device -> joint -> origin (SI)
        compliances: dict[str, dict[str, float]] = {}  # device -> joint -> [rad/(N m), m/N]
        sources: dict[str, Path] = {}
        files: list[Path] = []
        complete = True  # every pose file was read and schema-valid
        given_but_bad: set[str] = set()
        for i, rel in enumerate(self.cf.pose_files):
            real = self.base_dir / rel
            shown = str(self.display_dir / rel)
            if not real.is_file():
                self.err(("pose_files", i), f"no such pose file: {shown}")
                complete = False
                continue
            try:
                doc, pf = load_pose_file_doc(real, shown)
            except UserError as exc:
                self.issues.extend(exc.issues)
                complete = False
                continue
            self.read.append((real, doc.digest))
            files.append(real)
            self.issues.extend(implausible_values(doc, pf.units))
            L, A = LENGTH[pf.units.length], ANGLE[pf.units.angle]
            for name, pose in pf.poses.items():
                ppath = ("poses", name)
                decl = self.frames.get(name)
                if decl is None:
                    self.err(
                        ppath,
                        f"unknown frame '{name}'{did_you_mean(name, self.frames)}",
                        prefer="key",
                        doc=doc,
                    )
                    continue
                if decl.kind == "world":
                    self.err(
                        ppath,
                        "the world frame has no pose; it is the reference",
                        prefer="key",
                        doc=doc,
                    )
                    continue
                if decl.kind == "link" or name in self.fixed_poses:
                    how = "the DH table" if decl.kind == "link" else "a fixed joint"
                    self.err(
                        ppath,
                        f"'{name}' is a link frame placed by {how} of '{decl.owner}'; it "
                        "takes no pose",
                        prefer="key",
                        doc=doc,
                    )
                    continue
                T, error, warning = pose_to_matrix(pose, L, A)
                if error:
                    self.err(ppath, error, doc=doc)
                    given_but_bad.add(name)
                    continue
                if warning:
                    self.warn(ppath, warning, doc=doc)
                poses[name] = T
                sources[name] = real
            entries = [("joints", n, p) for n, p in pf.joints.items()]
            entries += [("corrections", n, p) for n, p in pf.corrections.items()]
            for section, name, pose in entries:
                jpath = (section, name)
                device, _, joint = name.rpartition(".")
                dev = self._joint_named(devices, name, jpath, doc)
                if dev is None:
                    continue
                frames = dev.convention == "frames"
                if frames != (section == "joints"):
                    self.err(
                        jpath,
                        f"'{device}' is given by a DH table: its calibrated joints go under "
                        "'corrections:' (a pose before each DH row)"
                        if frames is False
                        else f"'{device}' is given by joint frames: its calibrated joints go "
                        "under 'joints:' (each joint's frame)",
                        prefer="key",
                        doc=doc,
                    )
                    continue
                T, error, warning = pose_to_matrix(pose, L, A)
                if error:
                    self.err(jpath, error, doc=doc)
                    continue
                if warning:
                    self.warn(jpath, warning, doc=doc)
                nominal = next(j for j in dev.joints if j.name == joint)
                moved = np.linalg.solve(nominal.origin, T) if frames else T
                shift = float(np.linalg.norm(moved[:3, 3]))
                turn = float(np.arccos(np.clip((np.trace(moved[:3, :3]) - 1) / 2, -1.0, 1.0)))
                if shift > CALIBRATION_SHIFT or turn > CALIBRATION_TURN:
                    self.warn(
                        jpath,
                        f"moves {name}'s frame by {shift * 1000:.1f} mm and "
                        f"{np.degrees(turn):.2f} deg from the cell's nominal: more than a "
                        f"calibration does ({CALIBRATION_SHIFT * 1000:g} mm, "
                        f"{np.degrees(CALIBRATION_TURN):g} deg); check the overlay (a frame "
                        "the import merged into this joint, such as a base turned by 180 deg, "
                        "left out?)",
                        doc=doc,
                    )
                origins.setdefault(device, {})[joint] = T
            for name, value in pf.compliance.items():
                cpath = ("compliance", name)
                device, _, joint = name.rpartition(".")
                dev = self._joint_named(devices, name, cpath, doc)
                if dev is None:
                    continue
                if value < 0:  # kept: a fit's estimate, but not a physical one
                    self.warn(
                        cpath,
                        f"a negative compliance ({value:g}): the joint moves against its load; "
                        "a fit absorbing other error than compliance?",
                        doc=doc,
                    )
                kind = next(j.kind for j in dev.joints if j.name == joint)
                per_kilo = (A if kind == "revolute" else L) * 1e-3  # per kN m / kN -> SI
                compliances.setdefault(device, {})[joint] = value * per_kilo
        if complete:  # otherwise the missing poses may well be in the file we could not read
            shown_files = ", ".join(str(self.display_dir / r) for r in self.cf.pose_files)
            for name, decl in self.frames.items():
                if decl.kind in ("world", "link") or name in poses or name in given_but_bad:
                    continue
                self.err(
                    self.frame_paths[name],
                    f"no pose for frame '{name}' in {shown_files}; add '{name}: {{xyz: [x, y, z], "
                    "rpy: [r, p, y]}'",
                )
        return poses, sources, files, origins, compliances

    def _joint_named(self, devices, name: str, path, doc):
        """The device of a pose file's 'device.joint' key, or None with the error recorded."""
        device, _, joint = name.rpartition(".")
        dev = devices.get(device)
        if dev is not None and any(j.name == joint for j in dev.joints):
            return dev
        known = [f"{d}.{j.name}" for d, m in devices.items() for j in m.joints]
        self.err(
            path,
            f"unknown joint '{name}'{did_you_mean(name, known)}; write 'device.joint'",
            prefer="key",
            doc=doc,
        )
        return None


# an overlay that moves a joint's frame further than this is named (warning): calibrations move
# frames by tenths of millimetres, and a hand-copied factory calibration that drops a frame the
# import merged moves them by metres
CALIBRATION_SHIFT = 0.01  # [m]
CALIBRATION_TURN = np.radians(2.0)  # [rad]


# the six entries of a symmetric inertia tensor, by name (as cell files and URDF write them)
INERTIA_ENTRIES = {
    "ixx": (0, 0),
    "iyy": (1, 1),
    "izz": (2, 2),
    "ixy": (0, 1),
    "ixz": (0, 2),
    "iyz": (1, 2),
}


def inertia_matrix(entries: dict) -> np.ndarray:
    """The symmetric 3x3 tensor of ``{"ixx": ..., ...}`` (missing entries 0) [kg m^2]."""
    I = np.zeros((3, 3))
    for key, (a, b) in INERTIA_ENTRIES.items():
        I[a, b] = I[b, a] = entries.get(key, 0.0)
    return I


def inertia_entries(I: np.ndarray) -> dict[str, float]:
    """The six entries of a symmetric tensor, by name."""
    return {key: float(I[a, b]) for key, (a, b) in INERTIA_ENTRIES.items()}


def inertia_problem(I: np.ndarray) -> str | None:
    """Why ``I`` is no inertia (a negative principal moment), or None."""
    moments = np.linalg.eigvalsh(I)
    if moments[0] < -1e-12 * max(1.0, float(np.abs(moments).max())):
        return (
            "inertia is not positive semidefinite: principal moments "
            f"{', '.join(f'{m:.6g}' for m in moments)} kg m^2 include a negative one"
        )
    return None


def _moved_shape(shape: wm.Shape, T: np.ndarray) -> wm.Shape:
    """``shape`` given in a frame placed by ``T`` in its new owner's frame."""
    box = wm.Box(T @ shape.bounding_box.T_owner_box, shape.bounding_box.half_extents)
    return dataclasses.replace(shape, T_owner_shape=T @ shape.T_owner_shape, bounding_box=box)


def body_names(objects, devices) -> list[str]:
    """Names a collision rule may give: objects, devices, and links as ``device.link``."""
    names = list(objects) + list(devices)
    for dev in devices.values():
        names += list(dev.link_frames)
    return names
