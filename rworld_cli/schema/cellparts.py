"""The loader's shared pieces: numbers' plausibility, documents against their models, pose
files on their own, mesh facts, inertias, and the rules' tables (used by ``loader`` and its
mixins, ``cell_bodies``, ``cell_devices``, ``cell_rules``, ``cell_poses``)."""

from __future__ import annotations

import dataclasses
import functools
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import spatial
from ..errors import Issue, UserError
from ..model import cell as wm
from ..units import LENGTH

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


#: a pose matrix's rotation part further than this from a rotation (``rotation_error``) is
#: refused; nearer, its nearest rotation is used: a matrix printed to 4 decimals is at most
#: about 3e-4 away, a typo far more
MATRIX_ROTATION_REFUSED = 1e-3
#: ... and said (a warning) beyond this: 6 decimals' rounding (about 3e-6) passes quietly
MATRIX_ROTATION_QUIET = 1e-5


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
        if err > MATRIX_ROTATION_REFUSED:
            return (
                np.eye(4),
                "the matrix's rotation part is not a rotation (|R^T R - I| or |det R - 1| = "
                f"{err:.3g})",
                None,
            )
        warning = None
        T = M.copy()
        if err > 1e-12:
            # a matrix printed to a few decimals (a controller's log, a data set's text
            # file): its nearest rotation, the one a least-squares fit of the printed
            # entries gives (SVD); 6 decimals leave |R^T R - I| up to about 3e-6
            U, _, Vt = np.linalg.svd(M[:3, :3])
            T[:3, :3] = U @ Vt
            if err > MATRIX_ROTATION_QUIET:
                warning = (
                    f"the matrix's rotation part is {err:.2g} from a rotation (printed to few "
                    "decimals?); its nearest rotation used"
                )
        T[:3, 3] *= length
        return T, None, warning
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
