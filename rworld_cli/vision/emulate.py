"""What a camera sees of a board: the corners' exact pixel positions and which of them the image
holds; and views of a board from around it, with a known truth (simulated calibrations)."""

from __future__ import annotations

import numpy as np

from .. import spatial
from ..model.vision import BoardModel, CameraModel
from .calibrate import EYE_IN_HAND, BoardViews
from .camera import project, transform_points, visible


def seen_corners(camera: CameraModel, board: BoardModel, T_camera_board) -> np.ndarray:
    """The board's corners in the image, NaN where the camera does not see them (behind the
    lens, outside the image or past the distortion's one-to-one range; occlusion by other
    bodies is not looked at here).

    Parameters
    ----------
    T_camera_board : array_like, shape (..., 4, 4)
        The board in the camera's frame [m].

    Returns
    -------
    ndarray, shape (..., N, 2)
        [px], in :attr:`BoardModel.points` order.
    """
    pts = transform_points(T_camera_board, board.points)
    uv = project(camera.intrinsics, pts)
    return np.where(visible(camera, pts)[..., None], uv, np.nan)


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """The camera pose (OpenCV's axes: +z along the view, +y down the image) at ``eye`` looking
    at ``target``, its image's x axis horizontal to ``up``; shape (4, 4) [m]."""
    eye, target, up = (np.asarray(v, dtype=float) for v in (eye, target, up))
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    if np.linalg.norm(x) < 1e-9:
        x = np.cross(z, [1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return spatial.make_transform(np.column_stack([x, y, z]), eye)


def random_views(
    rng: np.random.Generator,
    camera: CameraModel,
    board: BoardModel,
    T_mount_camera: np.ndarray,
    T_holder_board: np.ndarray,
    count: int,
    distance=(0.35, 0.7),
    tilt_deg: float = 35.0,
    roll_deg: float = 30.0,
    noise_px: float = 0.0,
    setup: str = EYE_IN_HAND,
    flange_noise: tuple[float, float] = (0.0, 0.0),
) -> BoardViews:
    """``count`` views of the board, each seeing all of its corners, and the robot poses that
    give them (a simulated calibration with a known truth).

    The camera looks at a point near the board's centre from a direction within ``tilt_deg``
    of the board's normal, at a distance drawn from ``distance`` [m], turned about its axis
    by up to ``roll_deg``; pixel noise of ``noise_px`` (sigma, each coordinate) is added, and
    the flange poses given are the true ones times an error of sigma ``flange_noise``
    (rotation [rad], translation [m], each axis of the flange's frame): a robot's pose error.
    ``setup`` eye-in-hand: ``T_mount_camera`` is the camera in the flange and
    ``T_holder_board`` the board in the base; eye-to-hand: the camera in the base and the board
    in the flange.
    """
    centre = board.centre
    span = board.span
    flanges: list[np.ndarray] = []
    corners: list[np.ndarray] = []
    while len(flanges) < count:
        t = np.radians(tilt_deg) * np.sqrt(rng.uniform())
        a = rng.uniform(0, 2 * np.pi)
        d = rng.uniform(*distance)
        # the board's +z points away from the camera: views from -z
        direction = np.array([np.sin(t) * np.cos(a), np.sin(t) * np.sin(a), -np.cos(t)])
        aim = centre + rng.normal(0, 0.1 * span, 3) * [1, 1, 0]
        T_board_camera = look_at(aim + d * direction, aim, up=(0.0, -1.0, 0.0))
        roll = spatial.make_transform(spatial.rot_z(np.radians(rng.uniform(-roll_deg, roll_deg))))
        T_board_camera = T_board_camera @ roll
        T_camera_board = spatial.invert_transform(T_board_camera)
        uv = seen_corners(camera, board, T_camera_board)
        if not np.all(np.isfinite(uv)):
            continue
        # T_camera_board = X^-1 H Z  ->  H = X T_camera_board Z^-1
        H = T_mount_camera @ T_camera_board @ spatial.invert_transform(T_holder_board)
        F = spatial.invert_transform(H) if setup == EYE_IN_HAND else H
        error = spatial.make_transform(
            spatial.rotation_from_vector(rng.normal(0.0, flange_noise[0], 3)),
            rng.normal(0.0, flange_noise[1], 3),
        )
        flanges.append(F @ error)
        corners.append(uv + rng.normal(0.0, noise_px, uv.shape))
    names = tuple(f"view{k + 1:02d}" for k in range(count))
    return BoardViews(board, camera, setup, names, np.array(flanges), np.array(corners))
