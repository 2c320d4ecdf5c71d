"""Robot calibration observations: points an external instrument measured on a frame the robot
carries, with the joint values at each (``rworld calibrate-robot``).

YAML::

    units: {length: mm, angle: deg}
    device: ur5
    instrument: laser tracker
    sigma: 0.02                 # 1 sigma per coordinate, length unit
    target: ur5.tip             # the device frame the instrument measures
    frame: world                # the frame the points are in; its pose is estimated unless world
    observations:
      - {joints: [0, -30, 60, 0, 45, 0], point: [1203.4, -22.1, 803.9]}

CSV: a header naming the device's joints and ``x, y, z``, units stated as in the header
(``x_mm``, ``shoulder_pan_joint_deg``) or a ``# units: mm, deg`` line above it, never
defaulted; ``device``, ``target``, ``frame`` and ``sigma`` in ``# key: value`` lines above.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from annotated_types import Len
from pydantic import Field

from ..errors import Issue, UserError, did_you_mean
from ..model.cell import CellModel
from ..model.measurements import RobotObservations
from ..units import ANGLE, LENGTH
from .loader import joint_values, pose_to_matrix, validate_document
from .models import Name, Pose, Strict, Units, Vec3
from .yamlio import read_yaml, yaml_value


class Observation(Strict):
    joints: Annotated[list[float], Len(1)] = Field(
        description="The device's joint values (angle unit, length unit for prismatic joints)."
    )
    point: Vec3 | None = Field(None, description="The measured point in 'frame' [length unit].")
    pose: Pose | None = Field(
        None,
        description="A 6-DoF instrument's measured pose of the target in 'frame' (xyz and rpy "
        "or a quaternion), instead of a point.",
    )


class Contact(Strict):
    joints: Annotated[list[float], Len(1)] = Field(
        description="The device's joint values when its ball probe touched the feature."
    )
    feature: str = Field(
        description="The feature touched ('owner.feature'): a plane from its outside, an edge "
        "(line), a hole's wall (circle) from inside, or a sphere (a point feature with "
        "'radius')."
    )
    radius: float | None = Field(
        None, gt=0, description="A point feature: the radius of the sphere around it [length]."
    )


class ObservationFile(Strict):
    """Points an instrument measured on a device frame, with the joint values at each; or the
    contacts of the robot's own ball probe with features of known geometry."""

    units: Units
    device: Name
    instrument: str = ""
    sigma: float = Field(gt=0, description="1 sigma per coordinate [length unit].")
    sigma_angle: float | None = Field(
        None, gt=0, description="Poses: 1 sigma per rotation axis [angle unit]."
    )
    target: str = Field(description="The measured frame: a frame with a pose on a link.")
    frame: str = Field("world", description="The frame the points are in.")
    axes: Literal["cell", "controller"] = Field(
        "cell",
        description="Whose joint values: the cell's, or the controller's axis values as its "
        "pendant and logs give them (a FANUC's or ABB's coupled J3), mapped through the cell's "
        "controller.axes.",
    )
    observations: list[Observation] = Field(default_factory=list)
    contacts: list[Contact] = Field(
        default_factory=list,
        description="Self-calibration: the robot's ball probe ('target' is its centre) touching "
        "features of the cell at these joint values.",
    )
    probe_radius: float | None = Field(
        None, ge=0, description="Contacts: the probe ball's radius [length unit]."
    )


def _joint_reader(dev, axes: str, issue, path: str):
    """``read(values, L, A) -> (q, why)``: a file's joint values as the cell's (SI, within the
    limits); with ``axes: controller`` the controller's axis values, mapped through the cell's
    ``controller.axes`` first."""
    if axes == "controller":
        profile = dev.controller
        if profile is None:
            raise _refuse(
                [
                    issue(
                        f"axes: controller, but '{dev.name}' has no controller: section in the "
                        "cell (its axes map: docs/formats.md)"
                    )
                ]
            )

        def read(values, L, A):
            raw, why = joint_values(dev, values, L, A, limits=False)
            if why is not None:
                return None, why
            q = profile.joints(raw)
            return joint_values(dev, q / _file_scale(dev, L, A), L, A)

        return read

    coupled = dev.controller is not None and not dev.controller.identity

    def read(values, L, A):
        q, why = joint_values(dev, values, L, A)
        if why is not None and coupled and "beyond the joint limits" in why:
            why += (
                "; or the controller's axis values (its coupled or offset axes): say "
                "'axes: controller'"
            )
        return q, why

    return read


def _file_scale(dev, L: float, A: float) -> np.ndarray:
    return np.array([A if j.kind == "revolute" else L for j in dev.joints])


def _refuse(issues: list[Issue]) -> UserError:
    """A located refusal: every issue printed with its file:line:col."""
    return UserError(issues[0].message, issues)


def _check(cell: CellModel, device: str, target: str, frame: str, at) -> None:
    """Device, target and frame exist and fit together; errors located by ``at(key)``."""
    issues = []
    dev = cell.devices.get(device)
    if dev is None:
        issues.append(
            at("device", f"unknown device '{device}'{did_you_mean(device, cell.devices)}")
        )
    if target not in cell.frames:
        qualified = f"{device}.{target}"
        if qualified not in cell.frames:
            issues.append(
                at("target", f"unknown frame '{target}'{did_you_mean(target, cell.frames)}")
            )
    if frame != "world" and frame not in cell.frames:
        issues.append(at("frame", f"unknown frame '{frame}'{did_you_mean(frame, cell.frames)}"))
    if issues:
        raise _refuse(issues)


def read_observations(path: str, cell: CellModel) -> tuple[RobotObservations, dict]:
    """The observations of ``path`` (YAML, or CSV by its suffix), SI, checked against ``cell``;
    with the file's path and SHA-256 for provenance.

    Raises
    ------
    UserError
        Bad syntax, types, units, unknown names, a wrong number of joint values, a value outside
        a joint's limits or not finite: located.
    """
    p = Path(path)
    if not p.is_file():
        raise UserError(f"no such observation file: {path}")
    digest = {"path": str(path), "sha256": hashlib.sha256(p.read_bytes()).hexdigest()}
    if p.suffix.lower() == ".csv":
        return _read_csv(p, cell), digest
    doc = read_yaml(p, str(path))
    f = validate_document(doc, ObservationFile)
    L, A = LENGTH[f.units.length], ANGLE[f.units.angle]

    def at(key, message):
        return doc.issue((key,), message)

    _check(cell, f.device, f.target, f.frame, at)
    dev = cell.devices[f.device]
    read_joints = _joint_reader(dev, f.axes, lambda m: at("axes", m), str(path))
    if bool(f.observations) == bool(f.contacts):
        raise _refuse(
            [
                doc.issue(
                    (),
                    "give 'observations' (instrument points) or 'contacts' (the probe's "
                    "touches), one of them",
                )
            ]
        )
    if f.contacts:
        return _contacts(doc, f, cell, dev, str(path), L, A, read_joints), digest
    issues = []
    q, points, rotations, lines = [], [], [], []
    with_poses = any(o.pose is not None for o in f.observations)
    if with_poses and f.sigma_angle is None:
        issues.append(doc.issue(("sigma",), "poses need 'sigma_angle' too (their rotations')"))
    for k, o in enumerate(f.observations):
        where = ("observations", k)
        if (o.point is None) == (o.pose is None) or (o.pose is not None) != with_poses:
            issues.append(
                doc.issue(
                    where,
                    "give a 'point' or a 'pose', one kind for the whole file",
                )
            )
            continue
        if o.pose is not None:
            T, error, _ = pose_to_matrix(o.pose, L, A)
            if error:
                issues.append(doc.issue(where + ("pose",), error))
                continue
            o_point, rotation = T[:3, 3] / L, T[:3, :3]
        else:
            o_point, rotation = np.array(o.point), None
        values, why = read_joints(o.joints, L, A)
        point = np.asarray(o_point, dtype=float) * L
        if why is None and not np.all(np.isfinite(point)):
            why = "a value is not a finite number"
        if why is not None:
            issues.append(doc.issue(where + ("joints",), why))
            continue
        q.append(values)
        points.append(point)
        rotations.append(rotation)
        lines.append(f"{path}:{doc.position(where)[0]}")
    if issues:
        raise _refuse(issues)
    target = f.target if f.target in cell.frames else f"{f.device}.{f.target}"
    obs = RobotObservations(
        f.device,
        target,
        f.frame,
        np.array(q),
        np.array(points),
        f.sigma * L,
        lines,
        f.instrument,
        np.array(rotations) if with_poses else None,
        (f.sigma_angle or 0.0) * A,
    )
    return obs, digest


def _contacts(
    doc, f: ObservationFile, cell: CellModel, dev, path: str, L: float, A: float, read_joints
):
    """The contact form: each touch's feature geometry in world (the cell's current poses)."""
    from ..model.measurements import Surfaces

    issues = []
    if f.probe_radius is None:
        issues.append(doc.issue(("contacts",), "contacts need the 'probe_radius' of the ball"))
    if f.frame != "world":
        issues.append(doc.issue(("frame",), "contacts are with the cell's features: frame world"))
    q, kinds, points, directions, radii, names, lines = [], [], [], [], [], [], []
    owners = []
    for k, c in enumerate(f.contacts):
        where = ("contacts", k)
        feature = cell.features.get(c.feature)
        if feature is None:
            issues.append(
                doc.issue(
                    where + ("feature",),
                    f"unknown feature '{c.feature}'{did_you_mean(c.feature, cell.features)}",
                )
            )
            continue
        if feature.owner == dev.name:
            issues.append(doc.issue(where + ("feature",), "a feature the robot itself carries"))
            continue
        values, why = read_joints(c.joints, L, A)
        if why is not None:
            issues.append(doc.issue(where + ("joints",), why))
            continue
        kind = {"point": "sphere"}.get(feature.kind, feature.kind)
        if kind == "sphere" and c.radius is None:
            issues.append(
                doc.issue(where, "a point feature is touched as a sphere: give its 'radius'")
            )
            continue
        point = np.asarray(feature.point, dtype=float)  # the owner's frame: placed by the api
        direction = (
            np.asarray(feature.direction, dtype=float)
            if feature.direction is not None
            else np.zeros(3)
        )
        owners.append(feature.owner)
        radius = (c.radius * L) if kind == "sphere" else (feature.radius or 0.0)
        q.append(values)
        kinds.append(kind)
        points.append(point)
        directions.append(direction)
        radii.append(radius)
        names.append(c.feature)
        lines.append(f"{path}:{doc.position(where)[0]}")
    if issues:
        raise _refuse(issues)
    target = f.target if f.target in cell.frames else f"{f.device}.{f.target}"
    surfaces = Surfaces(
        kinds,
        np.array(points),
        np.array(directions),
        np.array(radii),
        float(f.probe_radius or 0.0) * L,
        names,
        owners,
    )
    return RobotObservations(
        f.device,
        target,
        "world",
        np.array(q),
        np.zeros((len(q), 3)),
        f.sigma * L,
        lines,
        f.instrument,
        surfaces=surfaces,
    )


def _limits(dev, values, issue) -> list[Issue]:
    lower, upper = dev.limit_array("lower"), dev.limit_array("upper")
    out = []
    for i, j in enumerate(dev.joints):
        if values[i] < lower[i] - 1e-9 or values[i] > upper[i] + 1e-9:
            out.append(
                issue(
                    f"joint {j.name}: {values[i]:.6g} is outside its limits "
                    f"[{lower[i]:.6g}, {upper[i]:.6g}] (SI): a joint value in the wrong unit?"
                )
            )
    return out


def _read_csv(p: Path, cell: CellModel) -> RobotObservations:
    """The CSV form: ``# key: value`` lines, then a header naming the joints and x, y, z."""
    from .csvtext import read_csv_table

    shown = str(p)
    table = read_csv_table(shown, "<joint names>,x,y,z")
    meta: dict[str, tuple[str, int]] = {}
    for number, text in table.comments:
        key, sep, value = text.partition(":")
        if sep and number < table.header_line:
            meta[key.strip()] = (value.strip(), number)

    def need(key: str) -> tuple[str, int]:
        if key not in meta:
            raise _refuse(
                [Issue(shown, 1, 1, key, f"the CSV needs a '# {key}: ...' line above its header")]
            )
        return meta[key]

    def at(key, message):
        return Issue(shown, meta.get(key, ("", 1))[1], 1, key, message)

    device, _ = need("device")
    target, _ = need("target")
    frame = meta.get("frame", ("world", 0))[0]
    sigma_text, sigma_line = need("sigma")
    _check(cell, device, target, frame, at)
    dev = cell.devices[device]
    axes = meta.get("axes", ("cell", 0))[0]
    if axes not in ("cell", "controller"):
        raise _refuse([at("axes", f"axes: {axes}: give 'cell' or 'controller'")])
    if axes == "controller" and dev.controller is None:
        raise _refuse(
            [at("axes", f"axes: controller, but '{device}' has no controller: section in the cell")]
        )
    words = [w.strip() for w in meta.get("units", ("", 0))[0].split(",") if w.strip()]
    length_word = next((w for w in words if w in LENGTH), None)
    angle_word = next((w for w in words if w in ANGLE), None)
    columns: dict[str, tuple[int, str]] = {}
    for k, h in enumerate(table.header):
        base, _, unit = h.rpartition("_")
        if base and (unit in LENGTH or unit in ANGLE):
            columns[base] = (k, unit)
        else:
            columns[h] = (k, "")
    revolute = {j.name for j in dev.joints if j.kind == "revolute"}
    wanted = [j.name for j in dev.joints] + ["x", "y", "z"]
    missing = [w for w in wanted if w not in columns]
    if missing:
        raise _refuse(
            [
                Issue(
                    shown,
                    table.header_line,
                    1,
                    "header",
                    f"the header lacks {', '.join(missing)} (it names {', '.join(table.header)})",
                )
            ]
        )
    scales = []
    for w in wanted:
        unit = columns[w][1] or (angle_word if w in revolute else length_word) or ""
        units = ANGLE if w in revolute else LENGTH
        if unit not in units:
            example = f"{w}_{'deg' if w in revolute else 'mm'}"
            raise _refuse(
                [
                    Issue(
                        shown,
                        table.header_line,
                        1,
                        "header",
                        f"no unit for '{w}': write it in the header ('{example}') or in a "
                        "'# units: mm, deg' line; rworld never guesses units",
                    )
                ]
            )
        scales.append(units[unit])
    try:
        sigma = float(sigma_text) * (LENGTH[length_word] if length_word else float("nan"))
    except ValueError:
        sigma = float("nan")
    if not (sigma > 0 and np.isfinite(sigma)):
        raise _refuse(
            [
                Issue(
                    shown,
                    sigma_line,
                    1,
                    "sigma",
                    f"sigma '{sigma_text}' needs a value above 0 and the length unit of a "
                    "'# units: mm, deg' line",
                )
            ]
        )
    issues = []
    q, points, lines = [], [], []
    for line_number, fields, cols in table.rows:
        if len(fields) != len(table.header):  # a field shifted or dropped: never matched up
            issues.append(
                Issue(
                    shown,
                    line_number,
                    1,
                    "row",
                    f"{len(fields)} fields where the header names {len(table.header)}",
                )
            )
            continue
        try:
            values = np.array([float(fields[columns[w][0]]) for w in wanted]) * np.array(scales)
        except (ValueError, IndexError):
            issues.append(Issue(shown, line_number, 1, "row", "a value is missing or no number"))
            continue
        if not np.all(np.isfinite(values)):
            issues.append(Issue(shown, line_number, 1, "row", "a value is not a finite number"))
            continue
        if axes == "controller":  # the controller's axis values: the cell's joints first
            values[: dev.dof] = dev.controller.joints(values[: dev.dof])
        issues += _limits(
            dev, values[: dev.dof], lambda m, n=line_number: Issue(shown, n, 1, "row", m)
        )
        q.append(values[: dev.dof])
        points.append(values[dev.dof :])
        lines.append(f"{shown}:{line_number}")
    if issues:
        raise _refuse(issues)
    if not q:
        raise _refuse([Issue(shown, table.header_line, 1, "rows", "no observations")])
    target = target if target in cell.frames else f"{device}.{target}"
    return RobotObservations(device, target, frame, np.array(q), np.array(points), sigma, lines)


def file_scale(dev) -> np.ndarray:
    """(n,) factors from SI joint values to the files' units: degrees and millimetres."""
    return np.array([np.degrees(1.0) if j.kind == "revolute" else 1000.0 for j in dev.joints])


def _head(dev, target: str, sigma: float, comment: list[str], instrument: str) -> list[str]:
    return [
        *comment,
        "units: {length: mm, angle: deg}",
        f"device: {yaml_value(dev.name)}",
        f"instrument: {instrument}",
        f"sigma: {sigma * 1000:g}",
        f"target: {yaml_value(target)}",
    ]


def observation_template(dev, target: str, Q: np.ndarray, points: np.ndarray, sigma: float) -> str:
    """An observation file (mm, deg) of joint states ``Q`` (N, n) with the nominal points
    (N, 3) [m] to replace by the measured ones."""
    comment = [
        "# Robot calibration observations to fill in: each point is where the nominal model",
        "# puts the target; replace it by what the instrument measures.",
    ]
    lines = _head(dev, target, sigma, comment, "laser tracker") + ["frame: world", "observations:"]
    for q, p in zip(Q, points * 1000):
        joints = ", ".join(f"{v:.6f}" for v in q * file_scale(dev))
        lines.append(f"  - {{joints: [{joints}], point: [{', '.join(f'{v:.4f}' for v in p)}]}}")
    return "\n".join(lines) + "\n"


def contacts_template(
    dev, target: str, Q: np.ndarray, features: list[str], sigma: float, radius: float
) -> str:
    """A self-calibration contacts file (mm, deg) of the planned touches: joint states ``Q``
    (N, n) at the nominal contact on ``features``, to replace by the joint values the
    controller records at each trigger."""
    scale = file_scale(dev)
    comment = [
        "# Robot self-calibration contacts to fill in: the joints are where the nominal model",
        "# touches; replace them by the joint values the controller records at each trigger.",
    ]
    lines = _head(dev, target, sigma, comment, "touch-trigger ball probe")
    lines += [f"probe_radius: {radius * 1000:g}", "contacts:"]
    for q, name in zip(Q, features, strict=True):
        joints = ", ".join(f"{v:.6f}" for v in q * scale)
        lines.append(f"  - {{joints: [{joints}], feature: {yaml_value(name)}}}")
    return "\n".join(lines) + "\n"


def observation_file_text(
    device,
    target: str,
    frame: str,
    instrument: str,
    sigma: float,
    sigma_angle: float,
    joints: np.ndarray,
    poses: np.ndarray,
    header: list[str],
) -> str:
    """A robot observation file of 6-DoF poses (mm, deg) for ``rworld calibrate-robot``: the
    pose of ``target`` (a frame on ``device``) in ``frame`` at each of the joint values
    ``joints`` (K, n) [rad or m], ``poses`` (K, 4, 4) [m]; ``sigma`` [m] and ``sigma_angle``
    [rad] per axis; ``header`` the comment lines on top."""
    from .. import spatial

    per_unit = [1000.0 if j.kind == "prismatic" else float(np.degrees(1.0)) for j in device.joints]
    lines = [
        *(f"# {line}" for line in header),
        "units: {length: mm, angle: deg}",
        f"device: {yaml_value(device.name)}",
        f"instrument: {yaml_value(instrument)}",
        f"sigma: {sigma * 1000!r}",
        f"sigma_angle: {float(np.degrees(sigma_angle))!r}",
        f"target: {yaml_value(target)}",
        f"frame: {yaml_value(frame)}",
        "observations:",
    ]
    for q, T in zip(joints, poses, strict=True):
        values = ", ".join(repr(float(v) * u) for v, u in zip(q, per_unit, strict=True))
        xyz = ", ".join(repr(float(v) * 1000) for v in T[:3, 3])
        rpy = ", ".join(repr(float(v)) for v in np.degrees(spatial.matrix_to_rpy(T[:3, :3])))
        lines.append(f"  - joints: [{values}]")
        lines.append(f"    pose: {{xyz: [{xyz}], rpy: [{rpy}]}}")
    return "\n".join(lines) + "\n"


def robot_overlay_text(
    device, device_name: str, poses: dict, tool: str, digests: list[dict], figures: dict
) -> str:
    """A robot calibration as a pose-file overlay (mm, deg): every joint's frame (or DH row's
    correction) of the corrected ``device``, its compliance when it has any, the ``poses``
    (name -> (4, 4) [m], relative to each frame's parent) and the provenance: the date, the
    ``tool``, the input files' hashes (``digests``: path, sha256) and ``figures`` (name ->
    a number or text)."""
    import datetime as _dt

    from .. import spatial

    def pose(T) -> str:
        xyz = ", ".join(repr(float(x) * 1000) for x in T[:3, 3])
        rpy = ", ".join(repr(float(x)) for x in np.degrees(spatial.matrix_to_rpy(T[:3, :3])))
        return f"{{xyz: [{xyz}], rpy: [{rpy}]}}"

    lines = [
        f"# The robot's calibrated kinematics, written by '{tool}'.  List this",
        "# file last in the cell's pose_files; the nominal values stay where they are.",
        "units: {length: mm, angle: deg}",
    ]
    if device.convention == "frames":  # each joint's frame
        lines.append("joints:")
        for j in device.joints:
            lines.append(f"  {yaml_value(f'{device_name}.{j.name}')}: {pose(j.origin)}")
    else:  # a small pose before each DH row
        lines.append("corrections:")
        for j in device.joints:
            lines.append(f"  {yaml_value(f'{device_name}.{j.name}')}: {pose(j.correction)}")
    if any(j.compliance for j in device.joints):  # per kN m (per kN): readable numbers
        lines.append("compliance:  # deg per kN m (mm per kN for a prismatic joint)")
        for j in device.joints:
            unit = 1000.0 if j.kind == "prismatic" else float(np.degrees(1.0))  # mm or deg
            value = repr(float(j.compliance * unit * 1000))
            lines.append(f"  {yaml_value(f'{device_name}.{j.name}')}: {value}")
    if poses:
        lines.append("poses:")
        for name, T in poses.items():
            lines.append(f"  {yaml_value(name)}: {pose(T)}")
    lines.append("provenance:")
    lines.append(f"  date: {yaml_value(_dt.datetime.now().replace(microsecond=0).isoformat())}")
    lines.append(f"  tool: {tool}")
    lines.append(f"  device: {yaml_value(device_name)}")
    lines.append("  observations:")
    for d in digests:
        lines.append(f"    - {{path: {yaml_value(str(d['path']))}, sha256: {d['sha256']}}}")
    for key, value in figures.items():
        if isinstance(value, float):
            lines.append(f"  {key}: {value:.6g}")
        else:
            lines.append(f"  {key}: {value if isinstance(value, int) else yaml_value(value)}")
    return "\n".join(lines) + "\n"
