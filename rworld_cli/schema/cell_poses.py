"""A cell's pose files as the loader reads them: each frame's pose, joint frames and DH
corrections, units, and what a calibration may move."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import UserError, did_you_mean
from ..model.vision import CameraModel
from ..units import ANGLE, LENGTH

if TYPE_CHECKING:  # pydantic, the file models and YAML load when a file is checked
    pass

from .cellparts import (
    CALIBRATION_SHIFT,
    CALIBRATION_TURN,
    implausible_values,
    load_pose_file_doc,
    pose_to_matrix,
)


def _shift_and_turn(T: np.ndarray) -> tuple[float, float]:
    """How far a relative pose (4, 4) moves: (its translation [m], its rotation angle [rad])."""
    turn = float(np.arccos(np.clip((np.trace(T[:3, :3]) - 1) / 2, -1.0, 1.0)))
    return float(np.linalg.norm(T[:3, 3])), turn


class PosesMixin:
    """The pose-file checks of the loader's builder (a mixin of ``loader._Builder``)."""

    # ------------------------------------------------------------------ poses
    def _poses(self, devices):
        poses: dict[str, np.ndarray] = dict(self.fixed_poses)
        origins: dict[str, dict[str, np.ndarray]] = {}  # device -> joint -> origin (SI)
        compliances: dict[str, dict[str, float]] = {}  # device -> joint -> [rad/(N m), m/N]
        self.cameras: dict[str, CameraModel] = {}  # camera sensor -> its intrinsics
        cf_sensors = {s.name: s for s in self.cf.sensors}
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
                if pf.provenance is not None and name in poses:  # 'rworld calibrate' wrote it
                    moved = np.linalg.solve(poses[name], T)
                    self.calibrated[name] = (real, *_shift_and_turn(moved))
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
                shift, turn = _shift_and_turn(moved)
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
            for name, spec in pf.cameras.items():
                cpath = ("cameras", name)
                sensor = cf_sensors.get(name)
                if sensor is None or sensor.type != "camera":
                    cameras = [n for n, c in cf_sensors.items() if c.type == "camera"]
                    self.err(
                        cpath,
                        f"'{name}' is not a camera sensor of the cell"
                        + (
                            did_you_mean(name, cameras) or f"; its cameras: {', '.join(cameras)}"
                            if cameras
                            else "; the cell has no camera sensor"
                        ),
                        prefer="key",
                        doc=doc,
                    )
                    continue
                k = spec.intrinsics
                self.cameras[name] = CameraModel(
                    name,
                    *spec.resolution,
                    k.fx,
                    k.fy,
                    k.cx,
                    k.cy,
                    np.array(spec.distortion, dtype=float),
                )
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
            for i, c in enumerate(self.cf.sensors):
                if c.type == "camera" and c.name not in self.cameras:
                    self.err(
                        ("sensors", i),
                        f"no intrinsics for camera '{c.name}' in {shown_files}; add 'cameras: "
                        f"{{{c.name}: {{resolution: [w, h], intrinsics: {{fx: .., fy: .., "
                        "cx: .., cy: ..}, distortion: [k1, k2, p1, p2, k3]}}' to a pose file",
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
