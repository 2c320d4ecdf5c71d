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
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import Issue, UserError, did_you_mean
from ..model import cell as wm
from ..units import ANGLE, LENGTH

if TYPE_CHECKING:  # pydantic, the file models and YAML load when a file is checked
    from . import models as sm
    from .yamlio import Marked

from .cell_bodies import BodiesMixin
from .cell_devices import DevicesMixin
from .cell_poses import PosesMixin
from .cell_rules import RulesMixin
from .cellparts import (  # noqa: F401 - re-exported: the loader's public pieces
    ANGLE_KEYS,
    CALIBRATION_SHIFT,
    CALIBRATION_TURN,
    CONDITION_FEATURE_KINDS,
    INERTIA_ENTRIES,
    LARGEST_LENGTH,
    LENGTH_KEYS,
    MAX_MAGNITUDE,
    MESH_FACTS_FORMAT,
    PULSES_PER_DEGREE,
    _implausible_numbers,
    _mesh_facts,
    _moved_shape,
    body_names,
    implausible_values,
    inertia_entries,
    inertia_matrix,
    inertia_problem,
    joint_values,
    load_pose_file_doc,
    pose_to_matrix,
    robot_pose_files,
    validate_document,
)


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
    loaded = LoadedCell(cell, [i for i in ordered if i.severity != "error"])
    cellcache.store(where, loaded, [(real, doc.digest), *builder.read])
    return loaded


class _Builder(BodiesMixin, DevicesMixin, RulesMixin, PosesMixin):
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
        self.calibrated: dict[str, tuple[Path, float, float]] = {}  # frame -> (overlay, m, rad)
        self.surfaces: list[tuple[str, tuple]] = []  # meshes marked open surfaces: (body, path)

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
        for name, camera in self.cameras.items():  # the cameras' intrinsics, from pose files
            if name in sensors:
                sensors[name] = dataclasses.replace(sensors[name], camera=camera)
        for name, values in compliances.items():  # the joints' compliance under load
            dev = devices[name]
            joints = tuple(
                dataclasses.replace(j, compliance=values[j.name]) if j.name in values else j
                for j in dev.joints
            )
            devices[name] = dataclasses.replace(dev, joints=joints)
        self._check_cycles(affixments)
        allowed = self._allowed_contacts(objects, devices)
        if self.surfaces:  # known open meshes: one line for all, a note (--quiet: none)
            names = [name for name, _ in self.surfaces]
            shown = ", ".join(names[:6]) + (f" and {len(names) - 6} more" if len(names) > 6 else "")
            self.issues.append(
                self.doc.issue(
                    self.surfaces[0][1],
                    f"{len(names)} mesh(es) marked 'surface: true' are open surfaces ({shown}): "
                    "checked as surfaces, so a body inside one goes unnoticed",
                    severity="note",
                )
            )
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
            calibrated=self.calibrated,
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
