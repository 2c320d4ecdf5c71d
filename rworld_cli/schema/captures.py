"""Camera capture files: the views of a calibration board with the robot's pose at each, for
``rworld calibrate-camera``; the corners detected in them (CSV); the calibrated camera and its
pose file, written (``docs/vision.md``).

YAML::

    units: {length: mm, angle: deg}
    setup: eye-in-hand            # or eye-to-hand
    camera:
      name: wrist_camera          # the camera's frame in the pose file written
      mount: tool0                # its parent there: the flange (eye-in-hand) or the base
      resolution: [1920, 1200]    # px
      intrinsics: {fx: 1050, fy: 1050, cx: 960, cy: 600}   # optional start values, px
      distortion: [0, 0, 0, 0, 0] # optional: k1 k2 p1 p2 k3
    board:
      name: board                 # the board's frame in the pose file written
      holder: base_link           # its parent: the base (eye-in-hand) or the flange
      pattern: chessboard         # or charuco (with marker and dictionary)
      columns: 24                 # inner corners along x (charuco: squares)
      rows: 17
      square: 15
    views:
      - image: images/im_01.png   # relative to this file
        flange: {xyz: [-567.4, 1129.8, 606.3], rpy: [7.7, 24.1, 156.9]}   # T_base_flange
        joints: [10.2, -35.0, 80.1, 0.0, 45.0, 12.0]   # optional, with 'robot'
    robot: {cell: ../cell, device: kr16}   # optional: the robot of the views' joint values
    corners: corners.csv          # optional: the corners already detected, per view

The corners CSV (``rworld calibrate-camera --save-corners``): ``view,corner,u,v`` with the
view's name (its image's name without the folder), the corner's index in the board's order,
and the pixel position; views whose board was not found have no rows.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from annotated_types import Len
from pydantic import Field

from .. import spatial
from ..errors import Issue, UserError
from ..model.cell import CellModel, DeviceModel
from ..model.vision import BoardModel, CameraModel
from ..units import ANGLE, LENGTH
from .cellparts import pose_to_matrix, validate_document
from .csvtext import read_csv_table
from .models import BoardPattern, FrameRef, Name, PinholeIntrinsics, Pose, Strict, Units
from .yamlio import read_yaml, yaml_value

#: the ArUco dictionaries a ChArUco board may name (OpenCV's predefined ones)
ARUCO_DICTIONARIES = tuple(
    f"DICT_{n}X{n}_{k}" for n in (4, 5, 6, 7) for k in (50, 100, 250, 1000)
) + ("DICT_ARUCO_ORIGINAL",)
#: the tag families an AprilTag grid may name (OpenCV's), with how many tags each holds
APRILTAG_FAMILIES = {
    "DICT_APRILTAG_16h5": 30,
    "DICT_APRILTAG_25h9": 35,
    "DICT_APRILTAG_36h10": 2320,
    "DICT_APRILTAG_36h11": 587,
}


class CameraSpec(Strict):
    name: Name = Field(description="The camera's frame, as the pose file written names it.")
    mount: FrameRef = Field(
        description="The frame the camera is fixed to: the flange (eye-in-hand) or the robot's "
        "base (eye-to-hand); the camera's parent in the pose file written."
    )
    resolution: Annotated[list[Annotated[int, Field(gt=0)]], Len(2, 2)] = Field(
        description="Image width and height [px]."
    )
    intrinsics: PinholeIntrinsics | None = Field(
        None, description="Start values; default OpenCV's calibrateCamera on the views."
    )
    distortion: Annotated[list[float], Len(5, 5)] | None = Field(
        None, description="OpenCV's k1 k2 p1 p2 k3 (start values with 'intrinsics')."
    )


class BoardSpec(BoardPattern):
    name: Name = Field(description="The board's frame, as the pose file written names it.")
    holder: FrameRef = Field(
        description="The frame the board is fixed to: the robot's base (eye-in-hand) or the "
        "flange (eye-to-hand); its parent in the pose file written."
    )


class View(Strict):
    image: Annotated[str, Len(1)] = Field(description="The image file, relative to this file.")
    flange: Pose = Field(description="The robot's flange in its base at this view (T_base_flange).")
    joints: Annotated[list[float], Len(1)] | None = Field(
        None,
        description="The robot's joint values at this view (angle unit; length unit for "
        "prismatic joints), with 'robot': its kinematics' own errors can then be calibrated.",
    )


class RobotRef(Strict):
    cell: Annotated[str, Len(1)] = Field(description="The cell, relative to this file.")
    device: Name = Field(description="The robot of the views' joint values.")


class CaptureFile(Strict):
    """Views of a calibration board with the robot's pose at each."""

    units: Units
    setup: Literal["eye-in-hand", "eye-to-hand"]
    camera: CameraSpec
    board: BoardSpec
    views: Annotated[list[View], Len(1)]
    robot: RobotRef | None = Field(
        None,
        description="The robot whose joint values the views give (every view then has 'joints').",
    )
    corners: str | None = Field(
        None,
        description="A CSV of corners already detected (view, corner, u, v), instead of "
        "detecting them in the images.",
    )


def board_model(name: str, b: BoardPattern, L: float):
    """The board of a pattern (SI), and its problems as ``(path within the pattern,
    message)``: a ChArUco board without its marker or dictionary, a marker not smaller than
    the square, an unknown dictionary, marker keys on a chessboard."""
    from ..errors import did_you_mean

    problems: list[tuple[tuple, str]] = []
    dictionary = b.dictionary
    for key in ("columns", "rows"):
        if b.pattern != "aprilgrid" and getattr(b, key) < 3:
            problems.append(((key,), f"a {b.pattern} board has 3 or more {key}"))
    if b.pattern != "aprilgrid" and b.spacing is not None:
        problems.append((("spacing",), "'spacing' is for AprilTag grids"))
    if b.pattern == "aprilgrid":
        dictionary = dictionary or "DICT_APRILTAG_36h11"
        if b.spacing is None:
            problems.append((("pattern",), "an AprilTag grid needs 'spacing' (between tags)"))
        if b.marker is not None:
            problems.append((("marker",), "'marker' is for ChArUco boards: a tag is 'square'"))
        if dictionary not in APRILTAG_FAMILIES:
            problems.append(
                (
                    ("dictionary",),
                    f"unknown AprilTag family {dictionary!r}"
                    + did_you_mean(dictionary, list(APRILTAG_FAMILIES)),
                )
            )
        elif b.columns * b.rows > APRILTAG_FAMILIES[dictionary]:
            problems.append(
                (
                    (),
                    f"{b.columns} x {b.rows} tags: {dictionary} holds "
                    f"{APRILTAG_FAMILIES[dictionary]}",
                )
            )
    elif b.pattern == "charuco":
        if b.marker is None or b.dictionary is None:
            problems.append((("pattern",), "a ChArUco board needs 'marker' and 'dictionary'"))
        elif b.marker >= b.square:
            problems.append(
                (
                    ("marker",),
                    f"the marker ({b.marker}) must be smaller than the square ({b.square})",
                )
            )
        if b.dictionary is not None and b.dictionary not in ARUCO_DICTIONARIES:
            problems.append(
                (
                    ("dictionary",),
                    f"unknown ArUco dictionary {b.dictionary!r}"
                    + did_you_mean(b.dictionary, ARUCO_DICTIONARIES),
                )
            )
    elif b.marker is not None or b.dictionary is not None:
        problems.append(((), "'marker' and 'dictionary' are for ChArUco boards"))
    board = BoardModel(
        name,
        b.pattern,
        b.columns,
        b.rows,
        b.square * L,
        None if b.marker is None else b.marker * L,
        dictionary,
        None if b.spacing is None else b.spacing * L,
    )
    return board, problems


class Captures:
    """A capture file read: SI data, each view's image path and source line."""

    def __init__(
        self,
        path,
        setup,
        camera,
        board,
        mount,
        holder,
        names,
        images,
        lines,
        flange,
        corners_file,
        digest,
    ):
        self.path = path
        self.setup: str = setup
        self.camera: CameraModel = camera
        self.board: BoardModel = board
        self.mount: str = mount
        self.holder: str = holder
        self.names: tuple[str, ...] = names
        self.images: list[Path] = images
        self.lines: list[tuple[int, int]] = lines  # each view's image: line, column
        self.T_base_flange: np.ndarray = flange
        self.corners_file: Path | None = corners_file
        self.digest: dict = digest
        self.camera_given: bool = camera.fx > 0
        # the robot of the views' joint values: its cell and name, each view's values as the
        # file gives them with their line and column, the file's length and angle units
        # (None: not given); ``joints`` (K, n) SI and ``robot_model`` (the cell loaded) once
        # the cell has converted them
        self.robot_cell: Path | None = None
        self.device: str | None = None
        self.joint_values: list[tuple[list[float], int, int]] = []
        self.units: tuple[float, float] = (1.0, 1.0)
        self.robot_line: tuple[int, int] = (0, 0)
        self.joints: np.ndarray | None = None
        self.robot_model: CellModel | None = None


def read_captures(path: str) -> Captures:
    """Read a capture file (SI), every problem located.

    Raises
    ------
    UserError
        Syntax, types, units, a board a detector cannot use, a view's pose, two views of one
        name: located.
    """
    p = Path(path)
    if not p.is_file():
        raise UserError(f"no such capture file: {path}")
    digest = {"path": str(path), "sha256": hashlib.sha256(p.read_bytes()).hexdigest()}
    doc = read_yaml(p, str(path))
    f = validate_document(doc, CaptureFile)
    L, A = LENGTH[f.units.length], ANGLE[f.units.angle]
    issues: list[Issue] = []
    b = f.board
    board, problems = board_model(b.name, b, L)
    issues += [doc.issue(("board",) + where, message) for where, message in problems]
    c = f.camera
    width, height = c.resolution
    if c.distortion is not None and c.intrinsics is None:
        issues.append(doc.issue(("camera", "distortion"), "give 'intrinsics' with 'distortion'"))
    if c.intrinsics is not None:
        k = c.intrinsics
        camera = CameraModel(
            c.name,
            width,
            height,
            k.fx,
            k.fy,
            k.cx,
            k.cy,
            np.array(c.distortion or [0.0] * 5, dtype=float),
        )
    else:
        camera = CameraModel(c.name, width, height, 0.0, 0.0, 0.0, 0.0)
    names, images, lines, flanges = [], [], [], []
    joint_values: list[tuple[list[float], int, int]] = []
    seen: dict[str, int] = {}
    for k, v in enumerate(f.views):
        where = ("views", k)
        name = Path(v.image).name
        line, column = doc.position(where + ("image",))
        if name in seen:
            issues.append(
                doc.issue(
                    where + ("image",),
                    f"a second view of image {name!r} (the first at line {seen[name]})",
                )
            )
            continue
        seen[name] = line
        T, error, _ = pose_to_matrix(v.flange, L, A)
        if error is None and not np.all(np.isfinite(T)):
            error = "a value is not a finite number"
        if error:
            issues.append(doc.issue(where + ("flange",), error))
            continue
        if f.robot is not None:
            if v.joints is None:
                issues.append(doc.issue(where, "a view without 'joints' where 'robot' is given"))
                continue
            joint_values.append((v.joints, *doc.position(where + ("joints",))))
        elif v.joints is not None:
            issues.append(doc.issue(where + ("joints",), "joint values need 'robot' (its cell)"))
            continue
        names.append(name)
        images.append(p.parent / v.image)
        lines.append((line, column))
        flanges.append(T)
    if issues:
        raise UserError(f"{path}: invalid", issues)
    corners_file = None if f.corners is None else p.parent / f.corners
    captures = Captures(
        str(path),
        f.setup,
        camera,
        board,
        c.mount,
        f.board.holder,
        tuple(names),
        images,
        lines,
        np.array(flanges),
        corners_file,
        digest,
    )
    if f.robot is not None:
        captures.robot_cell = p.parent / f.robot.cell
        captures.device = f.robot.device
        captures.joint_values = joint_values
        captures.units = (L, A)
        captures.robot_line = doc.position(("robot",))
    return captures


def read_corners(path: Path, captures: Captures) -> dict[str, np.ndarray]:
    """The corners CSV: view name -> (N, 2) [px], NaN for corners not listed; rows of views the
    capture file does not list are passed over (a capture file may take some of a set's views).

    Raises
    ------
    UserError
        A corner index outside the board, a corner listed twice, a value not a finite number:
        at its line and column.
    """
    if not path.is_file():
        raise UserError(f"no such corners file: {path}")
    table = read_csv_table(str(path), "view,corner,u,v")
    want = ["view", "corner", "u", "v"]
    if [h.lower() for h in table.header] != want:
        raise UserError(
            f"{path}: invalid",
            [
                Issue(
                    str(path),
                    table.header_line,
                    1,
                    "header",
                    f"expected the columns {','.join(want)}, got {','.join(table.header)}",
                )
            ],
        )
    count = len(captures.board.points)
    out: dict[str, np.ndarray] = {}
    issues: list[Issue] = []
    for line, fields, columns in table.rows:
        if len(fields) != 4:
            issues.append(Issue(str(path), line, 1, "row", f"expected 4 fields, got {len(fields)}"))
            continue
        view, corner_text, u_text, v_text = fields
        if view not in captures.names:
            continue  # a view the capture file leaves out (its own views are all reported)
        try:
            corner = int(corner_text)
        except ValueError:
            corner = -1
        if not 0 <= corner < count:
            issues.append(
                Issue(
                    str(path),
                    line,
                    columns[1],
                    "corner",
                    f"{corner_text!r} is not a corner index 0..{count - 1}",
                )
            )
            continue
        try:
            u, v = float(u_text), float(v_text)
        except ValueError:
            u = v = math.nan
        if not (math.isfinite(u) and math.isfinite(v)):
            issues.append(
                Issue(
                    str(path),
                    line,
                    columns[2],
                    "u, v",
                    "the pixel position is not two finite numbers",
                )
            )
            continue
        arr = out.setdefault(view, np.full((count, 2), np.nan))
        if np.isfinite(arr[corner, 0]):
            issues.append(
                Issue(str(path), line, 1, "corner", f"view {view!r} lists corner {corner} twice")
            )
            continue
        arr[corner] = (u, v)
    if issues:
        raise UserError(f"{path}: invalid", issues[:50])
    return out


def corners_text(names, corners: np.ndarray) -> str:
    """The corners CSV of views ``names`` with corners ``(V, N, 2)`` (NaN: not seen)."""
    rows = [
        "# corners detected by rworld calibrate-camera (OpenCV); pixels, top-left pixel's "
        "centre at 0, 0",
        "view,corner,u,v",
    ]
    for name, c in zip(names, corners, strict=True):
        for k in np.nonzero(np.isfinite(c[:, 0]))[0]:
            rows.append(f"{_csv_field(name)},{k},{c[k, 0]:.4f},{c[k, 1]:.4f}")
    return "\n".join(rows) + "\n"


def _csv_field(text: str) -> str:
    if any(ch in text for ch in ',;"\t\n\r') or text != text.strip():
        return '"' + text.replace('"', '""') + '"'
    return text


def _pose_line(name: str, T: np.ndarray) -> str:
    xyz = ", ".join(repr(float(x) * 1000) for x in T[:3, 3])
    rpy = ", ".join(repr(float(x)) for x in np.degrees(spatial.matrix_to_rpy(T[:3, :3])))
    return f"  {yaml_value(name)}: {{xyz: [{xyz}], rpy: [{rpy}]}}"


def _camera_fields(cam: CameraModel) -> tuple[str, str, str]:
    """A camera's resolution, intrinsics and distortion as YAML flow values (px; every digit)."""
    return (
        f"[{cam.width}, {cam.height}]",
        f"{{fx: {float(cam.fx)!r}, fy: {float(cam.fy)!r}, cx: {float(cam.cx)!r}, "
        f"cy: {float(cam.cy)!r}}}",
        "[" + ", ".join(repr(float(x)) for x in cam.distortion) + "]",
    )


def _camera_lines(cam: CameraModel, indent: str) -> list[str]:
    resolution, intrinsics, distortion = _camera_fields(cam)
    return [
        f"{indent}resolution: {resolution}",
        f"{indent}intrinsics: {intrinsics}",
        f"{indent}distortion: {distortion}",
    ]


def _camera_entry(cam: CameraModel) -> str:
    resolution, intrinsics, distortion = _camera_fields(cam)
    return f"{{resolution: {resolution}, intrinsics: {intrinsics}, distortion: {distortion}}}"


def pose_file_text(captures: Captures, result, date: str) -> str:
    """The calibrated camera and board poses as a pose file (mm, deg) with provenance: the
    camera's frame in its mount, the board's in its holder, and the camera's intrinsics
    (``cameras:``, for a cell's camera sensor of the camera's name)."""
    sigma = result.sigma
    lines = [
        "# The camera's and the board's poses written by 'rworld calibrate-camera'.  List this",
        "# file after the nominal pose file(s) in the cell's pose_files.",
        "units: {length: mm, angle: deg}",
        "poses:",
        _pose_line(captures.camera.name, result.T_mount_camera),
        _pose_line(captures.board.name, result.T_holder_board),
        "cameras:",
        f"  {yaml_value(captures.camera.name)}: {_camera_entry(result.camera)}",
        "provenance:",
        f"  date: {yaml_value(date)}",
        f"  captures: {{path: {yaml_value(captures.digest['path'])}, "
        f"sha256: {captures.digest['sha256']}}}",
        f"  setup: {captures.setup}",
        f"  parents: {{{yaml_value(captures.camera.name)}: {yaml_value(captures.mount)}, "
        f"{yaml_value(captures.board.name)}: {yaml_value(captures.holder)}}}",
        f"  views: {len(result.names)}",
        f"  reprojection_rms_px: {result.rms:.6g}",
        f"  sigma_camera_mm: [{', '.join(f'{s * 1000:.4g}' for s in sigma[12:15])}]",
        f"  sigma_camera_deg: [{', '.join(f'{np.degrees(s):.4g}' for s in sigma[9:12])}]",
        f"  sigma_board_mm: [{', '.join(f'{s * 1000:.4g}' for s in sigma[18:21])}]",
        f"  sigma_board_deg: [{', '.join(f'{np.degrees(s):.4g}' for s in sigma[15:18])}]",
    ]
    return "\n".join(lines) + "\n"


def camera_file_text(result, captures: Captures, date: str) -> str:
    """The calibrated intrinsics (px) with their sigmas: the camera's numeric file."""
    cam = result.camera
    s = result.sigma
    sd = ", ".join(f"{x:.3g}" for x in s[4:9])
    lines = [
        "# The camera's intrinsics written by 'rworld calibrate-camera' (OpenCV's model:",
        "# pixels, the top-left pixel's centre at 0, 0; distortion k1 k2 p1 p2 k3).",
        "camera:",
        f"  name: {yaml_value(cam.name)}",
        *_camera_lines(cam, "  "),
        "  sigma:",
        f"    intrinsics: {{fx: {s[0]:.3g}, fy: {s[1]:.3g}, cx: {s[2]:.3g}, cy: {s[3]:.3g}}}",
        f"    distortion: [{sd}]",
        "provenance:",
        f"  date: {yaml_value(date)}",
        f"  captures: {{path: {yaml_value(captures.digest['path'])}, "
        f"sha256: {captures.digest['sha256']}}}",
        f"  reprojection_rms_px: {result.rms:.6g}",
    ]
    return "\n".join(lines) + "\n"


def write_image(path, grey: np.ndarray) -> None:
    """A grey image ``(H, W)`` (uint8, or uint16 for depth) as a PNG, atomically."""
    import cv2

    from ..fileio import atomic_write_bytes

    ok, data = cv2.imencode(".png", grey)
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 array
        raise UserError(f"cannot encode the image for {path}")
    atomic_write_bytes(path, data.tobytes())


def capture_template_text(
    camera: CameraModel,
    mount: str,
    holder: str,
    board: BoardModel,
    T_base_flange,
    images: list[str] | None = None,
    setup: str = "eye-in-hand",
    header: list[str] | None = None,
    robot: tuple[str, DeviceModel] | None = None,
    joints: np.ndarray | None = None,
) -> str:
    """A capture file (mm, deg): the camera's nominal intrinsics as the start, the board,
    each view's image (default ``view01.png`` ...: planned views, the images to be taken) and
    flange pose; ``mount`` the camera's parent (the flange, or the base eye-to-hand),
    ``holder`` the board's (the base, or the flange eye-to-hand); ``header``: the comment
    lines on top (default: planned views' instructions); ``robot`` (the cell's path relative
    to the file, the device model) and ``joints`` (K, n) [rad or m]: each view's joint values,
    written in deg and mm."""
    b = board
    pattern = [
        f"  pattern: {b.pattern}",
        f"  columns: {b.columns}",
        f"  rows: {b.rows}",
        f"  square: {b.square * 1000!r}",
    ]
    if b.pattern == "charuco":
        pattern += [f"  marker: {float(b.marker or 0) * 1000!r}", f"  dictionary: {b.dictionary}"]
    if b.pattern == "aprilgrid":
        pattern += [f"  spacing: {float(b.spacing or 0) * 1000!r}", f"  dictionary: {b.dictionary}"]
    if header is None:
        header = [
            "Views planned by 'rworld plan-views': take an image at each (the program it wrote",
            "visits them) and name it as its view, then 'rworld calibrate-camera' this file.",
        ]
    lines = [
        *(f"# {line}" for line in header),
        "units: {length: mm, angle: deg}",
        f"setup: {setup}",
        "camera:",
        f"  name: {yaml_value(camera.name)}",
        f"  mount: {yaml_value(mount)}",
        *_camera_lines(camera, "  "),
        "board:",
        f"  name: {yaml_value(b.name)}",
        f"  holder: {yaml_value(holder)}",
        *pattern,
        "views:",
    ]
    for k, T in enumerate(T_base_flange):
        xyz = ", ".join(repr(float(x) * 1000) for x in T[:3, 3])
        rpy = ", ".join(repr(float(x)) for x in np.degrees(spatial.matrix_to_rpy(T[:3, :3])))
        image = images[k] if images is not None else f"view{k + 1:02d}.png"
        lines.append(f"  - image: {yaml_value(image)}")
        lines.append(f"    flange: {{xyz: [{xyz}], rpy: [{rpy}]}}")
        if robot is not None and joints is not None:
            device = robot[1]
            per_unit = [
                1000.0 if j.kind == "prismatic" else float(np.degrees(1.0)) for j in device.joints
            ]
            values = ", ".join(repr(float(v) * u) for v, u in zip(joints[k], per_unit))
            lines.append(f"    joints: [{values}]")
    if robot is not None and joints is not None:
        device = robot[1]
        lines.append(f"robot: {{cell: {yaml_value(robot[0])}, device: {yaml_value(device.name)}}}")
    return "\n".join(lines) + "\n"


def write_depth_image(path, depth) -> None:
    """A depth map [m] ``(H, W)`` as a 16-bit PNG in millimetres (the depth cameras' common
    form; 0 where nothing is, 65535 at 65.535 m and beyond), atomically."""
    millimetres = np.where(np.isfinite(depth), np.clip(np.rint(depth * 1000.0), 1, 65535), 0)
    write_image(path, millimetres.astype(np.uint16))
