"""Path files (``paths/*.yaml``): read with located errors against a device, written with new
knots.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import Issue, UserError
from ..fileio import atomic_write_text
from ..model.paths import MAX_BLEND, PathSpec
from ..units import ANGLE, LENGTH
from .loader import validate_document
from .program import PathFile
from .yamlio import Marked, comment_text, read_yaml, yaml_value

MAX_WAYPOINTS = 20_000  # a planned path has tens; a taught spline a few thousand
MAX_PATH_FILE_BYTES = 4_000_000  # 20 000 waypoints of 7 full-precision values: 2.8 MB
MIN_KNOT_STEP = 1e-9  # knots closer than this make the spline's speeds overflow


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
    doc, pf = read_path_file(path_file)
    n = device.dof
    issues = []
    if len(pf.waypoints) > MAX_WAYPOINTS:
        issues.append(
            doc.issue(
                ("waypoints",),
                f"{len(pf.waypoints)} waypoints; a path file holds at most {MAX_WAYPOINTS:,}",
            )
        )
    if pf.device is not None and pf.device != device.name:
        issues.append(
            doc.issue(
                ("device",),
                f"the path is for '{pf.device}', not for "
                f"'{device.name}': its joint values are another robot's (name '{device.name}' "
                "there if they are meant for it)",
            )
        )
    for k, row in enumerate(pf.waypoints):
        if len(row) != n:
            issues.append(
                doc.issue(
                    ("waypoints", k), f"{len(row)} value(s) but '{device.name}' has {n} joint(s)"
                )
            )
    if pf.knots is not None:
        kn = pf.knots
        # written so that NaN fails: each step must be a number of at least MIN_KNOT_STEP
        if (
            len(kn) != len(pf.waypoints)
            or kn[0] != 0
            or kn[-1] != 1
            or not all(b - a >= MIN_KNOT_STEP for a, b in zip(kn, kn[1:]))
        ):
            issues.append(
                doc.issue(
                    ("knots",),
                    f"knots must rise strictly from 0 to 1 (each step at least {MIN_KNOT_STEP:g}), "
                    f"one per waypoint ({len(pf.waypoints)})",
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
    bad = np.argwhere(~((q >= lo) & (q <= hi)))  # NaN is outside too
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


def read_path_file(path_file: str) -> tuple[Marked, PathFile]:
    """The path file's form alone (no device): (its document, PathFile); a file over
    MAX_PATH_FILE_BYTES is refused before it is parsed."""
    try:
        size = Path(path_file).stat().st_size
    except OSError:
        size = 0  # read_yaml names what is wrong
    if size > MAX_PATH_FILE_BYTES:
        raise UserError(
            f"{path_file}: {size:,} bytes; a path file holds at most "
            f"{MAX_PATH_FILE_BYTES:,} ({MAX_WAYPOINTS:,} waypoints)"
        )
    doc = read_yaml(path_file)
    return doc, validate_document(doc, PathFile)


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
