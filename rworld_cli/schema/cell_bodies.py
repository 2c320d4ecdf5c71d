"""A cell's bodies as the loader reads them: mass properties, shapes and meshes, auxiliary
frames, features, objects and sensors."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..model import cell as wm
from ..units import LENGTH

if TYPE_CHECKING:  # pydantic, the file models and YAML load when a file is checked
    from . import models as sm

from .cellcache import file_digest
from .cellparts import (
    _mesh_facts,
    inertia_matrix,
    inertia_problem,
    pose_to_matrix,
)


class BodiesMixin:
    """The body checks of the loader's builder (a mixin of ``loader._Builder``)."""

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
        self.read.append((file, file_digest(file)))  # before the facts are read: a later
        # change of the file then never matches, and the entry is not used
        facts = _mesh_facts(str(file.resolve()), stat.st_mtime_ns, stat.st_size)
        if isinstance(facts, str):
            self.err(path + ("file",), facts)
            return None
        T_mesh_box, extents, size, watertight = facts
        scale = LENGTH[mesh.units or self.cf.units.length]
        if not watertight and mesh.surface:
            self.surfaces.append((self._body_name(path), path + ("surface",)))
        elif not watertight:
            self.warn(
                path + ("file",),
                f"the mesh of '{self._body_name(path)}' is not closed (watertight): sensing and "
                "collision checks treat it as a surface, so a body inside it goes unnoticed "
                "('surface: true' in its mesh entry says so once for all such meshes)",
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
        board = None
        if o.board is not None:
            from .captures import board_model

            board, problems = board_model(o.name, o.board, self.L)
            for where, message in problems:
                self.err(path + ("board",) + where, message)
        return wm.ObjectModel(
            o.name,
            self._inertial(path, o.mass, o.com, o.inertia),
            self._shape(path + ("geometry",), o.geometry),
            board,
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
