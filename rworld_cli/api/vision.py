"""rworld calibrate-camera: a camera's intrinsics, its pose on the flange (or over the cell) and
the board's, from a capture file's images and robot poses (``docs/vision.md``)."""

from __future__ import annotations

import dataclasses
import datetime as _dt
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import Issue, UserError
from ..jsonvalues import finite
from ..vision.calibrate import (
    ROBOT_ERRORS_DOMINATE,
    BoardViews,
    CalibrationRefused,
    CameraCalibration,
    axxb_residuals,
    calibrate_views,
    calibrate_views_with_robot,
    orient_to_robot,
    pictures_rms,
    reprojection_rms,
    view_poses,
)
from ..vision.detect import Detection

#: the largest image file read [bytes]: a camera's frame is a few to a few tens of MB
MAX_IMAGE_BYTES = 512 * 2**20
#: fewest corners a view needs to count (its own pose has six unknowns)
MIN_CORNERS = 6
#: the most pixels an image may say it has (OpenCV's own bound, lowered from 2^30): 16384 x
#: 16384, more than any industrial camera's
MAX_IMAGE_PIXELS = 2**28


@dataclass
class CameraCalibrationRun:
    """What ``rworld calibrate-camera`` did.

    Attributes
    ----------
    detections : list of Detection
        Every view's corners or the reason it was not used, in the file's order.
    fitted, held_out : tuple of str
        The views fitted and those only predicted.
    held_out_rms : float or None
        The held-out views' corners predicted through the robot [px].
    axxb : tuple of float or None
        RMS rotation [rad] and translation [m] of AX = XB over the held-out views' pairs (the
        fitted views' when fewer than two are held out).
    written : list of str
        The files written.
    """

    captures: str
    setup: str
    camera_frame: str
    mount: str
    board_frame: str
    holder: str
    result: CameraCalibration
    detections: list[Detection]
    fitted: tuple[str, ...]
    held_out: tuple[str, ...]
    held_out_rms: float | None
    axxb: tuple[float, float] | None
    axxb_views: str
    seconds: dict[str, float] = field(default_factory=dict)
    written: list[str] = field(default_factory=list)
    held_out_view_rms: dict[str, float] = field(default_factory=dict)
    #: the capture file names the robot's cell and each view's joints (``robot:``): the fits
    #: through the robot (``--through-robot``, ``--with-robot``) can be asked
    robot_named: bool = False
    #: views whose corners were renumbered to agree with the robot's motion (a chessboard
    #: numbered from another corner): {name: the turn [deg]}
    turned: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict:
        r = self.result
        cam = r.camera
        s = r.sigma
        names = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
        return finite(
            {
                "captures": self.captures,
                "setup": self.setup,
                "camera": {
                    "name": cam.name,
                    "resolution": [cam.width, cam.height],
                    "intrinsics": dict(zip(names, cam.intrinsics.tolist(), strict=True)),
                    "sigma": dict(zip(names, s[:9].tolist(), strict=True)),
                },
                "camera_pose": _pose_dict(self.mount, r.T_mount_camera, s[9:15]),
                "board_pose": _pose_dict(self.holder, r.T_holder_board, s[15:21]),
                "reprojection_rms_px": r.rms,
                "pictures_rms_px": self.pictures_rms,
                "robot_errors_dominate": self.robot_errors_dominate,
                "turned_views": self.turned,
                "model_chosen": self.exact_robot_ratio is not None,
                "exact_robot_ratio": self.exact_robot_ratio,
                "robot_named": self.robot_named,
                "model": "robot errors"
                if r.robot is not None
                else "flange errors"
                if r.flange_sigma is not None
                else "exact robot",
                "robot": None if r.robot is None else _robot_dict(r.robot),
                "flange_sigma_deg": None
                if r.flange_sigma is None
                else float(np.degrees(r.flange_sigma[0])),
                "flange_sigma_mm": None if r.flange_sigma is None else r.flange_sigma[1] * 1000,
                "flange_error_correlation": None
                if r.flange_field is None
                else {
                    "neighbour": r.flange_field.neighbour_correlation,
                    "share": r.flange_field.share,
                    "length_m": r.flange_field.length,
                    "lever_m_per_rad": r.flange_field.lever,
                },
                "sigma0_px": r.sigma0,
                "observations": r.observations,
                "downweighted": r.downweighted,
                "held_out": list(self.held_out),
                "held_out_rms_px": self.held_out_rms,
                "axxb_rms_deg": None if self.axxb is None else float(np.degrees(self.axxb[0])),
                "axxb_rms_mm": None if self.axxb is None else self.axxb[1] * 1000,
                "axxb_views": self.axxb_views,
                "views": [
                    {
                        "name": d.name,
                        "corners": d.seen,
                        "refused": d.refused,
                        "detail": d.detail,
                        "sharpness_px": d.sharpness,
                        "fitted": d.name in self.fitted,
                        "rms_px": self.view_rms(d.name),
                    }
                    for d in self.detections
                ],
                "seconds": self.seconds,
                "written": self.written,
            }
        )

    @property
    def pictures_rms(self) -> float | None:
        """The fitted views' corners against each view's own pose of the board (OpenCV's
        ``calibrateCamera``: no robot pose in it), rms a corner [px]; the corners' own noise,
        to set against the fit through the robot's poses."""
        return pictures_rms(self.result)

    @property
    def exact_robot_ratio(self) -> float | None:
        """Where the data chose the model of the robot's poses (none asked): the exact-robot
        fit's corners this many times as far off as each view's own picture's."""
        r = self.result
        return r.exact_ratio if r.model_chosen else None

    @property
    def robot_errors_dominate(self) -> bool:
        """The robot's poses taken as exact, and the corners through them over 3x as far off
        as in each view's own picture: the robot's pose errors, not the pictures, set the
        fit (``--flange-errors`` models them)."""
        r = self.result
        exact = r.flange_sigma is None and r.robot is None
        return exact and r.exact_ratio is not None and r.exact_ratio > ROBOT_ERRORS_DOMINATE

    def view_rms(self, name: str) -> float | None:
        if name in self.result.names:
            return float(self.result.view_rms[self.result.names.index(name)])
        return self.held_out_view_rms.get(name)


def _robot_dict(robot) -> dict:
    """The robot's corrections of a ``--with-robot`` calibration: each identified joint-frame
    parameter (mm or deg) with its sigma, the ones kept nominal, the pictures' noise."""
    rows = []
    for k in robot.identified:
        name = robot.model.names[k]
        angle = name.rsplit(".", 1)[1].startswith("r")
        unit = float(np.degrees(1.0)) if angle else 1000.0
        rows.append(
            {
                "name": name,
                "correction": float(robot.p[k] * unit),
                "sigma": float(robot.sigma[k] * unit),
                "unit": "deg" if angle else "mm",
            }
        )
    return {
        "identified": int(robot.rank),
        "parameters": 6 * robot.device.dof,
        "corrections": rows,
        "kept_nominal": [u.parameters[0][0] for u in robot.unidentifiable],
        "pixel_noise_px": float(robot.sigma_instrument),
        "variance_factor": float(robot.variance_factor),
        "observability_index": float(robot.observability),
        "iterations": int(robot.iterations),
        "converged": bool(robot.converged),
    }


def _pose_dict(parent: str, T: np.ndarray, sigma: np.ndarray) -> dict:
    from .. import spatial

    return {
        "parent": parent,
        "xyz_mm": (T[:3, 3] * 1000).tolist(),
        "rpy_deg": np.degrees(spatial.matrix_to_rpy(T[:3, :3])).tolist(),
        "sigma_mm": (sigma[3:] * 1000).tolist(),
        "sigma_deg": np.degrees(sigma[:3]).tolist(),
    }


def read_grey(path: Path, where: Issue) -> np.ndarray:
    """An image file as grey uint8 ``(H, W)``; a file that is missing, too large, claiming
    more than :data:`MAX_IMAGE_PIXELS` or not an image OpenCV decodes: a located user error."""
    import os

    os.environ.setdefault("OPENCV_IO_MAX_IMAGE_PIXELS", str(MAX_IMAGE_PIXELS))
    import cv2

    def refuse(message: str) -> UserError:
        return UserError(
            message,
            [Issue(where.file, where.line, where.column, where.location, message)],
        )

    try:
        size = path.stat().st_size
    except OSError:
        raise refuse(f"no such image: {path}") from None
    if size > MAX_IMAGE_BYTES:
        raise refuse(
            f"{path}: {size / 2**20:.0f} MB, more than an image's {MAX_IMAGE_BYTES // 2**20} MB"
        )
    data = np.frombuffer(path.read_bytes(), dtype=np.uint8)
    try:
        image = cv2.imdecode(data, cv2.IMREAD_GRAYSCALE) if len(data) else None
    except cv2.error:  # OpenCV's checks (a size beyond its bound) raise
        image = None
    if image is None:
        raise refuse(f"{path}: not an image OpenCV reads (PNG, JPEG, BMP, TIFF ...)")
    return image


def detect_views(captures, progress=None) -> list[Detection]:
    """Each view's corners: from the capture file's corners CSV, else found in its image (two
    images at a time); an image of another size than the camera's is refused, located."""
    from ..schema.captures import read_corners
    from ..vision.detect import detect

    board = captures.board
    if captures.corners_file is not None:
        given = read_corners(captures.corners_file, captures)
        listed: list[Detection] = []
        for n in captures.names:
            corners = given.get(n, np.full((len(board.points), 2), np.nan))
            seen = int(np.isfinite(corners[:, 0]).sum())
            if seen == 0:
                listed.append(
                    Detection(
                        n, corners, "board not found", f"no corners in {captures.corners_file.name}"
                    )
                )
            elif seen < MIN_CORNERS:
                listed.append(
                    Detection(
                        n,
                        np.full_like(corners, np.nan),
                        "partly seen",
                        f"{seen} corners in {captures.corners_file.name}, {MIN_CORNERS} needed",
                    )
                )
            else:
                listed.append(Detection(n, corners))
        return listed
    from concurrent.futures import ThreadPoolExecutor

    width, height = captures.camera.width, captures.camera.height

    def one(k: int) -> Detection:
        line, column = captures.lines[k]
        where = Issue(captures.path, line, column, f"views[{k}].image", "")
        grey = read_grey(captures.images[k], where)
        if grey.shape != (height, width):
            message = (
                f"{captures.images[k]}: the image is {grey.shape[1]}x{grey.shape[0]} px, "
                f"the camera's resolution {width}x{height}"
            )
            raise UserError(
                message, [Issue(captures.path, line, column, f"views[{k}].image", message)]
            )
        return detect(captures.names[k], grey, board)

    out: list[Detection] = []
    with ThreadPoolExecutor(max_workers=2) as pool:  # OpenCV lets go of the GIL
        for k, d in enumerate(pool.map(one, range(len(captures.names)))):
            out.append(d)
            if progress is not None:
                progress(k + 1, len(captures.names), f"corners in {d.name}")
    return out


def load_captures(path: str, joints: bool = True):
    """A capture file (``schema/captures.read_captures``) with its views' joint values in SI
    (``captures.joints``, (K, n)) where it names a ``robot:`` and ``joints`` is asked:
    converted with its cell's device (the file's units, the joints' kinds), every problem at
    its line (a calibration that does not use them does not read the robot's cell).

    Raises
    ------
    UserError
        The capture file's problems; a robot cell that does not load, an unknown device,
        joint values of the wrong count, units or beyond the limits (at their line)."""
    from ..errors import did_you_mean
    from ..schema.captures import read_captures
    from ..schema.cellparts import joint_values
    from ..schema.loader import load_cell

    captures = read_captures(path)
    if captures.robot_cell is None or not joints:
        return captures
    line, column = captures.robot_line
    try:
        cell = load_cell(captures.robot_cell).cell
    except UserError as exc:
        issue = Issue(captures.path, line, column, "robot.cell", f"its cell: {exc.message}")
        raise UserError(f"{captures.path}: invalid", [issue, *exc.issues]) from None
    device = cell.devices.get(captures.device or "")
    if device is None:
        message = (
            f"no device '{captures.device}' in {captures.robot_cell}"
            f"{did_you_mean(captures.device or '', cell.devices)}"
        )
        raise UserError(
            f"{captures.path}: invalid", [Issue(captures.path, line, column, "robot", message)]
        )
    L, A = captures.units
    values_si, issues = [], []
    for k, (values, at_line, at_column) in enumerate(captures.joint_values):
        q, why = joint_values(device, values, L, A)
        if why is not None:
            issues.append(Issue(captures.path, at_line, at_column, f"views[{k}].joints", why))
        values_si.append(q)
    if issues:
        raise UserError(f"{captures.path}: invalid", issues)
    captures.joints = np.array(values_si)
    captures.robot_model = cell
    return captures


def capture_views(captures, detections: list[Detection] | None = None) -> BoardViews:
    """A capture file's views with each view's corners (``detections``; default
    :func:`detect_views`), NaN where not seen."""
    detections = detect_views(captures) if detections is None else detections
    return BoardViews(
        captures.board,
        captures.camera,
        captures.setup,
        captures.names,
        captures.T_base_flange,
        np.stack([d.corners for d in detections]),
    )


def calibrate_camera(
    captures_path: str,
    holdout_every: int = 0,
    fix_intrinsics: bool = False,
    flange_errors: bool | None = None,
    write_poses: str | None = None,
    write_camera: str | None = None,
    save_corners: str | None = None,
    progress=None,
    through_robot: bool = False,
    write_robot_observations: str | None = None,
    with_robot: bool = False,
    write_robot: str | None = None,
) -> CameraCalibrationRun:
    """Calibrate a camera from a capture file (``schema/captures.py``).

    Parameters
    ----------
    holdout_every : int
        Hold out every k-th view with the board found (the k-th, 2k-th, ...) from the fit and
        predict it through the robot (0: fit them all).
    fix_intrinsics : bool
        Keep the capture file's intrinsics (which must then be given).
    flange_errors : bool or None
        Give each view's flange pose an error of its own, estimated with its sigma
        (:func:`~rworld_cli.vision.calibrate.calibrate_views`); False: the robot's poses
        exact; None (default): chosen by the data - the model of the errors where the
        exact-robot fit's corners are more than ``ROBOT_ERRORS_DOMINATE`` times as far off as
        each view's own picture's (the robot's pose errors then set the fit;
        ``CameraCalibrationRun.exact_robot_ratio``).
    write_poses, write_camera, save_corners : str or None
        The pose file (camera in its mount, board in its holder), the camera's intrinsics and
        the corners CSV to write - together, atomically, only when the calibration succeeds.
    through_robot : bool
        Each view's flange pose from its joint values through the robot of the capture file's
        ``robot:`` cell (its pose files, a robot calibration included), not the file's
        ``flange:`` poses.
    write_robot_observations : str or None
        A robot observation file for ``rworld calibrate-robot`` (the robot's own kinematic
        errors): at every view with the board found, its joint values and the pose of what the
        robot carries (the camera, or the board eye-to-hand) in the frame of what stays, by
        PnP with the intrinsics of the views' own pictures (OpenCV's ``calibrateCamera``, the
        fit's start: the fit through the robot's poses bends them by the robot's errors;
        :func:`~rworld_cli.vision.calibrate.pose_observations`).
    with_robot : bool
        Estimate the robot's own kinematic errors (its joint frames) with the camera, in one
        bundle adjustment (:func:`~rworld_cli.vision.calibrate.calibrate_views_with_robot`):
        each view's flange pose from its joint values through the capture file's ``robot:``
        cell, corrected by the estimate; held-out views are predicted through the corrected
        robot.
    write_robot : str or None
        With ``with_robot``: the robot's corrections as a pose-file overlay for the robot's
        cell (as ``rworld calibrate-robot`` writes it), with the other outputs, atomically.

    Raises
    ------
    UserError
        Bad input (located), an image of another size than the camera's, too few views with
        the board found, a degenerate motion, views that leave the estimate undetermined.
    """
    from ..fileio import atomic_write_text, output_set
    from ..schema.captures import camera_file_text, corners_text, pose_file_text

    if write_robot and not with_robot:
        raise UserError("--write-robot writes what --with-robot estimates: give both")
    needs_joints = through_robot or with_robot or bool(write_robot_observations)
    captures = load_captures(captures_path, joints=needs_joints)
    if needs_joints and captures.joints is None:
        flag = (
            "--through-robot"
            if through_robot
            else "--with-robot"
            if with_robot
            else "--write-robot-observations"
        )
        raise UserError(
            f"{flag} needs the views' joint values",
            [
                Issue(
                    captures.path,
                    0,
                    0,
                    "robot",
                    f"{flag} needs the views' joint values: give 'robot: {{cell: ..., device: "
                    "...}' and each view's 'joints' ('rworld captures --from-log' writes them)",
                )
            ],
        )
    robot = None
    if with_robot:
        robot = _robot_model(captures)
        captures.T_base_flange = robot.poses(np.zeros(len(robot.names)), captures.joints)
    elif through_robot:
        captures.T_base_flange = _flanges_through_robot(captures)
    if fix_intrinsics and not captures.camera_given:
        raise UserError(
            "--fix-intrinsics needs the camera's intrinsics",
            [
                Issue(
                    captures.path,
                    0,
                    0,
                    "camera",
                    "give 'intrinsics' (and 'distortion') to keep them fixed",
                )
            ],
        )
    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    detections = detect_views(captures, progress)
    seconds["corners"] = time.perf_counter() - t0
    used = [k for k, d in enumerate(detections) if d.refused is None]
    held = [k for i, k in enumerate(used) if holdout_every and (i + 1) % holdout_every == 0]
    fit = [k for k in used if k not in held]
    all_views = capture_views(captures, detections)
    # a chessboard's views numbered from another corner than the others: renumbered where the
    # robot's motion says so (their own poses turned about the board's normal otherwise)
    oriented, turned = orient_to_robot(
        all_views.subset(used), captures.camera if fix_intrinsics else None
    )
    if turned:
        corners = all_views.corners.copy()
        corners[used] = oriented.corners
        all_views = dataclasses.replace(all_views, corners=corners)
    corners = all_views.corners
    t0 = time.perf_counter()
    try:
        if robot is not None:
            result = calibrate_views_with_robot(
                all_views.subset(fit), robot, captures.joints[fit], fix_intrinsics=fix_intrinsics
            )
            # every view's flange where the corrected robot puts it (the held-out ones too)
            assert result.robot is not None
            all_views = dataclasses.replace(
                all_views, T_base_flange=robot.poses(result.robot.p, captures.joints)
            )
        else:
            if progress is not None:
                progress(0, None, "calibrating")
            result = calibrate_views(
                all_views.subset(fit), fix_intrinsics=fix_intrinsics, flange_errors=flange_errors
            )
    except CalibrationRefused as exc:
        refused = [f"{d.name}: {d.refused} ({d.detail})" for d in detections if d.refused]
        message = str(exc)
        if refused:
            message += "; views not used: " + "; ".join(refused[:8])
            if len(refused) > 8:
                message += f"; ... {len(refused) - 8} more"
        raise UserError(
            f"{captures.path}: cannot calibrate", [Issue(captures.path, 0, 0, "views", message)]
        ) from None
    # held-out views where the estimate expects the robot: with the flange errors modelled,
    # each corrected by the error their correlation over the poses predicts there
    held_views = result.robot_views(all_views.subset(held))
    held_rms = None
    held_view_rms: dict[str, float] = {}
    if held:
        held_rms = reprojection_rms(
            result.camera, result.T_mount_camera, result.T_holder_board, held_views
        )
        d = result.predicted_corners(held_views) - held_views.corners
        per = np.sqrt(np.nanmean(np.sum(d * d, axis=-1), axis=1))
        held_view_rms = dict(zip(held_views.names, per.tolist(), strict=True))
    check_views = held_views if len(held) >= 2 else all_views.subset(fit)
    try:
        C = view_poses(check_views, result.camera)
    except CalibrationRefused as exc:  # PnP failed on a view: no AX = XB figure
        logging.getLogger("rworld").warning("AX = XB left out: %s", exc)
        axxb = None
    else:
        axxb = axxb_residuals(result.T_mount_camera, check_views, C)
    seconds["calibration"] = time.perf_counter() - t0
    run = CameraCalibrationRun(
        captures.path,
        captures.setup,
        captures.camera.name,
        captures.mount,
        captures.board.name,
        captures.holder,
        result,
        detections,
        tuple(captures.names[k] for k in fit),
        held_views.names,
        held_rms,
        axxb,
        "held out" if len(held) >= 2 else "fitted",
        seconds,
        held_out_view_rms=held_view_rms,
        robot_named=captures.robot_cell is not None,
        turned=turned,
    )
    date = _dt.datetime.now().replace(microsecond=0).isoformat()
    outputs = [
        (write_poses, lambda: pose_file_text(captures, result, date)),
        (write_camera, lambda: camera_file_text(result, captures, date)),
        (save_corners, lambda: corners_text(captures.names, corners)),
    ]
    if write_robot_observations:  # computed now: a PnP that fails is an error, before writing
        observations = _robot_observations(captures, all_views.subset(used), used, result, date)
        outputs.append((write_robot_observations, lambda: observations))
    if write_robot:
        outputs.append((write_robot, lambda: _robot_overlay(captures, result, len(fit))))
    if any(path for path, _ in outputs):
        with output_set():
            for path, text in outputs:
                if path:
                    atomic_write_text(path, text())
                    run.written.append(str(path))
    return run


def _robot_model(captures):
    """The capture file's robot as the robot calibration models it: the frame on its flange
    (the camera's mount, or the board's holder eye-to-hand) as a 6-DoF target on its link,
    in the robot's base."""
    from ..world.tree import World

    world = World(captures.robot_model)
    flange = captures.mount if captures.setup == "eye-in-hand" else captures.holder
    if flange not in world.cell.frames:
        raise UserError(
            f"{captures.path}: '{flange}' (the frame on the flange) is no frame of "
            f"{captures.robot_cell}"
        )
    return flange_robot(world, captures.device, flange)


def flange_robot(world, device: str, frame: str):
    """``device`` of ``world`` as the robot calibration models it with ``frame`` - the frame on
    its flange: the camera's mount, or the board's holder eye-to-hand - as a 6-DoF target on
    its link, in the robot's base (``calibrate-camera --with-robot``, ``plan-views
    --with-robot``)."""
    from ..calibration.robot import RobotModel

    link, T_link_frame = world.mount_of(device, frame)
    return RobotModel(
        world.cell.devices[device],
        np.eye(4),
        link,
        T_link_frame[:3, 3].copy(),
        False,
        T_link_frame[:3, :3].copy(),
    )


def _robot_overlay(captures, result, views: int) -> str:
    """``calibrate_camera``'s ``write_robot``: the robot's corrections as a pose-file overlay
    for its cell (the flange frame's own pose is the camera's or the board's, not moved)."""
    from ..schema.robotobs import robot_overlay_text

    robot = result.robot
    rms = float(np.sqrt(np.mean(np.sum(robot.residuals**2, axis=1))))
    return robot_overlay_text(
        robot.device,
        captures.device,
        {},
        "rworld calibrate-camera --with-robot",
        [captures.digest],  # the file as it was read
        {
            "views": views,
            "identified": f"{robot.rank} of {6 * robot.device.dof} joint parameters",
            "observability_index": float(robot.observability),
            "residual_rms_px": rms,
        },
    )


def _flanges_through_robot(captures) -> np.ndarray:
    """Each view's flange pose (V, 4, 4) [m]: the frame the capture file puts on the flange
    (the camera's mount, or the board's holder eye-to-hand) in the robot's base at the view's
    joint values, through the capture file's ``robot:`` cell."""
    robot = _robot_model(captures)
    return robot.poses(np.zeros(len(robot.names)), captures.joints)


def _robot_observations(captures, views, used: list[int], result, date: str) -> str:
    """The robot observation file of :func:`calibrate_camera`'s ``write_robot_observations``."""
    from ..schema.robotobs import observation_file_text
    from ..vision.calibrate import pose_observations

    # the intrinsics of the views' own pictures of the board (OpenCV's calibrateCamera, the
    # fit's start), not the fit through the robot's poses, which the robot's errors bend
    camera = result.start.get("camera", result.camera)
    try:
        poses, sigma, sigma_angle = pose_observations(views, camera)
    except CalibrationRefused as exc:
        raise UserError(f"{captures.path}: no robot observations: {exc}") from None
    device = captures.robot_model.devices[captures.device]
    eye_in_hand = captures.setup == "eye-in-hand"
    target = captures.camera.name if eye_in_hand else captures.board.name
    frame = captures.board.name if eye_in_hand else captures.camera.name
    return observation_file_text(
        device,
        target,
        frame,
        f"camera {captures.camera.name} on board {captures.board.name} (PnP)",
        sigma,
        sigma_angle,
        captures.joints[used],
        poses,
        [
            f"The pose of {target} in {frame} at each view of {captures.path} with the board "
            "found,",
            "by PnP with the intrinsics of the views' own pictures (OpenCV's calibrateCamera,",
            f"rworld calibrate-camera, {date}); the sigmas from the views' PnP at the pixel",
            f"noise. For 'rworld calibrate-robot {captures.robot_cell} FILE'.",
        ],
    )


@dataclass
class ViewPlanRun:
    """What ``rworld plan-views`` chose.

    Attributes
    ----------
    joints : ndarray, shape (N, n)
        The chosen views' joint values [rad or m], in the order visited.
    mount : str
        The frame on the robot's flange: the camera's mount (eye-in-hand) or the board's
        holder (eye-to-hand).
    T_base_flange : ndarray, shape (N, 4, 4)
        That frame in the robot's base at each [m].
    figures : dict
        The choice's predicted sigma of the camera's pose in its mount - the flange, or the
        robot's base eye-to-hand - (``position`` m, ``rotation`` rad) against the median of
        50 random choices of as many usable candidates; ``error`` and ``random_error`` at a
        point ``lever`` ahead [m] (with the robot's errors, ``with_robot``: the
        camera-to-board pose's at the robot's poses; ``robot_parameters`` the robot's
        parameters counted).
    """

    cell: str
    camera: str
    board: str
    device: str
    mount: str
    setup: str
    candidates: int
    usable: int
    lost: dict[str, int]
    joints: np.ndarray
    T_base_flange: np.ndarray
    figures: dict
    sigma_px: float
    seconds: float
    written: list[str] = field(default_factory=list)
    #: with the robot's errors: the robot's poses the camera-to-board error is predicted at
    #: (K, n) [rad or m] - usable candidates drawn at random
    check_joints: np.ndarray | None = None

    def as_dict(self) -> dict:
        from .. import spatial

        f = self.figures
        return finite(
            {
                "cell": self.cell,
                "camera": self.camera,
                "board": self.board,
                "device": self.device,
                "mount": self.mount,
                "setup": self.setup,
                "candidates": self.candidates,
                "usable": self.usable,
                "lost": self.lost,
                "refine": f.get("refine", 0),
                "refined_usable": f.get("refined", 0),
                "pixel_sigma_px": self.sigma_px,
                "with_robot": f["with_robot"],
                "robot_parameters": f["robot_parameters"],
                "camera_choice_error_mm": (
                    f["camera_choice_error"] * 1000 if "camera_choice_error" in f else None
                ),
                "predicted_error_mm": f["error"] * 1000,
                "random_error_mm": f["random_error"] * 1000,
                "lever_mm": f["lever"] * 1000,
                "predicted_position_mm": f["position"] * 1000,
                "predicted_rotation_deg": float(np.degrees(f["rotation"])),
                "random_position_mm": f["random_position"] * 1000,
                "random_rotation_deg": float(np.degrees(f["random_rotation"])),
                "views": [
                    {
                        "joints_deg": np.degrees(q).tolist(),
                        "flange_xyz_mm": (T[:3, 3] * 1000).tolist(),
                        "flange_rpy_deg": np.degrees(spatial.matrix_to_rpy(T[:3, :3])).tolist(),
                    }
                    for q, T in zip(self.joints, self.T_base_flange, strict=True)
                ],
                "seconds": self.seconds,
                "written": self.written,
            }
        )


def plan_views(
    cell_path: str,
    camera: str,
    count: int,
    board: str | None = None,
    candidates: int = 1000,
    seed: int = 0,
    distance: tuple[float, float] | None = None,
    tilt: float = np.radians(40.0),
    roll: float = np.radians(30.0),
    sigma_px: float = 0.1,
    captures: str | None = None,
    program: str | None = None,
    progress=None,
    refine: int | None = None,
    with_robot: bool = False,
) -> ViewPlanRun:
    """Choose ``count`` robot poses from which a camera sees the whole board - the camera on
    the robot (eye-in-hand), or fixed in the cell with the board on the robot (eye-to-hand) -
    and which together determine its calibration best (D-optimal on the 21 parameters'
    information, then exchanges for the camera's pose error, ``vision/plan.py``).

    Candidates are camera poses around the board (from its printed side, within ``tilt`` of
    its normal, ``distance`` [m] away - default where the board spans 35-80 % of the image's
    width - turned by up to ``roll``); a candidate is usable when the robot reaches it (IK for
    the camera's frame, or the board's), touches nothing there or on the straight joint path
    from home, and the camera sees every corner and the outer squares (nothing of the cell or
    the robot in the way). ``refine`` more candidates (default two thirds of ``candidates``; 0:
    none) are then drawn around the chosen views within the same bounds
    (:func:`~rworld_cli.vision.plan.refined_candidates`), in
    :data:`~rworld_cli.vision.plan.REFINE_ROUNDS` rounds each around the last choice, and the
    choice is made again from all; the random choices it is compared with come from the first
    candidates only.
    ``captures``: a capture file of the views to fill with images (``rworld
    calibrate-camera``); ``program``: a program that visits each from home, takes an image
    there (a ``capture:`` step) and returns.

    ``with_robot``: views for ``calibrate-camera --with-robot`` (the robot's joint-frame
    errors estimated with the camera): each view's information holds the robot's parameters
    too (those the usable candidates determine beside the camera's,
    :func:`~rworld_cli.calibration.robot.select` as the calibration decides it), and the
    exchanges lower the camera-to-board pose's predicted error at the robot's poses - 40 of
    the usable candidates' (:func:`~rworld_cli.vision.plan.place_weight`) - instead of the
    camera-in-mount pose's.

    Raises
    ------
    UserError
        Not a camera, no board or an unknown one, neither the camera nor the board on a
        robot, fewer usable candidates than views asked.
    """
    from .. import spatial
    from ..calibration.robotplan import collision_free_states
    from ..errors import did_you_mean
    from ..fileio import atomic_write_text, output_set
    from ..kinematics.inverse import solve_ik_many
    from ..kinematics.jacobian import ToolMount
    from ..sensing.camera import camera_reading
    from ..sensing.sensors import sensable_bodies
    from ..vision.camera import transform_points, visible
    from ..vision.plan import (
        REFINE_ROUNDS,
        camera_candidates,
        place_weight,
        refined_candidates,
        robot_information,
        select_views,
        view_information,
        weighted_error,
    )
    from .cells import load_world

    started = time.perf_counter()
    world, _ = load_world(cell_path)
    cell = world.cell
    cameras = [n for n, s in cell.sensors.items() if s.type == "camera"]
    if camera not in cameras:
        raise UserError(
            f"'{camera}' is not a camera sensor of {cell_path}{did_you_mean(camera, cameras)}; "
            f"its cameras: {', '.join(cameras) or 'none'}"
        )
    if not (count >= 3 and candidates >= count and sigma_px > 0):
        raise UserError("give --views 3 or more, --candidates at least --views, a sigma above 0")
    boards = [n for n, o in cell.objects.items() if o.board is not None]
    if board is not None and board not in boards:
        raise UserError(f"'{board}' is not a calibration board{did_you_mean(board, boards)}")
    # eye-in-hand: the camera on a robot's link; eye-to-hand: the camera fixed, the board on one
    carriers = [d for d in cell.devices if _on_robot(world, d, camera)]
    setup = "eye-in-hand" if carriers else "eye-to-hand"
    if setup == "eye-to-hand":
        held = [(d, b) for b in boards for d in cell.devices if _on_robot(world, d, b)]
        if board is not None:
            held = [(d, b) for d, b in held if b == board]
        if len(held) != 1:
            raise UserError(
                f"'{camera}' is fixed in the cell (on no robot's link), and "
                + (
                    f"{len(held)} boards are on robots ({', '.join(b for _, b in held)}): name "
                    "one with --board"
                    if held
                    else (f"'{board}' is" if board else "no calibration board is")
                    + " on a robot's link: to calibrate a fixed camera, a robot holds the board"
                )
            )
        device, board = held[0]
    else:
        device = carriers[0]
        if board is None:
            if len(boards) != 1:
                raise UserError(
                    f"{cell_path} has {len(boards)} calibration boards"
                    + (f" ({', '.join(boards)}): name one with --board" if boards else "")
                )
            board = boards[0]
    carried = camera if setup == "eye-in-hand" else board  # what the robot moves
    link, T_link_carried = world.mount_of(device, carried)
    dev = cell.devices[device]
    mount_frame = world.parent(carried)  # the frame on the flange: camera mount, board holder
    assert mount_frame is not None
    cam = cell.sensors[camera].camera
    model = cell.objects[board].board
    assert cam is not None and model is not None  # a camera sensor's model, a board's
    T_world_base = world.T_world(device)
    if distance is None:
        width = model.width
        distance = (cam.fx * width / (0.8 * cam.width), cam.fx * width / (0.35 * cam.width))
    rng = np.random.default_rng(seed)
    if setup == "eye-in-hand":  # the camera in the flange, the board in the base
        X, Z = world.T(mount_frame, camera), world.T(device, board)
    else:  # the camera in the base, the board in the flange
        X, Z = world.T(device, camera), world.T(mount_frame, board)
    T_world_board, T_world_camera = world.T_world(board), world.T_world(camera)
    lower, upper = dev.limit_array("lower"), dev.limit_array("upper")
    lo, hi = np.where(np.isfinite(lower), lower, -np.pi), np.where(np.isfinite(upper), upper, np.pi)

    def T_board_camera_of(F: np.ndarray) -> np.ndarray:
        """The camera in the board's frame (K, 4, 4) at flange poses ``F`` (K, 4, 4)."""
        if setup == "eye-in-hand":
            return np.linalg.inv(T_world_board) @ T_world_base @ F @ X
        return spatial.invert_transform(spatial.invert_transform(X) @ F @ Z)

    def usable(T_board_camera: np.ndarray, lost: dict[str, int], step: str):
        """The candidates' joints and flange poses where the robot reaches them, touches
        nothing there or on the straight joint path from home, and the camera sees the
        whole board; counts of the rest by reason in ``lost``."""
        M = len(T_board_camera)
        if setup == "eye-in-hand":  # the camera brought around the board
            T_base_target = np.linalg.inv(T_world_base) @ T_world_board @ T_board_camera
        else:  # the board brought in front of the camera
            T_base_target = (
                np.linalg.inv(T_world_base)
                @ T_world_camera
                @ spatial.invert_transform(T_board_camera)
            )
        # IK from home and two random starts for each candidate; the first that reaches it
        starts = np.concatenate([np.tile(dev.home, (M, 1)), rng.uniform(lo, hi, (2 * M, dev.dof))])
        Q, ok = solve_ik_many(
            dev, np.tile(T_base_target, (3, 1, 1)), starts, ToolMount(link, T_link_carried)
        )
        Q, ok = Q.reshape(3, M, -1), ok.reshape(3, M)
        first = np.argmax(ok, axis=0)
        reached = ok.any(axis=0)
        Q = Q[first, np.arange(M)]
        lost["out of reach"] = lost.get("out of reach", 0) + int((~reached).sum())
        keep = np.nonzero(reached)[0]
        if progress is not None:
            progress(1, 3, f"collision checks{step}")
        fractions = np.linspace(0.125, 1.0, 8)
        path = dev.home + fractions[:, None, None] * (Q[keep] - dev.home)[None]
        states = path.reshape(-1, dev.dof)
        free = collision_free_states(cell, device, states).reshape(8, -1).all(axis=0)
        why = "a collision there or on the way from home"
        lost[why] = lost.get(why, 0) + int((~free).sum())
        keep = keep[free]
        if progress is not None:
            progress(2, 3, f"what the camera sees{step}")
        seen_all = []
        saved = world.joints(device)
        for k in keep:
            world.set_joints(device, Q[k])
            reading = camera_reading(world, camera, cell.sensors[camera], sensable_bodies(world))
            b = (reading.image or {})["boards"][board]
            # every corner seen, and the outer squares inside the image (the detector needs them)
            around = transform_points(world.T(camera, board), model.outline)
            seen_all.append(b["seen"] == b["total"] and bool(visible(cam, around, 1.0).all()))
        seen_all_arr = np.array(seen_all, dtype=bool)
        why = "the board not whole in the image (hidden, or its corners or outer squares cut)"
        lost[why] = lost.get(why, 0) + int((~seen_all_arr).sum())
        keep = keep[seen_all_arr] if len(keep) else keep
        flanges = np.empty((len(keep), 4, 4))
        for i, k in enumerate(keep):
            world.set_joints(device, Q[k])
            flanges[i] = world.T(device, mount_frame)
        world.set_joints(device, saved)
        return Q[keep], flanges

    lost: dict[str, int] = {}
    T_board_camera = camera_candidates(rng, model, candidates, distance, tilt, roll)
    Q, T_base_flange = usable(T_board_camera, lost, "")
    if len(Q) < count:
        said = "; ".join(f"{n} {why}" for why, n in lost.items() if n)
        raise UserError(
            f"only {len(Q)} of {candidates} candidate views are usable ({said}); ask for "
            "fewer views or more candidates, or move the "
            + ("board" if setup == "eye-in-hand" else "camera")
            + " nearer the robot"
        )
    G = view_information(cam, model, X, Z, T_base_flange, sigma_px, setup)
    weight, robot, taken, robot_names, checks = None, None, np.zeros(0, dtype=int), [], None
    if with_robot:
        from ..vision.calibrate import joint_errors_determined

        robot = flange_robot(world, device, mount_frame)
        R = robot_information(cam, model, X, Z, robot, Q, sigma_px, setup)
        # the robot's parameters the candidates determine beside the camera's (whitened: 1)
        chosen_robot, _, _ = joint_errors_determined(
            robot, G.reshape(-1, G.shape[2]), R.reshape(-1, R.shape[2]), 1.0
        )
        taken = np.array(sorted(chosen_robot), dtype=int)
        robot_names = [robot.names[k] for k in taken]
        G = np.concatenate([G, R[:, :, taken]], axis=2)
        checks = Q[rng.choice(len(Q), min(40, len(Q)), replace=False)]
        weight = place_weight(cam, X, Z, robot, checks, taken, 0.3, setup)

    def information(Q_views: np.ndarray, flanges_views: np.ndarray) -> np.ndarray:
        """The views' whitened Jacobians (M, 2N, 21 [+ the robot's parameters taken])."""
        out = view_information(cam, model, X, Z, flanges_views, sigma_px, setup)
        if robot is None:
            return out
        R = robot_information(cam, model, X, Z, robot, Q_views, sigma_px, setup)
        return np.concatenate([out, R[:, :, taken]], axis=2)

    chosen, figures = select_views(G, count, seed, weight=weight)
    usable_count = len(Q)
    refine = 2 * candidates // 3 if refine is None else refine
    refined = 0
    # candidates around the chosen views, the choice made again from all; in rounds, each
    # around the last choice
    for k in range(REFINE_ROUNDS if refine else 0):
        share = refine // REFINE_ROUNDS + (refine % REFINE_ROUNDS if k == 0 else 0)
        around = refined_candidates(
            rng, model, T_board_camera_of(T_base_flange[chosen]), share, distance, tilt
        )
        Q_near, flanges_near = usable(around, {}, " (around the choice)")
        if len(Q_near):
            G = np.concatenate([G, information(Q_near, flanges_near)])
            chosen, figures = select_views(G, count, seed, random_from=usable_count, weight=weight)
            Q = np.concatenate([Q, Q_near])
            T_base_flange = np.concatenate([T_base_flange, flanges_near])
        refined += len(Q_near)
    if refine:
        figures["refined"] = int(refined)
        figures["refine_rounds"] = REFINE_ROUNDS
    figures["refine"] = int(refine)
    figures["with_robot"] = bool(with_robot)
    figures["robot_parameters"] = robot_names
    if weight is not None:  # the views chosen for the camera alone, from the same candidates
        for_camera, _ = select_views(G[:, :, :21], count, seed, random_from=usable_count)
        figures["camera_choice_error"] = weighted_error(G, for_camera, weight)
    # visited nearest first from home
    order = [int(c) for c in chosen[np.argsort(np.abs(Q[chosen] - dev.home).max(axis=1))]]
    joints = Q[order]
    flanges = T_base_flange[order]
    run = ViewPlanRun(
        cell_path,
        camera,
        board,
        device,
        mount_frame,
        setup,
        candidates,
        usable_count,
        lost,
        joints,
        flanges,
        figures,
        sigma_px,
        time.perf_counter() - started,
        check_joints=checks,
    )
    if captures or program:
        import os

        from ..schema.captures import capture_template_text
        from ..schema.programs import program_text

        per_unit = np.array(
            [1000.0 if j.kind == "prismatic" else np.degrees(1.0) for j in dev.joints]
        )  # the program's mm and deg
        # 6 decimals, rounded inside the limits (a view at a limit stays within it)
        low = np.ceil(dev.limit_array("lower") * per_unit * 1e6) / 1e6
        high = np.floor(dev.limit_array("upper") * per_unit * 1e6) / 1e6

        def written(q):
            return [float(v) for v in np.clip(np.round(q * per_unit, 6), low, high)]

        with output_set():
            if captures:
                # the robot and each view's joints as the program commands them (joint moves:
                # the robot stands there), for calibrate-camera --through-robot / --with-robot
                cell_dir = Path(cell_path).resolve()
                cell_dir = cell_dir.parent if cell_dir.is_file() else cell_dir
                base_dir = Path(captures).resolve().parent
                commanded = np.array([written(q) for q in joints]) / per_unit
                atomic_write_text(
                    captures,
                    capture_template_text(
                        cam,
                        mount_frame if setup == "eye-in-hand" else device,
                        device if setup == "eye-in-hand" else mount_frame,
                        model,
                        flanges,
                        setup=setup,
                        robot=(os.path.relpath(cell_dir, base_dir), dev),
                        joints=commanded,
                    ),
                )
                run.written.append(str(captures))
            if program:
                steps: list[tuple[dict, str | None]] = []
                home = written(dev.home)
                for number, q in enumerate(joints, start=1):
                    view = written(q)
                    steps.append(({"move": {"joints": view}}, f"view {number:02d}"))
                    steps.append(({"capture": camera}, f"view{number:02d}.png"))
                    steps.append(({"move": {"joints": home}}, None))
                doc = {
                    "header": [
                        f"{count} views of {board} for {camera}, chosen by rworld plan-views "
                        "(D-optimal); each visited from home, an image taken there (capture:",
                        "the trigger and the pose logged when exported; rworld captures reads "
                        "them back).",
                    ],
                    "device": device,
                    "units": {"length": "mm", "angle": "deg"},
                    "steps": steps,
                }
                atomic_write_text(program, program_text(doc))
                run.written.append(str(program))
    return run


#: how far a logged capture pose may lie from the simulated one before it is refused: the
#: controller's robot stands where the program sent it, to its accuracy
CAPTURE_TOLERANCE = 0.005  # [m]
CAPTURE_ANGLE_TOLERANCE = np.radians(1.0)  # [rad]


def captures_from_log(
    cell: str,
    run: str,
    log: str,
    images: list[str],
    output: str,
    fmt: str | None = None,
    device: str | None = None,
    frame: str | None = None,
    camera: str | None = None,
    board: str | None = None,
    capture_register: int = 151,
    tolerance: float = CAPTURE_TOLERANCE,
) -> dict:
    """A capture file from a robot's run of an exported program with ``capture:`` steps: the
    pose its controller logged at each image (``export program``'s capture reports), the
    images in the order they were taken, for ``rworld calibrate-camera``.

    The run is simulated on the cell as it is now (the pose files the program was exported
    with): it gives each capture its camera, the TCP the controller reported and the
    controller's frames (:func:`~rworld_cli.api.export.logged_reports`).  Each logged TCP pose
    is mapped into the robot's base frame (through its calibration, where the cell has one),
    and the flange's pose follows from the TCP's place on the flange: the camera's mount
    (eye-in-hand) or the board's holder (eye-to-hand, the camera fixed in the cell).

    Parameters
    ----------
    images : list of str
        The image files, one for each capture, in the order taken.
    tolerance : float
        How far a logged pose may lie from the simulated capture's [m] (and 1 deg): further,
        and it is not this capture's pose, or the log's frame or units are not the export's.

    Raises
    ------
    UserError
        A malformed log (at its line), a count or a field that does not match the program's
        captures, a pose far from its capture's, a missing image, captures of several cameras
        without ``camera``; nothing written.
    """
    import os

    from .. import spatial
    from ..errors import did_you_mean
    from ..fileio import atomic_write_text
    from ..schema.captures import capture_template_text
    from ..schema.contactlog import CAPTURE
    from .export import ARM_FORMATS, _world_at, logged_reports

    if not (tolerance > 0 and np.isfinite(tolerance)):
        raise UserError(f"--tolerance must be a finite length > 0, got {tolerance}")
    got = logged_reports(cell, run, log, CAPTURE, fmt, device, frame, capture_register, joints=True)
    world, records = got.world, got.records
    cell_model = got.loaded.cell
    cameras = sorted({r.feature for r in records})
    if camera is None:
        if len(cameras) > 1:
            raise UserError(
                f"{run}: the program captures with {len(cameras)} cameras "
                f"({', '.join(cameras)}): choose one with --camera"
            )
        camera = cameras[0]
    elif camera not in cameras:
        raise UserError(
            f"--camera {camera}: the program takes no image with it{did_you_mean(camera, cameras)}"
        )
    chosen = [k for k, r in enumerate(records) if r.feature == camera]
    if len(images) != len(chosen):
        raise UserError(
            f"{len(images)} image(s) given for the {len(chosen)} capture(s) of '{camera}' in "
            f"{log}: one image for each, in the order they were taken"
        )
    missing = [p for p in images if not Path(p).is_file()]
    if missing:
        raise UserError(
            f"no image file {missing[0]}"
            + (f" (and {len(missing) - 1} more)" if len(missing) > 1 else "")
        )
    boards = [n for n, o in cell_model.objects.items() if o.board is not None]
    name = got.device
    try:
        link, _ = world.mount_of(name, camera)
    except UserError:
        link = 0
    setup = "eye-in-hand" if link > 0 else "eye-to-hand"
    if board is None:
        carried = [b for b in boards if setup == "eye-in-hand" or _on_robot(world, name, b)]
        if len(carried) != 1:
            raise UserError(
                f"{cell} has {len(carried)} calibration board(s)"
                + (" on the robot" if setup == "eye-to-hand" else "")
                + (f" ({', '.join(carried)}): name one with --board" if carried else "")
            )
        board = carried[0]
    if board not in boards:
        raise UserError(
            f"--board: '{board}' is not a calibration board{did_you_mean(board, boards)}"
        )
    # the frame on the flange: the camera's mount, or the board's holder (eye-to-hand)
    flange_frame = world.parent(camera if setup == "eye-in-hand" else board)
    assert flange_frame is not None  # a sensor's and an object's parent: never the root
    if setup == "eye-to-hand" and not _on_robot(world, name, board):
        raise UserError(
            f"'{camera}' is fixed in the cell and '{board}' is not on '{name}': the robot moves "
            "neither, so its poses say nothing of the camera (eye-to-hand: the board on the "
            "flange)"
        )
    T_base_flange: list[np.ndarray] = []
    report: list[dict] = []
    for k in chosen:
        record, event, logged = records[k], got.events[k], got.logged[k]
        T_base_tcp = got.T_base_tcp[k]
        _world_at(world, result=got.result, t=event.t)
        assert record.tool is not None  # export refuses a capture before the first move
        tcp = record.tool.name  # the resolved TCP frame the move steered
        T_sim = world.T(name, tcp)
        T_flange = T_base_tcp @ world.T(tcp, flange_frame)
        off = float(np.linalg.norm(T_base_tcp[:3, 3] - T_sim[:3, 3]))
        turn = float(np.linalg.norm(spatial.rotation_vector(T_sim[:3, :3].T @ T_base_tcp[:3, :3])))
        # written so that a NaN anywhere is outside
        if not (off <= tolerance and turn <= CAPTURE_ANGLE_TOLERANCE):
            raise UserError(
                f"{logged.where}: capture {logged.number} ({camera}, step {record.step}) lies "
                f"{off * 1000:.3f} mm and {np.degrees(turn):.3f} deg from where the program "
                f"took it (at most {tolerance * 1000:g} mm and "
                f"{np.degrees(CAPTURE_ANGLE_TOLERANCE):g} deg): not this capture's pose, or "
                "the log's frame or units are not the export's"
            )
        T_base_flange.append(T_flange)
        report.append(
            {
                "capture": logged.number,
                "step": record.step,
                "where": record.where,
                "log": logged.where,
                "image": images[len(report)],
                "flange_xyz_mm": (T_flange[:3, 3] * 1000).tolist(),
                "flange_rpy_deg": np.degrees(spatial.matrix_to_rpy(T_flange[:3, :3])).tolist(),
                "from_simulated_mm": off * 1000,
                "from_simulated_deg": float(np.degrees(turn)),
            }
        )
    base_dir = Path(output).resolve().parent
    relative = [os.path.relpath(Path(p).resolve(), base_dir) for p in images]
    cell_dir = Path(cell).resolve()
    cell_dir = cell_dir.parent if cell_dir.is_file() else cell_dir
    robot = (os.path.relpath(cell_dir, base_dir), cell_model.devices[name])
    cam = cell_model.sensors[camera].camera
    pattern = cell_model.objects[board].board
    assert cam is not None and pattern is not None  # a camera sensor's model, a board's
    mount = flange_frame if setup == "eye-in-hand" else name
    holder = name if setup == "eye-in-hand" else flange_frame
    text = capture_template_text(
        cam,
        mount,
        holder,
        pattern,
        np.array(T_base_flange),
        relative,
        setup,
        [
            f"The images {camera} took in a run of {Path(run).name} on {name}, with the flange",
            f"poses its controller logged ({ARM_FORMATS[got.fmt]}: {Path(log).name}); read by",
            "'rworld captures --from-log'. Calibrate with 'rworld calibrate-camera' this file.",
            "The joints: the controller's, its nominal inverse kinematics of each logged pose.",
        ],
        robot,
        np.array([got.joints[k] for k in chosen]),
    )
    atomic_write_text(output, text)
    return {
        "written": output,
        "device": name,
        "format": got.fmt,
        "camera": camera,
        "board": board,
        "setup": setup,
        "views": report,
        "notes": got.notes,
    }


def _on_robot(world, device: str, frame: str) -> bool:
    """Whether ``frame`` rides on one of ``device``'s links (not its base)."""
    try:
        return world.mount_of(device, frame)[0] > 0
    except UserError:
        return False
