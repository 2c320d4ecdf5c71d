"""Program and run files: read and checked against the cell, with located errors, into
``model.program``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..errors import Issue, UserError, did_you_mean
from ..model.cell import CellModel
from ..model.program import FeatureGoal, Program, Run, Step
from ..units import (
    ANGLE,
    COLLISION_TOLERANCE,
    LENGTH,
    LENGTH_WORDS,
    parse_angle_value,
    parse_length,
    parse_quantity,
    parse_speed,
)
from . import program as sp
from .loader import body_names, joint_values, load_cell, pose_to_matrix, validate_document
from .yamlio import Marked, comment_text, parse_yaml_text, read_yaml, yaml_value


def _step_spec(step: sp.Step):
    return getattr(step, step.kind)


def _check_joint_goal(doc, path, spec, step, device, L, A, issues) -> None:
    """``move: {joints: [...]}``: one value per joint, the file's units, within the limits."""
    if device is None:
        return
    q, why = joint_values(device, spec.joints, L, A)
    if why is not None:
        issues.append(doc.issue(path, why))
        return
    step.joints = q
    _timed(doc, path, device, issues)


def _arm_angle(doc, path, spec, step, device, value, A, issues) -> None:
    """``config: {arm_angle}``: a 7-axis arm's arm angle [rad], for a joint move."""
    if not (device.dof == 7 and all(j.kind == "revolute" for j in device.joints)):
        issues.append(
            doc.issue(
                path,
                f"arm_angle is a 7-axis arm's; '{device.name}' has {device.dof} joint(s): "
                "give shoulder, elbow and wrist (a 6-axis arm) or 'near:' joint values",
            )
        )
        return
    if spec.motion == "linear":
        issues.append(
            doc.issue(
                path,
                "a linear move keeps the arm angle its line starts with: 'arm_angle' is for "
                "joint moves",
            )
        )
        return
    try:
        if isinstance(value, str):
            angle = parse_angle_value(value, "arm_angle", "")
        elif A is None:
            raise ValueError(
                f"arm_angle {value} has no unit: write e.g. 30deg, or give units.angle"
            )
        else:
            angle = float(value) * A
    except ValueError as exc:
        issues.append(doc.issue(path, str(exc)))
        return
    step.arm_angle = angle


def _check_config(doc, path, spec, step, device, named, L, A, issues) -> None:
    """A move's ``config:``: an arm's configuration, joint values to be near (SI)."""
    config = spec.config
    wanted = {k: getattr(config, k) for k in ("shoulder", "elbow", "wrist")}
    step.configuration = {k: v for k, v in wanted.items() if v is not None}
    if named:
        issues.append(
            doc.issue(path, f"'{spec.to}' is a joint position: it has no other configuration")
        )
        return
    if device is None:
        return
    arm = device.dof == 6 and all(j.kind == "revolute" for j in device.joints)
    if config.arm_angle is not None:
        _arm_angle(doc, path + ("arm_angle",), spec, step, device, config.arm_angle, A, issues)
    if step.configuration and not arm:
        issues.append(
            doc.issue(
                path,
                f"shoulder, elbow and wrist name the configurations of 6-axis arms; "
                f"'{device.name}' has {device.dof} joint(s): give 'near:' joint values instead",
            )
        )
    if config.near is None:
        return
    if spec.motion == "linear":
        issues.append(
            doc.issue(
                path + ("near",),
                "a linear move follows its line from where the joints are: 'near' is for joint "
                "moves",
            )
        )
        return
    near, why = joint_values(device, config.near, L, A, limits=False)
    if why is not None:
        issues.append(doc.issue(path + ("near",), why))
        return
    step.near = near


def _path_goal(doc, path, spec, step, device, issues) -> None:
    """``move: {path: FILE}``: the path file read against the device (relative to the
    program's folder), its waypoints the step's; it must be straight segments (``boundary:
    segments`` or ``blended``: the lines and blends 'rworld plan path' checked), its problems
    located in it."""
    from .paths import read_path

    if device is None:
        return
    where = Path(doc.file).parent / spec.path
    if not where.is_file():
        issues.append(doc.issue(path, f"no such path file: {where}"))
        return
    try:
        loaded = read_path(str(where), device)
    except UserError as exc:
        issues.append(doc.issue(path, f"the path file is invalid: {exc.message}"))
        issues.extend(exc.issues)
        return
    if loaded.spec.boundary not in ("segments", "blended"):
        issues.append(
            doc.issue(
                path,
                f"{spec.path} is a spline ('boundary: {loaded.spec.boundary}'): a program "
                "drives a path file's straight segments ('boundary: blended' or 'segments', as "
                "'rworld plan path' writes it); time a spline with 'rworld plan time-optimal'",
            )
        )
        return
    step.waypoints = np.asarray(loaded.spec.waypoints, dtype=float)
    if loaded.spec.boundary == "blended" and loaded.spec.blends is not None:
        step.blends = np.asarray(loaded.spec.blends, dtype=float)
    step.joints = step.waypoints[-1].copy()


def _check_move_details(
    doc, path, spec, step, device, named, cell, units, L, A, issues, device_name
) -> None:
    """A move's TCP, guard, touch depths, configuration and offset (any target)."""

    def frame(path, name, what="frame"):
        if name not in cell.frames and f"{device_name}.{name}" not in cell.frames:
            issues.append(
                doc.issue(path, f"unknown {what} '{name}'{did_you_mean(name, cell.frames)}")
            )

    if spec.tcp is not None:
        frame(path + ("tcp",), spec.tcp)
    if spec.until is not None and spec.until not in cell.sensors:
        issues.append(
            doc.issue(
                path + ("until",),
                f"unknown sensor '{spec.until}'{did_you_mean(spec.until, cell.sensors)}",
            )
        )
    if spec.touch:
        bodies = body_names(cell.objects, cell.devices)
        depths = spec.touch if isinstance(spec.touch, dict) else dict.fromkeys(spec.touch)
        for k, (name, depth) in enumerate(depths.items()):
            at = path + ("touch", name if isinstance(spec.touch, dict) else k)
            if name not in bodies:
                issues.append(
                    doc.issue(
                        at,
                        f"unknown object, device or link '{name}'{did_you_mean(name, bodies)}",
                    )
                )
            if depth is None:
                continue
            if not isinstance(depth, str) and L is None:
                issues.append(
                    doc.issue(
                        at,
                        f"a bare depth ({depth}) needs the file's units.length, and "
                        "rworld never guesses it: write it with its unit (2mm) or add "
                        "'units: {length: mm, angle: deg}'",
                    )
                )
                continue
            try:
                step.touch[name] = parse_length(
                    depth,
                    f"the depth '{name}' may be touched to",
                    units.length if units and units.length else "",
                )
            except ValueError as exc:
                issues.append(doc.issue(at, str(exc)))
        for name in depths:
            step.touch.setdefault(name, None)
    if spec.config is not None:
        _check_config(doc, path + ("config",), spec, step, device, named, L, A, issues)
    if spec.offset is not None and (L is None or A is None):
        issues.append(
            doc.issue(
                path + ("offset",),
                "an offset needs the file's units, and rworld never guesses them: add "
                "'units: {length: mm, angle: deg}' at the top of the program",
            )
        )
    elif spec.offset is not None:
        T, error, warning = pose_to_matrix(spec.offset, L, A)
        if error:
            issues.append(doc.issue(path + ("offset",), error))
        step.T_offset = T
    if device is not None:
        _timed(doc, path, device, issues)


def _timed(doc, path, device, issues) -> None:
    """A device with no acceleration limit at all: nothing times its moves."""
    if not np.isfinite(device.limit_array("acceleration")).any():
        issues.append(
            doc.issue(
                path,
                f"no joint of '{device.name}' has an acceleration limit, so nothing times its "
                "moves; add them to the cell",
            )
        )


_KINDS_SERVING = {  # what each feature step can take
    "move": ("plane", "circle", "line", "point"),
    "insert": ("circle",),
    "insert object": ("circle", "line"),
    "place": ("plane",),
    "place object": ("plane",),
    "follow": ("line",),
    "probe": ("plane", "circle", "line"),
}
_SERVES = {
    "move": "a move",
    "insert": "'into' (a hole: a circle)",
    "insert object": "'object' (the held tip: a circle or an axis line)",
    "place": "'on' (a plane)",
    "place object": "'object' (the held face: a plane)",
    "follow": "'edge' (a line)",
    "probe": "probing moves",
}


class _FeatureChecks:
    """A program's feature steps checked against the cell: names, kinds, owners and the
    numbers (the file's units), into :class:`FeatureGoal` (SI)."""

    def __init__(self, doc, cell: CellModel, device: str, units, issues: list[Issue]):
        self.doc, self.cell, self.device, self.issues = doc, cell, device, issues
        self.length_unit = units.length if units and units.length else None
        self.angle_unit = units.angle if units and units.angle else None

    def feature(self, path, name: str, role: str, held: bool = False):
        """The feature ``name`` fit for ``role``, or None (an issue said why)."""
        f = self.cell.features.get(name)
        if f is None:
            self.issues.append(
                self.doc.issue(
                    path, f"unknown feature '{name}'{did_you_mean(name, self.cell.features)}"
                )
            )
            return None
        if f.kind not in _KINDS_SERVING[role]:
            wanted = " or ".join(_KINDS_SERVING[role])
            self.issues.append(
                self.doc.issue(
                    path,
                    f"'{name}' is a {f.kind}: {_SERVES[role]} needs a {wanted} feature",
                )
            )
            return None
        if held and f.owner not in self.cell.objects:
            self.issues.append(
                self.doc.issue(path, f"'{name}' is on '{f.owner}', not on an object to hold")
            )
            return None
        if not held and (
            f.owner == self.device or f.owner not in self.cell.objects | self.cell.devices
        ):
            self.issues.append(
                self.doc.issue(
                    path,
                    f"'{name}' is on '{f.owner}' itself: {self.device} cannot move to its own "
                    "features",
                )
            )
            return None
        return f

    def length(self, path, value, what: str, signed: bool = False) -> float | None:
        if isinstance(value, (int, float)) and self.length_unit is None:
            self.issues.append(
                self.doc.issue(
                    path,
                    f"a bare {what} ({value}) needs the file's units.length, and rworld never "
                    "guesses it: write it with its unit (20mm) or add 'units: {length: mm, "
                    "angle: deg}'",
                )
            )
            return None
        try:
            if signed:
                out = parse_quantity(value, LENGTH_WORDS, self.length_unit or "")
                if not np.isfinite(out):
                    raise ValueError(f"{what} '{value}' is not a length: write e.g. 20mm")
                return float(out)
            return parse_length(value, what, self.length_unit or "")
        except ValueError as exc:
            self.issues.append(self.doc.issue(path, str(exc)))
            return None

    def angle(self, path, value, what: str) -> float | None:
        if value is None:
            return None
        if isinstance(value, (int, float)) and self.angle_unit is None:
            self.issues.append(
                self.doc.issue(
                    path,
                    f"a bare {what} ({value}) needs the file's units.angle: write it with its "
                    "unit (90deg) or add 'units: {length: mm, angle: deg}'",
                )
            )
            return None
        try:
            return parse_angle_value(value, what, self.angle_unit or "")
        except ValueError as exc:
            self.issues.append(self.doc.issue(path, str(exc)))
            return None

    def at(self, path, f, value):
        """``at:`` on ``f``: [u, v] on a plane, a distance along a line, or another feature of
        the same object projected onto the plane."""
        if value is None or f is None:
            return None
        if f.kind == "line":
            if isinstance(value, list):
                self.issues.append(self.doc.issue(path, "on a line, 'at' is one distance"))
                return None
            return self.length(path, value, "distance along the line", signed=True)
        if f.kind != "plane":
            self.issues.append(
                self.doc.issue(path, f"'at' places a target on a plane or a line, not a {f.kind}")
            )
            return None
        if isinstance(value, list):
            if len(value) != 2:
                self.issues.append(self.doc.issue(path, "on a plane, 'at' is [u, v]"))
                return None
            uv = [
                self.length(path + (k,), v, "in-plane coordinate", True)
                for k, v in enumerate(value)
            ]
            return None if None in uv else np.array(uv, dtype=float)
        other = self.cell.features.get(str(value))
        if other is None or other.owner != f.owner:
            mine = [n for n, g in self.cell.features.items() if g.owner == f.owner]
            self.issues.append(
                self.doc.issue(
                    path,
                    f"'{value}' is not a feature of '{f.owner}'{did_you_mean(str(value), mine)}: "
                    "'at' takes [u, v] or another feature of the same object",
                )
            )
            return None
        return other.name  # its point, projected onto the plane when the step runs

    def step(self, path, kind: str, spec, step: Step, after_guard: bool) -> None:
        """Check one step that may name features; set ``step.goal`` when it does."""
        doc = self.doc
        if kind == "move":
            t = spec.to
            f = self.feature(path + ("to", "feature"), t.feature, "move")
            standoff = self.length(path + ("to", "standoff"), t.standoff, "standoff")
            at = self.at(path + ("to", "at"), f, t.at)
            spin = self.angle(path + ("to", "spin"), t.spin, "spin")
            if f is not None and standoff is not None:
                step.goal = FeatureGoal(f.name, at, standoff, spin)
                step.goal.where = _where(doc, path + ("to",))
        elif kind == "insert":
            held = self.feature(path + ("object",), spec.object, "insert object", held=True)
            f = self.feature(path + ("into",), spec.into, "insert")
            depth = self.length(path + ("depth",), spec.depth, "depth")
            approach = self.length(path + ("approach",), spec.approach, "approach")
            spin = self.angle(path + ("spin",), spec.spin, "spin")
            if spec.until is not None and spec.until not in self.cell.sensors:
                self.issues.append(
                    doc.issue(
                        path + ("until",),
                        f"unknown sensor '{spec.until}'"
                        f"{did_you_mean(spec.until, self.cell.sensors)}",
                    )
                )
            if None not in (held, f, depth, approach):
                step.goal = FeatureGoal(
                    f.name, None, 0.0, spin, held=held.name, depth=depth, approach=approach
                )
                step.goal.where = _where(doc, path + ("into",))
        elif kind == "place":
            held = self.feature(path + ("object",), spec.object, "place object", held=True)
            f = self.feature(path + ("on",), spec.on, "place")
            at = self.at(path + ("at",), f, spec.at)
            approach = self.length(path + ("approach",), spec.approach, "approach")
            spin = self.angle(path + ("spin",), spec.spin, "spin")
            if None not in (held, f, approach):
                step.goal = FeatureGoal(f.name, at, 0.0, spin, held=held.name, approach=approach)
                step.goal.where = _where(doc, path + ("on",))
        elif kind == "follow":
            f = self.feature(path + ("edge",), spec.edge, "follow")
            speed = None
            if isinstance(spec.speed, (int, float)) and self.length_unit is None:
                self.length(path + ("speed",), spec.speed, "speed")  # says why
            else:
                try:
                    speed = parse_speed(spec.speed, "speed", self.length_unit or "")
                except ValueError as exc:
                    self.issues.append(doc.issue(path + ("speed",), str(exc)))
            ends = [
                None if v is None else self.length(path + (key,), v, "distance", signed=True)
                for key, v in (("from", spec.from_), ("to", spec.to))
            ]
            approach = self.length(path + ("approach",), spec.approach, "approach")
            spin = self.angle(path + ("spin",), spec.spin, "spin")
            if spec.offset is not None and (self.length_unit is None or self.angle_unit is None):
                self.issues.append(
                    doc.issue(
                        path + ("offset",),
                        "an offset needs the file's units: add 'units: {length: mm, angle: deg}'",
                    )
                )
            elif spec.offset is not None:
                T, error, _ = pose_to_matrix(
                    spec.offset, LENGTH[self.length_unit], ANGLE[self.angle_unit]
                )
                if error:
                    self.issues.append(doc.issue(path + ("offset",), error))
                step.T_offset = T
            if None not in (f, speed, approach):
                step.goal = FeatureGoal(
                    f.name,
                    None,
                    0.0,
                    spin,
                    approach=approach,
                    extent=(ends[0], ends[1]),
                    speed=speed,
                )
                step.goal.where = _where(doc, path + ("edge",))
        elif kind == "probe":
            moves = spec.points is not None or spec.tcp is not None or spec.sensor is not None
            if after_guard and not moves:
                return  # records the guarded move's contact
            f = self.feature(path + ("feature",), spec.feature, "probe")
            if spec.sensor is not None and spec.sensor not in self.cell.sensors:
                self.issues.append(
                    doc.issue(
                        path + ("sensor",),
                        f"unknown sensor '{spec.sensor}'"
                        f"{did_you_mean(spec.sensor, self.cell.sensors)}",
                    )
                )
            if f is not None:
                from ..units import MIN_POINTS

                step.goal = FeatureGoal(f.name, points=spec.points or MIN_POINTS[f.kind])
                step.goal.where = _where(doc, path + ("feature",))


def _where(doc, path) -> str:
    line, col = doc.position(path)
    return f"{doc.file}:{line}:{col}"


def _check_program(
    doc: Marked, pf: sp.ProgramFile, cell: CellModel, run_devices: set[str], issues: list[Issue]
) -> Program:
    units = pf.units
    L = LENGTH[units.length] if units and units.length else None
    A = ANGLE[units.angle] if units and units.angle else None
    device = cell.devices.get(pf.device)
    if device is None:
        issues.append(
            doc.issue(
                ("device",), f"unknown device '{pf.device}'{did_you_mean(pf.device, cell.devices)}"
            )
        )
    primitives = set(cell.objects) | set(cell.devices) | set(cell.sensors)

    def frame(path, name, what="frame"):
        if name not in cell.frames and f"{pf.device}.{name}" not in cell.frames:
            issues.append(
                doc.issue(path, f"unknown {what} '{name}'{did_you_mean(name, cell.frames)}")
            )

    def obj(path, name, kinds=("object",)):
        pool = {n for n in primitives if cell.primitive_kind(n) in kinds}
        if name not in pool:
            issues.append(
                doc.issue(path, f"unknown {' or '.join(kinds)} '{name}'{did_you_mean(name, pool)}")
            )

    features = _FeatureChecks(doc, cell, pf.device, units, issues)
    steps = []
    for i, raw in enumerate(pf.steps):
        spec = _step_spec(raw)
        path = ("steps", i, raw.kind)
        line = doc.position(("steps", i))[0]
        step = Step(i, raw.kind, spec, f"{doc.file}:{line}")
        after_guard = i > 0 and pf.steps[i - 1].kind == "move" and pf.steps[i - 1].move.until
        if raw.kind == "move" and spec.path not in ("straight", "free"):
            _path_goal(doc, path + ("path",), spec, step, device, issues)
            if spec.tcp is not None:
                frame(path + ("tcp",), spec.tcp)
        elif raw.kind == "move" and spec.joints is not None:
            _check_joint_goal(doc, path + ("joints",), spec, step, device, L, A, issues)
        elif raw.kind == "move" and isinstance(spec.to, sp.FeatureTarget):
            features.step(path, "move", spec, step, False)
            _check_move_details(
                doc, path, spec, step, device, False, cell, units, L, A, issues, pf.device
            )
        elif raw.kind in ("insert", "follow") or (raw.kind == "place" and spec.on in cell.features):
            features.step(path, raw.kind, spec, step, False)
            if raw.kind == "follow" and spec.tcp is not None:
                frame(path + ("tcp",), spec.tcp)
            if raw.kind == "insert" and device is not None:
                _timed(doc, path, device, issues)
        elif raw.kind == "probe" and not (
            after_guard and spec.points is None and spec.tcp is None and spec.sensor is None
        ):
            features.step(path, "probe", spec, step, after_guard)
            if spec.tcp is not None:
                frame(path + ("tcp",), spec.tcp)
        elif raw.kind == "move":
            target = spec.to
            named = device is not None and (target == "home" or target in device.positions)
            if not named:
                if target not in cell.frames:
                    choices = list(cell.frames) + (
                        list(device.positions) + ["home"] if device else []
                    )
                    where = f" or a position of '{device.name}'" if device else ""
                    issues.append(
                        doc.issue(
                            path + ("to",),
                            f"'{target}' is not a frame{where}{did_you_mean(target, choices)}",
                        )
                    )
            elif spec.offset is not None or spec.motion == "linear":
                issues.append(
                    doc.issue(
                        path + ("to",),
                        f"'{target}' is a joint position of '{device.name}': it takes a joint "
                        "move without offset",
                    )
                )
            _check_move_details(
                doc, path, spec, step, device, named, cell, units, L, A, issues, pf.device
            )
        elif raw.kind in ("grasp", "release"):
            obj(path + ("object",), spec.object, ("object", "sensor"))
            if raw.kind == "grasp" and spec.tcp is not None:
                frame(path + ("tcp",), spec.tcp)
        elif raw.kind == "place":
            obj(path + ("object",), spec.object, ("object", "sensor"))
            frame(path + ("on",), spec.on)
        elif raw.kind in ("attach_tool", "detach_tool"):
            obj(path + ("tool",), spec.tool, ("device", "object"))
            if spec.at is not None:
                frame(path + ("at",), spec.at)
            if spec.on is not None:
                frame(path + ("on",), spec.on)
        elif raw.kind == "sense":
            if spec not in cell.sensors:
                issues.append(
                    doc.issue(
                        ("steps", i, "sense"),
                        f"unknown sensor '{spec}'{did_you_mean(spec, cell.sensors)}",
                    )
                )
        elif raw.kind == "capture":
            cameras = [n for n, sensor in cell.sensors.items() if sensor.type == "camera"]
            if spec.camera not in cameras:
                issues.append(
                    doc.issue(
                        path + ("camera",),
                        f"'{spec.camera}' is not a camera sensor"
                        f"{did_you_mean(spec.camera, cameras)}; the cell's cameras: "
                        f"{', '.join(cameras) or 'none'}",
                    )
                )
        elif raw.kind == "probe":
            if spec.feature not in cell.features:
                issues.append(
                    doc.issue(
                        path + ("feature",),
                        f"unknown feature '{spec.feature}'"
                        f"{did_you_mean(spec.feature, cell.features)}",
                    )
                )
        elif raw.kind == "wait" and spec.for_ is not None:
            if spec.for_ not in run_devices:
                issues.append(
                    doc.issue(
                        path + ("for",),
                        f"no program of this run drives '{spec.for_}': waiting for it would never "
                        "end" + did_you_mean(spec.for_, run_devices),
                    )
                )
            elif spec.for_ == pf.device:
                issues.append(
                    doc.issue(path + ("for",), "a device cannot wait for its own program to end")
                )
        steps.append(step)
    return Program(pf.device, doc.file, steps)


def load_run(
    cell_path: str, run_path: str, dt: float | None = None, pose_files: list[str] | None = None
) -> Run:
    """Load a cell and a run file (and its programs); every problem at once.

    A program file given as ``run_path`` runs alone (``dt`` default 0.01 s).

    Raises
    ------
    UserError
        Located issues in the cell, run or program files (exit 2).
    """
    cell = load_cell(cell_path, pose_files=pose_files).cell
    run_doc = read_yaml(run_path)
    if isinstance(run_doc.data, dict) and "device" in run_doc.data and "steps" in run_doc.data:
        run_doc = parse_yaml_text(
            f"programs: [{json.dumps(Path(run_path).name)}]\ndt: {dt or 0.01!r}\n",
            str(Path(run_path).parent / "(program run)"),
        )
    rf = validate_document(run_doc, sp.RunFile)
    issues: list[Issue] = []
    base = Path(run_path).parent
    docs = []
    for i, rel in enumerate(rf.programs):
        path = Path(os.path.normpath(base / rel))
        if not path.is_file():
            issues.append(run_doc.issue(("programs", i), f"no such program file: {path}"))
            continue
        try:
            doc = read_yaml(path)
            docs.append((i, doc, validate_document(doc, sp.ProgramFile)))
        except UserError as exc:
            issues.extend(exc.issues)
    devices_seen: dict[str, int] = {}
    for i, doc, pf in docs:
        if pf.device in devices_seen:
            issues.append(
                run_doc.issue(
                    ("programs", i),
                    f"'{pf.device}' already has a program in this run (entry "
                    f"{devices_seen[pf.device] + 1}); a device runs one program",
                )
            )
        devices_seen.setdefault(pf.device, i)
    run_devices = set(devices_seen)
    programs = [_check_program(doc, pf, cell, run_devices, issues) for _, doc, pf in docs]
    warnings = []
    sync_users: dict[str, set[str]] = {}
    for prog in programs:
        for st in prog.steps:
            if st.kind == "sync":
                sync_users.setdefault(st.spec, set()).add(prog.device)
    for prog in programs:
        for st in prog.steps:
            if st.kind == "sync" and len(sync_users[st.spec]) < 2:
                warnings.append(
                    Issue(
                        st.where.rsplit(":", 1)[0],
                        int(st.where.rsplit(":", 1)[1]),
                        1,
                        f"steps[{st.index}].sync",
                        f"sync '{st.spec}' appears in no other program of the run; it passes at "
                        "once",
                        "warning",
                    )
                )
    # the model checked them already (located); here they become metres
    lengths = {
        key: parse_length(getattr(rf, key), key)
        for key in ("clearance", "collision_tolerance")
        if getattr(rf, key) is not None
    }
    if issues:
        raise UserError(
            f"{run_path}: {len(issues)} error(s)",
            sorted(issues, key=lambda i: (i.file, i.line, i.column)),
        )
    return Run(
        cell,
        programs,
        dt if dt is not None else rf.dt,
        run_path,
        warnings,
        clearance=lengths.get("clearance", 0.0),
        collision_tolerance=lengths.get("collision_tolerance", COLLISION_TOLERANCE),
        paths=rf.paths,
        seed=rf.seed,
        timeout=float(rf.timeout),
    )


def flow(value) -> str:
    """A program's value as one line of YAML flow text: mappings and lists by structure, their
    keys the format's own words, every name or text a quoted scalar (:func:`yaml_value`)."""
    if isinstance(value, dict):
        return "{" + ", ".join(f"{key}: {flow(v)}" for key, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(flow(v) for v in value) + "]"
    if isinstance(value, float):
        return repr(value)
    return yaml_value(value)


def program_text(doc: dict, schemas: str | None = None) -> str:
    """A program file from data: ``header`` (comment lines), ``device``, ``description``,
    ``units``, ``steps`` as (step mapping, trailing comment or None).  Written through the YAML
    library, so reading it back gives the same data whatever the names hold.  ``schemas``: the
    folder of the JSON Schemas its editor line points at (absolute; None: no such line)."""
    lines = []
    if schemas is not None:
        path = comment_text(str(Path(schemas) / "program.schema.json"))
        lines.append(f"# yaml-language-server: $schema={path}")
    lines += [f"# {comment_text(line)}" for line in doc.get("header", [])]
    lines.append(f"device: {yaml_value(doc['device'])}")
    if doc.get("description") is not None:
        lines.append(f"description: {yaml_value(doc['description'])}")
    if doc.get("units") is not None:
        lines.append(f"units: {flow(doc['units'])}")
    lines.append("steps:")
    for step, comment in doc["steps"]:
        [(kind, spec)] = step.items()  # one step, one kind
        line = f"  - {kind}: {flow(spec)}"
        lines.append(line + (f"   # {comment_text(comment)}" if comment else ""))
    return "\n".join(lines) + "\n"
