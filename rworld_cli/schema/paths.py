"""Path files (``paths/*.yaml``): read with located errors against a device, written with new
knots.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import Issue, UserError
from ..fileio import atomic_write_text
from ..model.paths import MAX_BLEND, PathSpec
from ..units import ANGLE, LENGTH
from .loader import validate_document
from .program import PathFile
from .yamlio import Marked, comment_text, read_yaml, yaml_value


@dataclass
class LoadedPath:
    """A path file read against a device: the path in SI, and where each value sits in the file."""

    spec: PathSpec
    file: str
    scale: np.ndarray  # (n,): file unit -> SI per joint
    doc: Marked
    raw: PathFile

    def issue(self, waypoint: int, joint: int, message: str) -> Issue:
        """A problem located at waypoint ``waypoint``'s value of joint ``joint`` (0-based)."""
        return self.doc.issue(("waypoints", waypoint, joint), message)


def read_path(path_file: str, device) -> LoadedPath:
    """Read a path file for ``device`` (a DeviceModel).

    Raises
    ------
    UserError
        Located problems: syntax and types, waypoints of the wrong length, knots that do not
        rise from 0 to 1, waypoints outside their joint's position limits.
    """
    doc = read_yaml(path_file)
    pf = validate_document(doc, PathFile)
    n = device.dof
    issues = []
    for k, row in enumerate(pf.waypoints):
        if len(row) != n:
            issues.append(
                doc.issue(
                    ("waypoints", k), f"{len(row)} value(s) but '{device.name}' has {n} joint(s)"
                )
            )
    if pf.knots is not None:
        kn = pf.knots
        if (
            len(kn) != len(pf.waypoints)
            or kn[0] != 0
            or kn[-1] != 1
            or any(b <= a for a, b in zip(kn, kn[1:]))
        ):
            issues.append(
                doc.issue(
                    ("knots",),
                    f"knots must rise strictly from 0 to 1, one per waypoint ({len(pf.waypoints)})",
                )
            )
    issues += _blend_issues(doc, pf)
    kinds = {j.kind for j in device.joints}
    for kind, unit, example in (("revolute", "angle", "deg"), ("prismatic", "length", "mm")):
        if kind in kinds and getattr(pf.units, unit) is None:
            issues.append(
                doc.issue(
                    ("units",),
                    f"'{device.name}' has {kind} joints, and the file gives no units.{unit}: add "
                    f"it (e.g. {unit}: {example}); rworld never guesses units",
                )
            )
    if issues:
        raise UserError(f"{path_file}: invalid path", issues)
    scale = np.array(
        [
            ANGLE[pf.units.angle] if j.kind == "revolute" else LENGTH[pf.units.length]
            for j in device.joints
        ]
    )
    q = np.array(pf.waypoints, dtype=float) * scale
    lo, hi = device.limit_array("lower"), device.limit_array("upper")
    bad = np.argwhere((q < lo) | (q > hi))
    if len(bad):
        issues = [
            doc.issue(
                ("waypoints", int(k), int(j)),
                f"{pf.waypoints[k][j]} is outside the position limits of "
                f"{device.joints[j].name} [{lo[j] / scale[j]:.6g}, {hi[j] / scale[j]:.6g}]",
            )
            for k, j in bad
        ]
        k, j = bad[0]
        raise UserError(
            f"{path_file}: waypoint {k + 1} puts joint {device.joints[j].name} outside its "
            "position limits",
            issues,
        )
    knots = None if pf.knots is None else np.array(pf.knots, dtype=float)
    blends = None if pf.blends is None else np.array(pf.blends, dtype=float)
    return LoadedPath(PathSpec(q, knots, pf.boundary, pf.device, blends), path_file, scale, doc, pf)


def _blend_issues(doc: Marked, pf: PathFile) -> list[Issue]:
    """Located problems of a path file's ``blends``: only with ``boundary: blended``, one per
    waypoint, each in [0, 0.5], the ends 0; a blended path gives no knots."""
    if pf.boundary != "blended":
        if pf.blends is not None:
            return [doc.issue(("blends",), "blends are for 'boundary: blended'")]
        return []
    out = []
    if pf.knots is not None:
        out.append(
            doc.issue(
                ("knots",),
                "a blended path's knots follow its joint-space lengths: remove 'knots'",
            )
        )
    for k in range(1, len(pf.waypoints)):
        if pf.waypoints[k] == pf.waypoints[k - 1]:
            out.append(
                doc.issue(
                    ("waypoints", k),
                    f"waypoint {k + 1} repeats waypoint {k}: a blended path's knots follow its "
                    "lengths, so each waypoint must differ from the one before",
                )
            )
    if pf.blends is None:
        return out
    b, W = pf.blends, len(pf.waypoints)
    if len(b) != W:
        return out + [doc.issue(("blends",), f"{len(b)} blend(s) for {W} waypoints: one each")]
    for k, value in enumerate(b):
        if not 0 <= value <= MAX_BLEND:
            out.append(
                doc.issue(("blends", k), f"{value} is outside [0, {MAX_BLEND}] (a fraction)")
            )
        elif k in (0, W - 1) and value != 0:
            out.append(doc.issue(("blends", k), "the path's ends are at rest: blend 0"))
    return out


def read_path_file(path_file: str) -> tuple[PathFile, Marked]:
    """The path file's form alone (no device): (PathFile, its document)."""
    doc = read_yaml(path_file)
    return validate_document(doc, PathFile), doc


def write_path_with_knots(path_file: str, knots, output: str, note: str = "") -> None:
    """Write ``path_file`` again with new ``knots`` (same waypoints, units and boundary),
    atomically.
    """
    pf = validate_document(read_yaml(path_file), PathFile)
    if pf.boundary == "blended":
        raise UserError(
            f"{path_file}: a blended path's knots follow its joint-space lengths; it is not "
            "written with other knots"
        )
    lines = [
        f"# {comment_text(path_file)} with new knots{': ' + comment_text(note) if note else ''}"
    ]
    if pf.device:
        lines.append(f"device: {yaml_value(pf.device)}")
    units = {k: v for k, v in (("length", pf.units.length), ("angle", pf.units.angle)) if v}
    lines.append("units: {" + ", ".join(f"{k}: {v}" for k, v in units.items()) + "}")
    lines.append("waypoints:")
    lines += ["  - [" + ", ".join(repr(float(v)) for v in row) + "]" for row in pf.waypoints]
    lines.append("knots: [" + ", ".join(f"{float(k):.9g}" for k in knots) + "]")
    lines.append(f"boundary: {pf.boundary}")
    atomic_write_text(output, "\n".join(lines) + "\n")


def write_planned_path(output: str, device, waypoints, blends, note: str) -> None:
    """A planned joint path as a path file, atomically: ``waypoints`` (W, n) in SI written in
    rad and m (read back bit for bit), ``boundary: blended`` with ``blends`` (W,) (the
    straight joint-space lines between the waypoints, their corners blended: what was
    checked; the knots follow the joint-space lengths)."""
    waypoints = np.asarray(waypoints, dtype=float)
    kinds = {j.kind for j in device.joints}
    units = ([("angle", "rad")] if "revolute" in kinds else []) + (
        [("length", "m")] if "prismatic" in kinds else []
    )
    lines = [
        f"# {comment_text(note)}",
        f"device: {yaml_value(device.name)}",
        "units: {" + ", ".join(f"{k}: {v}" for k, v in units) + "}",
        "waypoints:",
    ]
    lines += ["  - [" + ", ".join(repr(float(v)) for v in row) + "]" for row in waypoints]
    lines.append("boundary: blended")
    lines.append("blends: [" + ", ".join(repr(float(b)) for b in blends) + "]")
    atomic_write_text(output, "\n".join(lines) + "\n")
