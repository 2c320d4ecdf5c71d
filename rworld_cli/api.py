"""Task-level functions: what each CLI command does, callable from Python.

Nothing here prints or exits; results are dataclasses, problems are raised
as :class:`~rworld_cli.errors.UserError`.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import Issue, UserError

__all__ = [
    "FileReport",
    "validate_files",
    "load_world",
    "FrameNode",
    "CellSummary",
    "summarize_cell",
    "schema_documents",
    "write_schemas",
    "stale_schemas",
]


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
    """(kind, parsed document or None): 'cell', 'poses', 'program' or 'run', from the top-level keys.

    A directory means its cell.yaml.  A file that cannot be read or parsed is
    treated as a cell, so the cell loader reports the problem with its location.
    """
    if path.is_dir():
        return "cell", None
    from .schema.yamlio import read_yaml

    try:
        doc = read_yaml(path)
    except UserError:
        return "cell", None
    if isinstance(doc.data, dict) and "name" not in doc.data:
        for key, kind in (("poses", "poses"), ("steps", "program"), ("programs", "run"), ("waypoints", "path")):
            if key in doc.data:
                return kind, doc
    return "cell", doc


def _cell_of(path: Path, cell: str | None) -> str | None:
    """The cell a path file is checked against: ``cell``, else the cell whose ``paths/`` folder holds it."""
    if cell is not None:
        return cell
    home = path.resolve().parent
    if home.name == "paths" and (home.parent / "cell.yaml").is_file():
        return os.path.relpath(home.parent / "cell.yaml")
    return None


def _validate_path_file(raw: str, doc, cell: str | None) -> str:
    """Check a path file (and against its cell, when one is known); returns the summary."""
    from .schema.loader import load_cell, validate_document
    from .errors import did_you_mean
    from .schema.program import PathFile

    pf = validate_document(doc, PathFile)
    cell_path = _cell_of(Path(raw), cell)
    if cell_path is None:
        return (f"{len(pf.waypoints)} waypoint(s); checked against a cell with --cell CELL "
                "(or when the file is in the cell's paths/ folder)")
    devices = load_cell(cell_path).cell.devices
    name = pf.device or (next(iter(devices)) if len(devices) == 1 else None)
    if name is None:
        raise UserError(f"{raw}: name the device", [doc.issue((), f"the cell has {len(devices)} devices ({', '.join(devices)}): "
                                                                  "say which one the path is for with 'device:'")])
    if name not in devices:
        raise UserError(f"{raw}: unknown device", [doc.issue(("device",), f"'{name}' is not a device of {cell_path}"
                                                                           f"{did_you_mean(name, devices)}")])
    path, doc2, _, scale = _read_path(raw, devices[name])
    issues = path_range_issues(path, devices[name], raw, doc2, scale)
    if issues:
        raise UserError(f"{raw}: the path leaves a joint's position range between waypoints", issues)
    return f"{len(pf.waypoints)} waypoint(s) for {name}, within its position range all along (checked against {cell_path})"


def validate_files(paths: list[str], cell: str | None = None) -> list[FileReport]:
    """Validate cell files (with the pose files and meshes they name), pose, program, run and path files.

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
    from .schema import models as sm
    from .schema import program as sp
    from .schema.loader import load_cell, resolve_cell_path, validate_document

    reports = []
    for raw in paths:
        kind, doc = _file_kind(Path(raw))
        shown = resolve_cell_path(raw)[1] if kind == "cell" else raw
        report = FileReport(shown, kind)
        try:
            if kind == "cell":
                loaded = load_cell(raw, doc)
                report.warnings = loaded.warnings
                c = loaded.cell
                report.summary = (
                    f"{len(c.devices)} device(s), {len(c.objects)} object(s), {len(c.sensors)} sensor(s), "
                    f"{len(c.frames) - 1} frame(s), {len(c.features)} feature(s), {len(c.conditions)} condition(s)"
                )
            elif kind == "path":
                report.summary = _validate_path_file(raw, doc, cell)
            elif kind == "poses":
                pf = validate_document(doc, sm.PoseFile)
                report.summary = f"{len(pf.poses)} pose(s); frame names are checked when a cell uses this file"
            else:
                model = sp.ProgramFile if kind == "program" else sp.RunFile
                parsed = validate_document(doc, model)
                count = f"{len(parsed.steps)} step(s) for {parsed.device}" if kind == "program" else f"{len(parsed.programs)} program(s)"
                report.summary = f"{count}; names are checked against the cell by 'rworld simulate' and 'rworld check'"
        except UserError as exc:
            report.errors = [i for i in exc.issues if i.severity == "error"] or [Issue(shown, 0, 0, "(file)", exc.message)]
            report.warnings = [i for i in exc.issues if i.severity == "warning"]
        reports.append(report)
    return reports


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
    from .schema.loader import load_cell
    from .world.tree import World

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
    children: list["FrameNode"] = field(default_factory=list)

    def as_dict(self) -> dict:
        from .spatial import matrix_to_rpy

        return {
            "name": self.name,
            "kind": self.kind,
            "owner": self.owner,
            "parent": self.parent,
            "primitive": self.primitive,
            "affixment": self.affixment,
            "xyz": self.T_world[:3, 3].tolist(),
            "rpy": matrix_to_rpy(self.T_world[:3, :3]).tolist(),
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
        seg = {"tactile": f" {s.rows}x{s.cols} cells", "proximity": f" {s.slices} slices"}.get(s.type, "")
        return kind, None, f"{s.type}{seg}"
    if kind == "device":
        d = cell.devices[name]
        kinds = "".join("R" if j.kind == "revolute" else "P" for j in d.joints)
        return kind, d.total_mass, f"{d.dof} DOF {kinds}, {d.convention} DH"
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

    def build(name: str) -> FrameNode:
        decl = cell.frames[name]
        primitive, mass, detail = _detail(cell, name) if decl.kind == "natural" else (None, None, "")
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
        node.children = [build(c) for c in world.children(name)]
        return node

    return CellSummary(
        name=cell.name,
        description=cell.description,
        root=build("world"),
        joints={d: world.joints(d).tolist() for d in cell.devices},
        active_tcps={d: world.active_tcp(d) for d in cell.devices},
        warnings=warnings,
        conditions=[{"frame": c.frame, "code": c.code, "type": c.name, "features": list(c.features)} for c in cell.conditions],
    )


# --------------------------------------------------------------------------- schemas

SCHEMA_FILES = {
    "cell.schema.json": ("models", "CellFile"),
    "poses.schema.json": ("models", "PoseFile"),
    "program.schema.json": ("program", "ProgramFile"),
    "run.schema.json": ("program", "RunFile"),
    "path.schema.json": ("program", "PathFile"),
}


def schema_documents() -> dict[str, str]:
    """The JSON Schema text of each file format, keyed by file name."""
    import importlib

    out = {}
    for filename, (module, model_name) in SCHEMA_FILES.items():
        model = getattr(importlib.import_module(f".schema.{module}", __package__), model_name)
        doc = {"$schema": "https://json-schema.org/draft/2020-12/schema", "$id": f"rworld/{filename}"}
        doc.update(model.model_json_schema(mode="validation"))
        out[filename] = json.dumps(doc, indent=2, ensure_ascii=False) + "\n"
    return out


def write_schemas(directory: str | Path) -> list[Path]:
    """Write every schema into ``directory`` atomically; return the paths written."""
    from .fileio import atomic_write_text

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


# --------------------------------------------------------------------------- device physics


@dataclass
class DeviceContext:
    """A device in its cell: the model, where its base is, which tool frame, and gravity in its base."""

    world: object  # World
    device: object  # DeviceModel
    tcp: str
    mount: object  # ToolMount
    T_world_base: np.ndarray
    gravity_base: np.ndarray
    warnings: list[Issue]

    def to_world(self, T_base: np.ndarray) -> np.ndarray:
        return self.T_world_base @ T_base

    def jacobian_to_world(self, J: np.ndarray) -> np.ndarray:
        R = self.T_world_base[:3, :3]
        out = np.empty_like(J)
        out[..., :3, :] = np.einsum("ij,...jk->...ik", R, J[..., :3, :])
        out[..., 3:, :] = np.einsum("ij,...jk->...ik", R, J[..., 3:, :])
        return out


def _tool_mount(world, device, tcp: str):
    """(ToolMount) of frame ``tcp`` on ``device``: the link it rides on and its fixed pose there."""
    from .kinematics.jacobian import ToolMount

    return ToolMount(*world.mount_of(device.name, tcp))


def device_context(cell_path: str, device: str, tcp: str | None = None,
                   joints: dict[str, list[float]] | None = None) -> DeviceContext:
    """Load a cell and prepare one device for kinematics and dynamics.

    Parameters
    ----------
    joints : dict, optional
        Joint values (SI) of devices, e.g. a conveyor that carries this one;
        they fix the device's base pose and the tools it carries.
    tcp : str, optional
        A frame carried by the device (default its active TCP); local names
        (``tool``) are qualified with the device name.
    """
    from .errors import did_you_mean

    world, warnings = load_world(cell_path, joints)
    cell = world.cell
    if device not in cell.devices:
        raise UserError(f"unknown device '{device}'{did_you_mean(device, cell.devices)}; the cell has: {', '.join(cell.devices) or 'none'}")
    model = cell.devices[device]
    if tcp is None:
        tcp = world.active_tcp(device)
    elif tcp not in cell.frames and f"{device}.{tcp}" in cell.frames:
        tcp = f"{device}.{tcp}"
    if tcp not in cell.frames:
        raise UserError(f"unknown frame '{tcp}'{did_you_mean(tcp, cell.frames)}")
    mount = _tool_mount(world, model, tcp)
    T_world_base = world.T_world(device)
    gravity_base = T_world_base[:3, :3].T @ cell.gravity
    return DeviceContext(world, model, tcp, mount, T_world_base, gravity_base, warnings)


def _check_joint_count(ctx: DeviceContext, q: np.ndarray, what: str = "joint values"):
    n = ctx.device.dof
    if q.shape[-1] != n:
        raise UserError(f"device '{ctx.device.name}' has {n} joint(s); {what} have {q.shape[-1]}")


def forward_kinematics(ctx: DeviceContext, q) -> np.ndarray:
    """``T_world_tcp`` for joint values ``q`` (n,) or (N, n); shape (4, 4) or (N, 4, 4)."""
    from .kinematics.jacobian import tool_pose

    q = np.asarray(q, dtype=float)
    _check_joint_count(ctx, q)
    return ctx.to_world(tool_pose(ctx.device, q, ctx.mount))


@dataclass
class JacobianResult:
    jacobian: np.ndarray  # (N, 6, n)
    manipulability: np.ndarray  # (N,)
    condition_number: np.ndarray  # (N,)
    frame: str


def jacobians(ctx: DeviceContext, q, frame: str = "world", point_in_tool=None) -> JacobianResult:
    """Geometric Jacobians at the TCP origin (or a point on the tool), with manipulability and conditioning."""
    from .kinematics.jacobian import condition_number, jacobian, manipulability

    q = np.atleast_2d(np.asarray(q, dtype=float))
    _check_joint_count(ctx, q)
    J = jacobian(ctx.device, q, ctx.mount, point_in_tool)
    if frame == "world":
        J = ctx.jacobian_to_world(J)
    elif frame != "base":
        raise UserError(f"frame must be 'world' or 'base', got '{frame}'")
    return JacobianResult(J, manipulability(J), condition_number(J), frame)


def inverse_kinematics(ctx: DeviceContext, T_world_target: np.ndarray, target_name: str, seed=None,
                       position_only: bool = False, restarts: int = 16):
    """Solve IK for the context's TCP; raise UserError (exit 2) with the figures when unreachable."""
    from .kinematics.inverse import solve_ik

    T_base_target = np.linalg.inv(ctx.T_world_base) @ T_world_target
    seed = ctx.world.joints(ctx.device.name) if seed is None else np.asarray(seed, dtype=float)
    _check_joint_count(ctx, np.asarray(seed), "the seed")
    result = solve_ik(ctx.device, T_base_target, ctx.mount, seed, position_only, restarts)
    if not result.success:
        why = result.unreachable(target_name, ctx.tcp, [j.name for j in ctx.device.joints], position_only)
        raise UserError(f"target {why[:-1]}; {restarts + 1} starts)")
    return result


def resolve_payload(ctx: DeviceContext, object_name: str | None, mass: float | None, com=None):
    """A Payload from an object of the cell (at its current pose relative to the TCP, or at the TCP) or a point mass."""
    from .dynamics import Payload
    from .errors import did_you_mean

    if object_name and mass is not None:
        raise UserError("give --payload OBJECT or --payload-mass KG, not both")
    if object_name:
        objects = ctx.world.cell.objects
        if object_name not in objects:
            raise UserError(f"unknown object '{object_name}'{did_you_mean(object_name, objects)}")
        held = object_name in ctx.world.subtree(ctx.tcp)
        T = ctx.world.T(ctx.tcp, object_name) if held else np.eye(4)
        return Payload.rigid_body(objects[object_name].inertial, T)
    if mass is not None:
        if not (mass >= 0 and np.isfinite(mass)):
            raise UserError(f"--payload-mass must be a finite number >= 0, got {mass}")
        return Payload.point_mass(mass, com if com is not None else (0.0, 0.0, 0.0))
    return None


def carried_loads(ctx: DeviceContext, exclude=()) -> dict[int, list]:
    """What rides on the device's links in the cell's state - aggregated devices (a hand on the
    flange), grasped objects - as ``DeviceDynamics`` link loads; ``exclude`` names primitives to leave
    out (an object given as the payload)."""
    return ctx.world.carried_loads(ctx.device.name, set(exclude))


def carried_summary(ctx: DeviceContext, exclude=()) -> list[dict]:
    """[{"name", "link", "mass"}] of what rides on the device's links (see :func:`carried_loads`)."""
    return [{"name": name, "link": link, "mass": float(sum(inertial.mass for inertial, _ in bodies))}
            for name, link, bodies in ctx.world.carried(ctx.device.name, set(exclude))]


def device_dynamics(ctx: DeviceContext, payload=None, armature: bool = True, friction: bool = True, exclude=()):
    """:class:`~rworld_cli.dynamics.DeviceDynamics` of the context's device, payload at its TCP.

    What the cell's state puts on its links (hands, grasped objects) is included, as the simulator
    includes it, except the primitives named in ``exclude`` (an object given as the payload).
    """
    from .dynamics import DeviceDynamics

    if payload is not None and payload.mass > 0 and ctx.mount.link == 0:
        raise UserError(f"'{ctx.tcp}' sits on the base of '{ctx.device.name}': a payload there loads no joint; choose a TCP on a link")
    return DeviceDynamics(ctx.device, payload, ctx.mount, armature, friction, link_loads=carried_loads(ctx, exclude))


@dataclass
class StaticResult:
    tau: np.ndarray  # (N, n) total: gravity hold + J^T w
    tau_wrench: np.ndarray
    tau_gravity: np.ndarray
    max_scale: np.ndarray  # (N,)
    limiting_joint: np.ndarray  # (N,)


def static_torques(ctx: DeviceContext, q, wrench_world, payload=None, gravity: bool = True, exclude=()) -> StaticResult:
    """Joint torques holding the device (and payload) still while the tool exerts ``wrench_world``.

    Also the largest multiple of the wrench the effort limits allow, and the joint that binds.
    """
    from .dynamics.statics import wrench_capacity, wrench_torques

    q = np.atleast_2d(np.asarray(q, dtype=float))
    _check_joint_count(ctx, q)
    w = np.asarray(wrench_world, dtype=float)
    J = jacobians(ctx, q, "world").jacobian
    tau_w = wrench_torques(J, w)
    dyn = device_dynamics(ctx, payload, armature=False, friction=False, exclude=exclude)
    tau_g = dyn.gravity_torques(q, ctx.gravity_base) if gravity else np.zeros_like(q)
    cap = wrench_capacity(J, w, ctx.device.limit_array("effort"), tau_g)
    return StaticResult(tau_g + tau_w, tau_w, tau_g, cap.scale, cap.limiting_joint)


# --------------------------------------------------------------------------- sensing


def sense(cell_path: str, joints: dict[str, list[float]] | None = None, sensors: list[str] | None = None,
          tolerance: float | None = None):
    """Load a cell, set joint values, and read its sensors by interference checking.

    Returns
    -------
    (World, list of SensorReading)
    """
    from .errors import did_you_mean
    from .sensing.geometry import DEFAULT_TOLERANCE
    from .sensing.sensors import read_sensors

    world, _ = load_world(cell_path, joints)
    for name in sensors or []:
        if name not in world.cell.sensors:
            raise UserError(f"unknown sensor '{name}'{did_you_mean(name, world.cell.sensors)}; the cell has: {', '.join(world.cell.sensors) or 'none'}")
    tol = DEFAULT_TOLERANCE if tolerance is None else tolerance
    if not (tol >= 0 and np.isfinite(tol)):
        raise UserError(f"the tolerance must be a finite length >= 0 (m), got {tolerance}")
    return world, read_sensors(world, sensors or None, tol)


# --------------------------------------------------------------------------- calibration


def parse_length(text: str, default_unit: str = "mm") -> float:
    """'0.05mm', '50um', '0.00005m' or a bare number in ``default_unit`` -> metres."""
    import re

    m = re.fullmatch(r"\s*([0-9.eE+-]+)\s*(mm|um|m)?\s*", str(text))
    if not m:
        raise UserError(f"'{text}' is not a length: write e.g. 0.05mm, 50um or 0.00005m")
    try:
        value = float(m.group(1))
    except ValueError:
        raise UserError(f"'{text}' is not a length: write e.g. 0.05mm, 50um or 0.00005m") from None
    unit = m.group(2) or default_unit
    return value * {"mm": 1e-3, "um": 1e-6, "m": 1.0}[unit]


@dataclass
class CalibrationRun:
    result: object  # CalibrationResult
    written: Path | None
    output: Path
    listed: bool  # the output is among the cell's pose files


def calibrate_cell(cell_path: str, measurement_paths: list[str], frames: list[str] | None = None, output: str | None = None,
                   csv_units: str = "mm", dry_run: bool = False) -> CalibrationRun:
    """Calibrate a cell's conditioned frames and write the overlay (unless ``dry_run`` or a frame is undetermined)."""
    from .calibration.measurements import load_measurements
    from .calibration.pipeline import calibrate, overlay_yaml
    from .fileio import atomic_write_text
    from .schema.loader import load_cell, resolve_cell_path

    loaded = load_cell(cell_path)
    cell = loaded.cell
    real, _ = resolve_cell_path(cell_path)
    out = Path(output) if output else real.parent / "calibrated.yaml"
    protected = {real.resolve()} | {p.resolve() for p in cell.pose_files[:1]}
    if out.resolve() in protected or out.resolve().parent.name in ("programs", "runs"):
        raise UserError(f"refusing to write calibrated poses to {out}: it is the cell's structure, its nominal pose file or a program; "
                        "write an overlay (default: calibrated.yaml beside cell.yaml)")
    measured = load_measurements(measurement_paths, cell, csv_units)
    result = calibrate(cell, measured, frames)
    written = None
    if not dry_run and not result.undetermined:
        atomic_write_text(out, overlay_yaml(result, measured.files))
        written = out
    listed = out.resolve() in {p.resolve() for p in cell.pose_files}
    return CalibrationRun(result, written, out, listed)


def simulate_measurement_file(cell_path: str, truth_path: str, output: str, sigma: float, seed: int = 0,
                              points: int = 10, frames: list[str] | None = None) -> dict:
    """Synthetic probe points of the conditioned features, taken on a 'true' cell, written as a measurement file."""
    from .calibration.pipeline import measurement_yaml, simulate_measurements
    from .fileio import atomic_write_text
    from .schema.loader import load_cell

    nominal = load_cell(cell_path).cell
    truth = load_cell(truth_path).cell
    if set(nominal.features) != set(truth.features):
        raise UserError(f"the truth cell {truth_path} must have the same features as {cell_path}")
    if not (sigma >= 0 and np.isfinite(sigma)):
        raise UserError(f"sigma must be a finite length >= 0, got {sigma}")
    if points < 1:
        raise UserError(f"--points must be at least 1, got {points}")
    conditions = [c for c in nominal.conditions if frames is None or c.frame in frames]
    features = sorted({f for c in conditions for f in c.features})
    if not features:
        raise UserError("no conditioned features to measure: the cell has no frame conditions (for the frames asked)")
    from .units import MIN_POINTS

    counts = {f: max(points, MIN_POINTS[nominal.features[f].kind]) for f in features}
    doc = simulate_measurements(nominal, truth, features, counts, sigma, seed)
    atomic_write_text(output, measurement_yaml(doc, nominal.name, sigma if sigma > 0 else 1e-12, seed, str(truth_path)))
    return {"features": features, "points": counts, "written": output}


def plan_cell_measurements(cell_path: str, frames: list[str] | None, sigma: float, tolerance: float):
    """Measuring directives for a cell's conditioned frames (see calibration/plan.py)."""
    from .calibration.plan import plan_measurements
    from .schema.loader import load_cell
    from .errors import did_you_mean

    cell = load_cell(cell_path).cell
    conditioned = {c.frame for c in cell.conditions}
    if not conditioned:
        raise UserError(f"{cell_path} has no frame conditions: nothing to measure (add 'conditions' to the cell)")
    for f in frames or []:
        if f not in conditioned:
            raise UserError(f"'{f}' has no frame condition{did_you_mean(f, conditioned)}; conditioned frames: {', '.join(sorted(conditioned))}")
    for name, value in (("sigma", sigma), ("tolerance", tolerance)):
        if not (value > 0 and np.isfinite(value)):
            raise UserError(f"{name} must be a positive length, got {value}")
    return cell, plan_measurements(cell, frames, sigma, tolerance)


# --------------------------------------------------------------------------- planning


def _read_path(path_file: str, device):
    """(JointPath, doc, PathFile, scale): a path file checked against the device (located errors, exit 2)."""
    from .planning.path import JointPath
    from .schema.loader import ANGLE, LENGTH, validate_document
    from .schema.program import PathFile
    from .schema.yamlio import read_yaml

    doc = read_yaml(path_file)
    pf = validate_document(doc, PathFile)
    n = device.dof
    issues = []
    for k, row in enumerate(pf.waypoints):
        if len(row) != n:
            issues.append(doc.issue(("waypoints", k), f"{len(row)} value(s) but '{device.name}' has {n} joint(s)"))
    if pf.knots is not None:
        kn = pf.knots
        if len(kn) != len(pf.waypoints) or kn[0] != 0 or kn[-1] != 1 or any(b <= a for a, b in zip(kn, kn[1:])):
            issues.append(doc.issue(("knots",), f"knots must rise strictly from 0 to 1, one per waypoint ({len(pf.waypoints)})"))
    if issues:
        raise UserError(f"{path_file}: invalid path", issues)
    scale = np.array([ANGLE[pf.units.angle] if j.kind == "revolute" else LENGTH[pf.units.length] for j in device.joints])
    q = np.array(pf.waypoints, dtype=float) * scale
    lo, hi = device.limit_array("lower"), device.limit_array("upper")
    bad = np.argwhere((q < lo) | (q > hi))
    if len(bad):
        issues = [doc.issue(("waypoints", int(k), int(j)), f"{pf.waypoints[k][j]} is outside the position limits of {device.joints[j].name} "
                            f"[{lo[j] / scale[j]:.6g}, {hi[j] / scale[j]:.6g}]") for k, j in bad]
        k, j = bad[0]
        raise UserError(f"{path_file}: waypoint {k + 1} puts joint {device.joints[j].name} outside its position limits", issues)
    return JointPath(q, pf.knots, pf.boundary), doc, pf, scale


def path_range_issues(path, device, path_file: str, doc=None, scale=None) -> list[Issue]:
    """Located issues for joints that leave their position range between the path's waypoints.

    The extrema are exact (the roots of q' on every cubic piece).  Each issue points at the
    waypoint that ends the piece where the joint peaks, with the value and limit in the file's units.
    """
    from .planning.path import range_excursions

    out = []
    scale = np.ones(device.dof) if scale is None else scale
    for e in range_excursions(path, device.limit_array("lower"), device.limit_array("upper")):
        piece = int(np.clip(np.searchsorted(path.knots, e.s, side="right") - 1, 0, len(path.knots) - 2))
        name = device.joints[e.joint].name
        where = "above its upper" if e.side == "upper" else "below its lower"
        message = (f"joint {name} leaves its position range between waypoints {piece + 1} and {piece + 2}: "
                   f"{e.value / scale[e.joint]:.6g} at s = {e.s:.4f}, {where} limit {e.limit / scale[e.joint]:.6g}")
        if doc is not None:
            out.append(doc.issue(("waypoints", piece + 1, e.joint), message))
        else:
            out.append(Issue(path_file, 0, 0, "(path)", message))
    return out


def load_joint_path(path_file: str, device, check_range: bool = True):
    """A :class:`~rworld_cli.planning.path.JointPath` from a path file, checked against the device.

    Raises
    ------
    UserError
        The file is malformed, or a waypoint is outside its joint's range (exit 2).
    CheckFailed
        ``check_range`` and the spline leaves a joint's range between waypoints (exit 1).
    """
    from .errors import CheckFailed

    path, doc, _, scale = _read_path(path_file, device)
    if check_range:
        issues = path_range_issues(path, device, path_file, doc, scale)
        if issues:
            raise CheckFailed(f"{path_file}: the path leaves a joint's position range between waypoints", issues)
    return path


def check_path_range(path, device, what: str) -> None:
    """Raise CheckFailed (exit 1) when ``path`` (built in code, e.g. reshaped knots) leaves a joint's range."""
    from .errors import CheckFailed

    issues = path_range_issues(path, device, what)
    if issues:
        raise CheckFailed(f"{what}: the path leaves a joint's position range", issues)


def write_path_with_knots(path_file: str, knots, output: str, note: str = "") -> None:
    """Write ``path_file`` again with new ``knots`` (same waypoints, units and boundary), atomically."""
    from .fileio import atomic_write_text
    from .schema.loader import validate_document
    from .schema.program import PathFile
    from .schema.yamlio import read_yaml

    pf = validate_document(read_yaml(path_file), PathFile)
    lines = [f"# {path_file} with new knots{': ' + note if note else ''}"]
    if pf.device:
        lines.append(f"device: {pf.device}")
    lines.append(f"units: {{length: {pf.units.length}, angle: {pf.units.angle}}}")
    lines.append("waypoints:")
    lines += ["  - [" + ", ".join(repr(float(v)) for v in row) + "]" for row in pf.waypoints]
    lines.append("knots: [" + ", ".join(f"{float(k):.9g}" for k in knots) + "]")
    lines.append(f"boundary: {pf.boundary}")
    atomic_write_text(output, "\n".join(lines) + "\n")


def planning_limits(device, torque: bool = True, acceleration: bool = True):
    """The device's limits for planning.  A joint with no limit of a kind is unlimited in that kind,
    alone (``inf``); the other joints keep theirs.  ``torque=False`` / ``acceleration=False`` leave
    the kind out for every joint."""
    from .planning.topp import Limits

    v, a, e = device.limit_array("velocity"), device.limit_array("acceleration"), device.limit_array("effort")
    return Limits(v, a if acceleration and np.any(np.isfinite(a)) else None, e if torque and np.any(np.isfinite(e)) else None)


def unlimited_joints(device, limits) -> dict[str, list[str]]:
    """Per kind, the names of the joints that run unlimited in a plan with ``limits`` (no limit in the cell)."""
    names = [j.name for j in device.joints]
    out = {kind: [names[j] for j in joints] for kind, joints in limits.unlimited().items()}
    position = device.unlimited().get("position")
    if position:
        out = {"position": position, **out}
    return out


def plan_time_optimal(ctx: DeviceContext, path, payload=None, gridpoints: int = 1000, torque: bool = True, friction: bool = False,
                      exclude=()):
    """Time-optimal timing of ``path`` for the context's device; (timing, info, dynamics, limits).

    The torques include what the cell's state puts on the device's links, except ``exclude``.
    """
    from .planning.topp import InfeasiblePath, time_optimal

    limits = planning_limits(ctx.device, torque)
    dyn = device_dynamics(ctx, payload, armature=True, friction=friction, exclude=exclude) if limits.effort is not None else None
    try:
        timing, info = time_optimal(path, limits, dyn, ctx.gravity_base, gridpoints)
    except InfeasiblePath as exc:
        raise UserError(f"no timing of the path stays within the limits: {exc}") from None
    return timing, info, dyn, limits


def parse_period(text: str) -> float:
    """'8ms', '0.008s' or a bare number of seconds -> seconds (> 0)."""
    import re

    m = re.fullmatch(r"\s*([0-9.eE+-]+)\s*(ms|s|us)?\s*", str(text))
    try:
        value = float(m.group(1)) * {"ms": 1e-3, "s": 1.0, "us": 1e-6}[m.group(2) or "s"] if m else float("nan")
    except ValueError:
        value = float("nan")
    if not (value > 0 and np.isfinite(value)):
        raise UserError(f"--period '{text}' is not a positive duration: write e.g. 8ms, 0.004s or 0.002")
    return value


def sample_timed_path(path, timing, samples: int | None = None, period: float | None = None, grid_instants: bool = False):
    """The rows a plan writes: ``samples`` equally spaced instants or every ``period`` seconds,
    plus both sides of every grid instant (where sddot jumps) with ``grid_instants``."""
    from .planning.topp import sample_instants, sample_path

    return sample_path(path, timing, sample_instants(timing, samples, period), switches=grid_instants)


def trajectory_table(samples, dynamics=None, gravity=None) -> tuple[list[str], np.ndarray]:
    """(columns, rows) of a trajectory CSV: t, s, sd, sdd, q1..qn, qd1..qdn, qdd1..qddn[, tau1..taun] (SI)."""
    n = samples.q.shape[1]
    cols = ["t", "s", "sd", "sdd"] + [f"{g}{i}" for g in ("q", "qd", "qdd") for i in range(1, n + 1)]
    blocks = [samples.t[:, None], samples.s[:, None], samples.sd[:, None], samples.sdd[:, None], samples.q, samples.qd, samples.qdd]
    if dynamics is not None:
        cols += [f"tau{i}" for i in range(1, n + 1)]
        blocks.append(dynamics.inverse(samples.q, samples.qd, samples.qdd, gravity))
    return cols, np.hstack(blocks)


@dataclass
class TimedTrajectory:
    """A trajectory timed elsewhere, read from CSV (SI)."""

    t: np.ndarray  # (K,)
    q: np.ndarray  # (K, n)
    qd: np.ndarray
    qdd: np.ndarray
    source: str

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])


def read_trajectory(csv_path: str, device) -> TimedTrajectory:
    """A trajectory CSV (columns t, q1..qn, qd1..qdn, qdd1..qddn in SI; others ignored), checked.

    Raises
    ------
    UserError
        Missing columns, bad values, time that goes back, or joint values outside their
        position limits - located as ``file:line:col``; nothing is evaluated.
    """
    from .tableio import read_states

    data = read_states(csv_path, device.dof, ["q", "qd", "qdd"], scalars=("t",))
    t, lines, tcol = data["t"], data["_line"], data["_column"]["t"]
    issues = []
    back = np.flatnonzero(np.diff(t) < 0)  # a repeated instant is allowed: both sides of a switch in the acceleration
    for k in back[:10]:
        issues.append(Issue(csv_path, int(lines[k + 1]), int(tcol[k + 1]), "column 't'",
                            f"time {float(t[k + 1])!r} comes before the row above ({float(t[k])!r}): a trajectory's time must not go back"))
    lo, hi = device.limit_array("lower"), device.limit_array("upper")
    for k, j in np.argwhere((data["q"] < lo - 1e-9) | (data["q"] > hi + 1e-9))[:10]:
        issues.append(Issue(csv_path, int(lines[k]), 0, f"column 'q{j + 1}'",
                            f"{data['q'][k, j]:.6g} is outside the position limits of {device.joints[j].name} [{lo[j]:.6g}, {hi[j]:.6g}]"))
    if issues:
        raise UserError(f"{csv_path}: {len(issues)} error(s)", issues)
    if not t[-1] > t[0]:
        raise UserError(f"{csv_path}: a trajectory needs rows at two instants at least",
                        [Issue(csv_path, int(lines[0]), 1, "(rows)", "every row is at the same instant")])
    return TimedTrajectory(t, data["q"], data["qd"], data["qdd"], csv_path)


@dataclass
class PayloadResult:
    capacity: object  # planning.payload.Capacity
    duration: float  # [s]
    binding_time: float  # [s] from the start of the motion
    instants: int  # instants checked


def plan_payload(ctx: DeviceContext, path_file: str | None, trajectory_file: str | None, timing: str = "time-optimal",
                 duration: float | None = None, com=(0.0, 0.0, 0.0), payload_object: str | None = None,
                 gridpoints: int = 1000, samples: int = 20001) -> PayloadResult:
    """The exact payload capacity of a motion: a path timed here (time-optimal or quintic) or a trajectory CSV.

    The torques include what the cell's state puts on the device's links (except ``payload_object``).
    """
    from .dynamics import Payload
    from .planning.payload import payload_capacity, quintic_timing

    if trajectory_file is not None:
        tr = read_trajectory(trajectory_file, ctx.device)
        t, q, qd, qdd, T = tr.t - tr.t[0], tr.q, tr.qd, tr.qdd, tr.duration
    else:
        path = load_joint_path(path_file, ctx.device)
        if timing == "quintic":
            if duration is None or not duration > 0:
                raise UserError("--timing quintic needs --duration SECONDS > 0")
            t, s, sd, sdd = quintic_timing(duration, samples)
            q, dq, ddq = path.evaluate(s)
            qd, qdd = dq * sd[:, None], ddq * (sd**2)[:, None] + dq * sdd[:, None]
            T = duration
        else:
            tm, _, _, _ = plan_time_optimal(ctx, path, None, gridpoints, torque=False)
            # the acceleration jumps at grid instants: both one-sided limits count, not only the samples
            rows = sample_timed_path(path, tm, samples, grid_instants=True)
            t, q, qd, qdd, T = rows.t, rows.q, rows.qd, rows.qdd, tm.duration
    unit = None
    if payload_object:
        obj = ctx.world.cell.objects.get(payload_object)
        if obj is None or obj.inertial.mass <= 0:
            raise UserError(f"'{payload_object}' is not an object with mass in the cell")
        held = payload_object in ctx.world.subtree(ctx.tcp)
        body = Payload.rigid_body(obj.inertial, ctx.world.T(ctx.tcp, payload_object) if held else None)
        unit = Payload(1.0, body.com, body.inertia / body.mass)
    exclude = [payload_object] if payload_object else ()
    cap = payload_capacity(ctx.device, q, qd, qdd, ctx.gravity_base, com, ctx.mount, armature=True, friction=False,
                           unit_payload=unit, link_loads=carried_loads(ctx, exclude))
    return PayloadResult(cap, float(T), float(t[cap.sample]), len(t))
