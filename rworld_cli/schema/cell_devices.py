"""A cell's devices as the loader reads them: DH rows or joint frames, limits, controller
profiles, named positions, home; free frames and owned parents."""

from __future__ import annotations

import dataclasses
import re
from typing import TYPE_CHECKING

import numpy as np

from ..errors import did_you_mean
from ..model import cell as wm

if TYPE_CHECKING:  # pydantic, the file models and YAML load when a file is checked
    from . import models as sm

from .cellparts import (
    PULSES_PER_DEGREE,
    _moved_shape,
    pose_to_matrix,
)


class DevicesMixin:
    """The device checks of the loader's builder (a mixin of ``loader._Builder``)."""

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
