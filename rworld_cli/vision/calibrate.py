"""The camera's calibration from views of a board: intrinsics, hand-eye and the board's place,
in one bundle adjustment on the reprojection errors (``docs/vision.md``).

The two set-ups share one model. With ``X = T_mount_camera`` (the camera in the flange for
eye-in-hand, in the robot's base for eye-to-hand), ``Z = T_holder_board`` (the board in the
base, or in the flange) and the robot's pose ``F_i = T_base_flange`` of view *i*::

    T_camera_board_i = X^-1 H_i Z,   H_i = F_i^-1 (eye-in-hand) or F_i (eye-to-hand)

and the board's corners ``p_j`` are seen at ``project(intrinsics, T_camera_board_i p_j)``.
OpenCV gives the start (``calibrateCamera``, then ``calibrateRobotWorldHandEye`` with Shah's
method); a least-squares fit of every reprojection error (Huber's loss beyond 3 robust sigmas)
gives the estimate, and two covariances: the pixel-noise one (``s^2 (J^T J)^-1``) and the one
that lets the errors of a view be shared (a robot pose's error moves all of a view's corners:
the sandwich clustered by view), which is the one reported as the sigma. With
``flange_errors`` each view's flange pose gets an error of its own (a random effect), its
sigmas and the pixels' estimated by variance components; the errors shared by all views (in
the flange's frame and in the base's: the views cannot tell them from ``X`` and ``Z``) are
then put into ``X`` and ``Z``, and the sigma is that of the poses so seen.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .. import spatial
from ..calibration.robot import RobotCalibration, RobotModel
from ..model.vision import BoardModel, CameraModel
from .camera import project, transform_points

EYE_IN_HAND = "eye-in-hand"
EYE_TO_HAND = "eye-to-hand"

#: the parameters in the order of the estimate's vector and covariance
PARAMETER_NAMES = (
    "fx",
    "fy",
    "cx",
    "cy",
    "k1",
    "k2",
    "p1",
    "p2",
    "k3",
    "camera.rx",
    "camera.ry",
    "camera.rz",
    "camera.x",
    "camera.y",
    "camera.z",
    "board.rx",
    "board.ry",
    "board.rz",
    "board.x",
    "board.y",
    "board.z",
)

#: the exact-robot fit's corners this many times as far off as each view's own picture's: the
#: robot's pose errors set the fit, and the model of them is taken unless one is asked
#: (rendered exact robots: 1.05-1.24; the real sets, Ali et al.'s KUKA and Tabb and Ahmad
#: Yousef's Denso: 9.8-32)
ROBOT_ERRORS_DOMINATE = 3.0
#: fewest views with the board found that a calibration takes
MIN_VIEWS = 3
#: the robot must turn at least this much between some two views [rad]
MIN_ROTATION = np.radians(2.0)
#: the robot's turns between views must span a second axis: the second singular value of their
#: unit axes (in the base's axes) at least this fraction of the first
MIN_SECOND_AXIS = 0.05


class CalibrationRefused(ValueError):
    """The views cannot determine the calibration; the message says why (the api makes it a
    located user error)."""


@dataclass(frozen=True)
class BoardViews:
    """What the calibration is given.

    Attributes
    ----------
    T_base_flange : ndarray, shape (V, 4, 4)
        The robot's flange in its base at each view [m].
    corners : ndarray, shape (V, N, 2)
        Each view's detected corners [px], NaN where a corner was not seen; N is the board's
        corner count, in :attr:`BoardModel.points` order.
    """

    board: BoardModel
    camera: CameraModel
    setup: str
    names: tuple[str, ...]
    T_base_flange: np.ndarray
    corners: np.ndarray

    def subset(self, index) -> BoardViews:
        index = np.asarray(index, dtype=int)
        return BoardViews(
            self.board,
            self.camera,
            self.setup,
            tuple(self.names[i] for i in index),
            self.T_base_flange[index],
            self.corners[index],
        )

    @property
    def H(self) -> np.ndarray:
        """``T_mount_holder`` at each view, shape (V, 4, 4)."""
        if self.setup == EYE_IN_HAND:
            return spatial.invert_transform(self.T_base_flange)
        return self.T_base_flange


#: the grid the flange errors' correlation is fitted over (:func:`fit_error_correlation`):
#: the lever that makes a turn a distance [m/rad], the correlation's length [m], and the
#: share of each view's error that is correlated with its neighbours'
CORRELATION_LEVERS = (0.25, 0.5, 1.0, 2.0)
CORRELATION_LENGTHS = np.geomspace(0.03, 3.0, 25)
CORRELATION_SHARES = np.linspace(0.0, 0.98, 50)


def pose_distances(Fa: np.ndarray, Fb: np.ndarray, lever: float) -> np.ndarray:
    """Distances between flange poses ``Fa`` (A, 4, 4) and ``Fb`` (B, 4, 4):
    ``sqrt(|dp|^2 + (lever * angle)^2)`` [m], ``lever`` [m/rad]. Shape (A, B)."""
    dp = np.linalg.norm(Fa[:, None, :3, 3] - Fb[None, :, :3, 3], axis=-1)
    R = np.einsum("aji,bjk->abik", Fa[:, :3, :3], Fb[:, :3, :3])
    angle = np.linalg.norm(spatial.rotation_vector(R.reshape(-1, 3, 3)), axis=-1)
    return np.sqrt(dp**2 + (lever * angle.reshape(dp.shape)) ** 2)


@dataclass(frozen=True)
class FlangeErrorField:
    """The robot's flange pose error as a smooth function of the pose: two views' errors
    correlate by ``share * exp(-d^2 / 2 length^2)`` over their poses' distance ``d``
    (:func:`pose_distances` with ``lever``), the rest of each view's error its own. Fitted
    to the calibration's views ``T_base_flange`` (V, 4, 4) and their estimated ``errors``
    (V, 6: rotation vector [rad], translation [m], in the flange's frame) before the parts the
    views cannot tell from the poses were put into them: ``base_side`` and ``flange_side``
    (4, 4; :func:`_through_robot_errors`)."""

    lever: float
    length: float
    share: float
    T_base_flange: np.ndarray
    errors: np.ndarray
    base_side: np.ndarray = field(default_factory=lambda: np.eye(4))
    flange_side: np.ndarray = field(default_factory=lambda: np.eye(4))

    def correlation(self, Fa: np.ndarray, Fb: np.ndarray) -> np.ndarray:
        """The errors' correlation between the poses ``Fa`` (A, 4, 4) and ``Fb`` (B, 4, 4)
        (the share of each view's own error not included). Shape (A, B)."""
        d = pose_distances(Fa, Fb, self.lever)
        return self.share * np.exp(-0.5 * (d / self.length) ** 2)

    @property
    def neighbour_correlation(self) -> float:
        """The correlation of each fitted view's error with its nearest view's, averaged:
        near 0 when the errors are independent (``share`` may then be large with a
        ``length`` shorter than the views' spacing)."""
        C = self.correlation(self.T_base_flange, self.T_base_flange)
        np.fill_diagonal(C, -np.inf)
        return float(np.mean(C.max(axis=1))) if len(C) > 1 else 0.0

    def prior(self) -> np.ndarray:
        """The correlation of the fitted views' errors, each view's own share included: the
        random effects' correlation over the views, shape (V, V)."""
        F = self.T_base_flange
        return self.correlation(F, F) + (1.0 - self.share) * np.eye(len(F))

    def predict(self, T_base_flange: np.ndarray) -> np.ndarray:
        """The expected flange pose error at new poses ``T_base_flange`` (K, 4, 4) given the
        fitted views' (kriging: the conditional mean). Shape (K, 6)."""
        weights = np.linalg.solve(self.prior(), self.errors)
        return self.correlation(T_base_flange, self.T_base_flange) @ weights

    def corrected(self, T_base_flange: np.ndarray) -> np.ndarray:
        """The flange poses (K, 4, 4) with their expected errors applied, for the poses the
        calibration writes: ``B F exp(e) C^-1``, ``B`` and ``C`` the errors' parts it put
        into them (``base_side``, ``flange_side``; :func:`_through_robot_errors`)."""
        F = _with_errors(T_base_flange, self.predict(T_base_flange))
        return self.base_side @ F @ spatial.invert_transform(self.flange_side)


def _with_errors(F: np.ndarray, errors: np.ndarray) -> np.ndarray:
    """Flange poses ``F`` (V, 4, 4) with their errors (V, 6) applied: ``F exp(e)``."""
    return F @ spatial.make_transform(spatial.rotation_from_vector(errors[:, :3]), errors[:, 3:])


def fit_error_correlation(
    T_base_flange: np.ndarray, standardized: np.ndarray
) -> tuple[float, float, float]:
    """The correlation of the flange errors over the poses (``lever``, ``length``,
    ``share``) that makes the views' standardized errors ``standardized`` (V, 6: each
    component over its sigma) likeliest: a Gaussian with one scale profiled out, over the
    grid :data:`CORRELATION_LEVERS` x :data:`CORRELATION_LENGTHS` x
    :data:`CORRELATION_SHARES`. ``share`` 0: the errors are independent."""
    V, k = standardized.shape
    best = (-np.inf, CORRELATION_LEVERS[0], float(CORRELATION_LENGTHS[0]), 0.0)
    shares = CORRELATION_SHARES[:, None, None]
    for lever in CORRELATION_LEVERS:
        D = pose_distances(T_base_flange, T_base_flange, lever)
        for length in CORRELATION_LENGTHS:
            C = shares * np.exp(-0.5 * (D / length) ** 2) + (1.0 - shares) * np.eye(V)
            L = np.linalg.cholesky(C)  # (S, V, V)
            a = np.linalg.solve(L, np.broadcast_to(standardized, (len(shares), V, k)))
            scale = np.sum(a * a, axis=(1, 2)) / (V * k)
            log_det = 2.0 * np.sum(np.log(np.diagonal(L, axis1=1, axis2=2)), axis=1)
            likelihood = -0.5 * (k * log_det + V * k * np.log(scale))
            i = int(np.argmax(likelihood))
            if likelihood[i] > best[0]:
                best = (float(likelihood[i]), lever, float(length), float(CORRELATION_SHARES[i]))
    return best[1], best[2], best[3]


@dataclass(frozen=True)
class CameraCalibration:
    """The estimate.

    Attributes
    ----------
    camera : CameraModel
        The calibrated intrinsics.
    T_mount_camera : ndarray, shape (4, 4)
        The camera in the flange (eye-in-hand) or the robot's base (eye-to-hand) [m].
    T_holder_board : ndarray, shape (4, 4)
        The board in the robot's base (eye-in-hand) or the flange (eye-to-hand) [m]. With the
        robot's errors modelled, both poses hold the errors shared by all views (in the
        flange's frame and in the base's): as the robot's nominal poses see them.
    covariance : ndarray, shape (21, 21)
        Of :data:`PARAMETER_NAMES` (px, rad about the mount's or holder's axes, m), errors
        shared within a view allowed (clustered by view).
    covariance_pixels : ndarray, shape (21, 21)
        The same if every corner's error were independent pixel noise of the residuals' size.
    sigma0 : float
        The residuals' robust standard deviation [px].
    rms : float
        Root mean square reprojection error of the views fitted [px].
    view_rms : ndarray, shape (V,)
        Each view's [px].
    start : dict
        The closed-form start: ``camera`` (OpenCV's intrinsics), ``T_mount_camera``,
        ``T_holder_board``.
    flange_sigma : tuple of float or None
        With the robot's errors modelled: the sigma of a view's flange pose error, rotation
        [rad] and translation [m] (each axis).
    flange_errors : ndarray, shape (V, 6), or None
        Each view's estimated flange pose error (rotation vector [rad], translation [m], in
        the flange's frame), the errors shared by all views taken out.
    flange_field : FlangeErrorField or None
        With the robot's errors modelled: their correlation over the poses and the fitted
        views' errors, to predict the robot's error at other poses.
    exact_ratio : float or None
        The exact-robot fit's corners against each view's own picture's (rms over
        :func:`pictures_rms`, taken as at least 0.01 px): near 1 where the robot's poses are
        as good as the pictures, far above where its pose errors set the fit
        (:func:`calibrate_views`; with ``robot`` None).
    model_chosen : bool
        The model of the robot's poses was chosen by ``exact_ratio`` (none asked).
    robot : RobotCalibration or None
        Estimated with the robot's own errors (:func:`calibrate_views_with_robot`): the
        robot's joint-frame corrections, their covariance (joint in the one estimate) and
        the corrected device; its ``residuals`` are the corners' (M, 2) [px].
    robot_cross : ndarray, shape (21, P), or None
        With ``robot``: the covariance of :data:`PARAMETER_NAMES` with the robot's ``P``
        parameters (``robot.covariance`` and ``covariance`` the diagonal blocks).
    """

    setup: str
    camera: CameraModel
    T_mount_camera: np.ndarray
    T_holder_board: np.ndarray
    covariance: np.ndarray
    covariance_pixels: np.ndarray
    sigma0: float
    rms: float
    view_rms: np.ndarray
    names: tuple[str, ...]
    observations: int
    downweighted: int
    start: dict = field(default_factory=dict)
    flange_sigma: tuple[float, float] | None = None
    flange_errors: np.ndarray | None = None
    flange_field: FlangeErrorField | None = None
    exact_ratio: float | None = None
    model_chosen: bool = False
    robot: RobotCalibration | None = None
    robot_cross: np.ndarray | None = None

    @property
    def sigma(self) -> np.ndarray:
        """Standard deviations of :data:`PARAMETER_NAMES`, shape (21,)."""
        return np.sqrt(np.diag(self.covariance))

    def camera_board(self, views: BoardViews) -> np.ndarray:
        """``T_camera_board`` predicted through the robot at each view, shape (V, 4, 4)."""
        return spatial.invert_transform(self.T_mount_camera) @ views.H @ self.T_holder_board

    def robot_views(self, views: BoardViews) -> BoardViews:
        """Other views with their flange poses where the estimate expects the robot to be:
        with a flange error field, each corrected by the error it predicts there
        (:meth:`FlangeErrorField.corrected`); else as given."""
        if self.flange_field is None:
            return views
        F = self.flange_field.corrected(views.T_base_flange)
        return BoardViews(views.board, views.camera, views.setup, views.names, F, views.corners)

    def predicted_corners(self, views: BoardViews) -> np.ndarray:
        """The corners predicted through the robot at each view, shape (V, N, 2) [px]."""
        pts = transform_points(self.camera_board(views), views.board.points)
        return project(self.camera.intrinsics, pts)


# --------------------------------------------------------------------------- checks


def check_motion(views: BoardViews) -> None:
    """Refuse robot motions that leave the hand-eye unobservable.

    Pure translations leave the camera's position in the flange undetermined, and turns about
    one axis (or parallel axes) leave its offset along that axis undetermined (Tsai and Lenz).
    """
    V = len(views.names)
    if V < MIN_VIEWS:
        raise CalibrationRefused(
            f"too few views: {V} with the board found, a calibration needs {MIN_VIEWS} at least "
            "(15 or more, turned about different axes, for a good one)"
        )
    R = views.T_base_flange[:, :3, :3]
    i, j = np.triu_indices(V, 1)
    turns = spatial.rotation_vector(np.swapaxes(R[i], -1, -2) @ R[j])  # in flange i's axes
    turns = np.einsum("kab,kb->ka", R[i], turns)  # in the base's axes: comparable
    angles = np.linalg.norm(turns, axis=1)
    largest = float(angles.max()) if len(angles) else 0.0
    if largest < MIN_ROTATION:
        raise CalibrationRefused(
            "degenerate motion: the robot turns at most "
            f"{np.degrees(largest):.3g} deg between views (pure translations leave the "
            f"camera's position in the flange unobservable); turn the flange by "
            f"{np.degrees(MIN_ROTATION):.3g} deg or more about two different axes"
        )
    axes = turns[angles > 1e-6] / angles[angles > 1e-6, None]
    # the axes' spread: the second singular value of the unit axes (sign-free) relative to
    # the first
    s = np.linalg.svd(axes, compute_uv=False)
    spread = float(s[1] / s[0]) if len(s) > 1 else 0.0
    if spread < MIN_SECOND_AXIS:
        axis = np.linalg.svd(axes)[2][0]
        raise CalibrationRefused(
            "degenerate motion: every turn of the robot between views is about one axis "
            f"(base direction {np.array2string(axis, precision=3)}; the second axis's share "
            f"{spread:.3g}, below {MIN_SECOND_AXIS}): the camera's offset along it is "
            "unobservable; turn the flange about a second axis as well"
        )


# --------------------------------------------------------------------------- start values


def _as_cv_views(views: BoardViews):
    obj, img, keep = [], [], []
    pts = views.board.points.astype(np.float32)
    for k in range(len(views.names)):
        seen = np.isfinite(views.corners[k, :, 0])
        obj.append(pts[seen])
        img.append(views.corners[k, seen].astype(np.float32)[:, None, :])
        keep.append(seen)
    return obj, img, keep


def _poses(rvecs, tvecs) -> np.ndarray:
    R = spatial.rotation_from_vector(np.asarray(rvecs, dtype=float).reshape(-1, 3))
    T = np.tile(np.eye(4), (len(R), 1, 1))
    T[:, :3, :3] = R
    T[:, :3, 3] = np.asarray(tvecs, dtype=float).reshape(-1, 3)
    return T


def intrinsics_start(views: BoardViews, use_guess: bool) -> tuple[CameraModel, np.ndarray]:
    """OpenCV's ``calibrateCamera`` on the views: the intrinsics and each view's
    ``T_camera_board`` (V, 4, 4)."""
    import cv2

    obj, img, _ = _as_cv_views(views)
    cam = views.camera
    flags = cv2.CALIB_USE_INTRINSIC_GUESS if use_guess else 0
    K0 = cam.matrix if use_guess else None
    d0 = cam.distortion.copy() if use_guess else None
    _rms, K, d, rvecs, tvecs = cv2.calibrateCamera(
        obj, img, (cam.width, cam.height), K0, d0, flags=flags
    )
    d = np.asarray(d, dtype=float).ravel()[:5]
    camera = cam.with_intrinsics(np.r_[K[0, 0], K[1, 1], K[0, 2], K[1, 2], d])
    return camera, _poses(rvecs, tvecs)


def view_poses(views: BoardViews, camera: CameraModel) -> np.ndarray:
    """Each view's own ``T_camera_board`` by OpenCV's PnP with the given intrinsics,
    shape (V, 4, 4)."""
    import cv2

    obj, img, _ = _as_cv_views(views)
    out = np.zeros((len(obj), 4, 4))
    for k, (o, i) in enumerate(zip(obj, img, strict=True)):
        ok, rvec, tvec = cv2.solvePnP(o, i, camera.matrix, camera.distortion)
        if not ok:
            raise CalibrationRefused(f"view {views.names[k]!r}: the board's pose was not found")
        out[k] = _poses(rvec, tvec)[0]
    return out


def pose_observations(views: BoardViews, camera: CameraModel) -> tuple[np.ndarray, float, float]:
    """The camera and board as a 6-DoF instrument for the robot's own calibration: at each view
    the pose of what the robot carries in the frame of what stays (eye-in-hand the camera in
    the board's frame, ``T_board_camera``; eye-to-hand the board in the camera's,
    ``T_camera_board``) by PnP with ``camera``, and the sigmas of those poses.

    The sigmas follow from each view's PnP: the pixel noise (the residuals' rms over every
    view, each pose's 6 unknowns taken off the degrees of freedom) through the pose's
    information ``J^T J`` (``J``: the corners' pixels by the pose's translation in the frame
    and its rotation in its own axes, central differences); the median over the views of each
    block's root mean variance per axis.

    Returns
    -------
    poses : ndarray, shape (V, 4, 4)
        [m].
    sigma_position : float
        [m], per axis.
    sigma_angle : float
        [rad], per axis.
    """
    C = view_poses(views, camera)  # T_camera_board
    carried = spatial.invert_transform(C) if views.setup == EYE_IN_HAND else C
    points = views.board.points

    def pixels(P):
        T = spatial.invert_transform(P) if views.setup == EYE_IN_HAND else P
        return project(camera.intrinsics, transform_points(T, points))

    squares, count = 0.0, 0
    sig_p, sig_r = [], []
    for k, P in enumerate(carried):
        seen = np.isfinite(views.corners[k, :, 0])
        residual = pixels(P)[seen] - views.corners[k][seen]
        squares += float(np.sum(residual**2))
        count += 2 * int(seen.sum()) - 6
        J = np.empty((2 * int(seen.sum()), 6))
        for i in range(6):
            h = 1e-7
            d = np.zeros(6)
            d[i] = h
            up, down = P.copy(), P.copy()
            if i < 3:  # the position, in the frame's axes
                up[:3, 3] += d[:3]
                down[:3, 3] -= d[:3]
            else:  # the rotation, in the carried frame's own axes
                up[:3, :3] = P[:3, :3] @ spatial.rotation_from_vector(d[3:])
                down[:3, :3] = P[:3, :3] @ spatial.rotation_from_vector(-d[3:])
            J[:, i] = ((pixels(up) - pixels(down))[seen] / (2 * h)).ravel()
        cov = np.linalg.inv(J.T @ J)
        sig_p.append(np.sqrt(np.trace(cov[:3, :3]) / 3))
        sig_r.append(np.sqrt(np.trace(cov[3:, 3:]) / 3))
    noise = np.sqrt(squares / max(count, 1))
    return carried, float(noise * np.median(sig_p)), float(noise * np.median(sig_r))


#: a view's corner order is turned only where the robot's motion tells: the best order's
#: mismatch at most this fraction of the next best's [-], and the next best's at least
#: ``ORDER_MIN_GAP`` [rad] (the median over the other views of the turn angles' mismatch)
ORDER_MAX_RATIO = 1.0 / 3.0
ORDER_MIN_GAP = np.radians(5.0)


def board_turns(board: BoardModel) -> list[np.ndarray]:
    """The turns of a chessboard's corner grid onto itself about its normal: for each, the
    permutation ``perm`` (N,) with point ``perm[k]`` where the turn takes point ``k``; the
    first is no turn. A rectangular grid has the half turn; a square one the quarter turns
    too. A ChArUco board or an AprilTag grid has none (their markers name each corner)."""
    pts = board.points
    identity = np.arange(len(pts))
    if board.pattern != "chessboard":
        return [identity]
    centre = pts.mean(axis=0)
    quarter = board.columns == board.rows
    out = [identity]
    for angle in (np.pi / 2, np.pi, 3 * np.pi / 2) if quarter else (np.pi,):
        turned = (pts - centre) @ spatial.rot_z(angle).T + centre
        d = np.linalg.norm(turned[:, None, :2] - pts[None, :, :2], axis=-1)
        perm = np.argmin(d, axis=1)
        if d[identity, perm].max() < 1e-9 * max(board.square, 1e-12):
            out.append(perm)
    return out


def orient_to_robot(views: BoardViews, camera: CameraModel | None = None):
    """Each chessboard view's corner order agreed with the robot's motion.

    A chessboard's pattern turned by half a turn (a quarter, if square) looks the same, so a
    detector may number a view's corners from another corner than the next view's: its own
    pose of the board is then turned about the board's normal, and the hand-eye's equations
    (the camera's motion between two views the robot's, seen from the camera) do not hold.
    The turn angle of a motion is the same seen from the camera or from the flange: for every
    pair of views, the camera's turn (each view's own pose, OpenCV's ``calibrateCamera``, or
    PnP with ``camera``) against the robot's. Each view's order is the one whose turns agree
    with the other views' (the median mismatch), taken where the next best is clearly worse
    (``ORDER_MAX_RATIO``, ``ORDER_MIN_GAP``); the order most views came with is kept.

    Returns
    -------
    views : BoardViews
        The views with their corners renumbered where needed.
    turned : dict
        ``{view name: the turn [deg] its corners were renumbered by}``.
    """
    perms = board_turns(views.board)
    V = len(views.names)
    if len(perms) == 1 or V < 3:
        return views, {}
    import cv2

    K = len(perms)
    try:
        C = view_poses(views, camera) if camera is not None else intrinsics_start(views, False)[1]
    except (cv2.error, CalibrationRefused):  # the calibration names what is wrong with them
        return views, {}
    RC, RH = C[:, :3, :3], views.H[:, :3, :3]

    def angles(R):
        return np.linalg.norm(spatial.rotation_vector(R), axis=-1)

    robot = angles(RH[:, None] @ np.swapaxes(RH[None], -1, -2))  # (V, V)
    step = 2 * np.pi / K
    # mismatch[d, i, j]: the pair's turns with view j's order turned by d steps against i's
    mismatch = np.stack(
        [
            np.abs(
                angles(RC[:, None] @ spatial.rot_z(d * step) @ np.swapaxes(RC[None], -1, -2))
                - robot
            )
            for d in range(K)
        ]
    )
    np.einsum("dii->di", mismatch)[:] = np.nan  # a view with itself says nothing
    labels = np.zeros(V, dtype=int)
    for _ in range(20):
        # cost[t, j]: view j's order turned by t against every other view's current one
        cost = np.stack(
            [
                np.nanmedian(
                    mismatch[(t - labels[:, None]) % K, np.arange(V)[:, None], np.arange(V)[None]],
                    axis=0,
                )
                for t in range(K)
            ]
        )
        new = np.argmin(cost, axis=0)
        if np.array_equal(new, labels):
            break
        labels = new
    ranked = np.sort(cost, axis=0)
    clear = (ranked[0] <= ORDER_MAX_RATIO * ranked[1]) & (ranked[1] >= ORDER_MIN_GAP)
    labels = np.where(clear, labels, 0)
    # the order most views came with is the board's
    shift = int(np.argmax(np.bincount(labels[clear] % K, minlength=K))) if clear.any() else 0
    labels = np.where(clear, (labels - shift) % K, 0)
    if not labels.any():
        return views, {}
    corners = views.corners.copy()
    turned = {}
    for i in np.nonzero(labels)[0]:
        # the view's order is the board's turned by labels[i] steps: its corner k is the
        # board's corner perm[k] under that turn (a view's camera-to-board pose C turned: C S)
        perm = perms[labels[i]]
        corners[i, perm] = views.corners[i]
        turned[views.names[i]] = float(np.degrees(labels[i] * step))
    return replace(views, corners=corners), turned


def robot_world_start(views: BoardViews, C: np.ndarray, method: int | None = None):
    """OpenCV's robot-world hand-eye closed form: ``(T_mount_camera, T_holder_board)`` from
    each view's ``C_i = T_camera_board`` (default Shah's method)."""
    import cv2

    H = views.H
    method = cv2.CALIB_ROBOT_WORLD_HAND_EYE_SHAH if method is None else method
    R_b2w, t_b2w, R_g2c, t_g2c = cv2.calibrateRobotWorldHandEye(
        list(C[:, :3, :3]), list(C[:, :3, 3]), list(H[:, :3, :3]), list(H[:, :3, 3]), method=method
    )
    # OpenCV's results map base points to the world's (the board's) and gripper points to the
    # camera's: T_board_holder and T_camera_mount
    T_camera_mount = spatial.make_transform(R_g2c, np.ravel(t_g2c))
    T_board_holder = spatial.make_transform(R_b2w, np.ravel(t_b2w))
    return spatial.invert_transform(T_camera_mount), spatial.invert_transform(T_board_holder)


def hand_eye_start(views: BoardViews, C: np.ndarray, method: int):
    """OpenCV's hand-eye (AX = XB) closed form: ``T_mount_camera``, and the board from the
    views' mean (chordal) of ``X C_i`` through the robot."""
    import cv2

    G = spatial.invert_transform(views.H)  # "gripper to base" for eye-in-hand, its inverse else
    R_c2g, t_c2g = cv2.calibrateHandEye(
        list(G[:, :3, :3]), list(G[:, :3, 3]), list(C[:, :3, :3]), list(C[:, :3, 3]), method=method
    )
    X = spatial.make_transform(R_c2g, np.ravel(t_c2g))
    Zs = spatial.invert_transform(views.H) @ X @ C
    return X, mean_pose(Zs)


def mean_pose(T) -> np.ndarray:
    """The chordal mean of poses ``(V, 4, 4)``: rotations' projected mean, translations'
    mean."""
    U, _, Vt = np.linalg.svd(T[:, :3, :3].sum(axis=0))
    R = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
    return spatial.make_transform(R, T[:, :3, 3].mean(axis=0))


# --------------------------------------------------------------------------- the fit


def _perturbed(T0: np.ndarray, d: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = spatial.rotation_from_vector(d[:3]) @ T0[:3, :3]
    T[:3, 3] = T0[:3, 3] + d[3:]
    return T


class _Problem:
    """The reprojection residuals of ``theta`` (the 21 parameters) and, with
    ``flange_errors``, of each view's flange pose error ``e_i`` (6: a rotation vector and a
    translation in the flange's frame, ``F_i' = F_i exp(e_i)``)."""

    def __init__(self, views: BoardViews, X0: np.ndarray, Z0: np.ndarray):
        self.setup = views.setup
        self.F = views.T_base_flange
        self.H = views.H
        self.points = views.board.points
        self.seen = np.isfinite(views.corners[..., 0])
        self.observed = views.corners[self.seen]  # (M, 2)
        self.view_of = np.nonzero(self.seen)[0]
        self.X0, self.Z0 = X0, Z0

    def poses(self, theta):
        return _perturbed(self.X0, theta[9:15]), _perturbed(self.Z0, theta[15:21])

    def predicted(self, theta, flange_errors=None, F=None) -> np.ndarray:
        """The corners (V, N, 2) [px] at ``theta``; ``F`` (V, 4, 4): the flange poses instead
        of the views' (a calibrated robot's)."""
        X, Z = self.poses(theta)
        H = self.H
        if flange_errors is not None or F is not None:
            F = self.F if F is None else F
            if flange_errors is not None:
                F = _with_errors(F, flange_errors)
            H = spatial.invert_transform(F) if self.setup == EYE_IN_HAND else F
        C = spatial.invert_transform(X) @ H @ Z
        return project(theta[:9], transform_points(C, self.points))  # (V, N, 2)

    def residuals(self, theta, flange_errors=None, F=None) -> np.ndarray:
        return (self.predicted(theta, flange_errors, F)[self.seen] - self.observed).ravel()

    def jacobian(self, theta) -> np.ndarray:
        """Central differences, steps scaled to each parameter (the covariance's Jacobian)."""
        J = np.empty((2 * len(self.observed), len(theta)))
        for k, h in enumerate(_steps(theta)):
            e = np.zeros_like(theta)
            e[k] = h
            J[:, k] = (self.residuals(theta + e) - self.residuals(theta - e)) / (2 * h)
        return J


def _steps(theta) -> np.ndarray:
    """Central-difference steps: 1e-4 of a focal length or principal point, 1e-6 of a
    distortion coefficient, 1e-8 rad or m of a pose."""
    return np.r_[1e-4 * np.abs(theta[:4]), np.full(5, 1e-6), np.full(len(theta) - 9, 1e-8)]


#: the robot-error model's variance components: at most this many rounds, and done when every
#: component's factor is within this of 1
VARIANCE_ROUNDS = 8
VARIANCE_TOLERANCE = 0.02
#: the smallest flange error sigma the variance components may reach (rad, m): a robot exact
#: to the data leaves the prior rows to this
SMALLEST_FLANGE_SIGMA = (1e-8, 1e-8)
#: the step in the log of a variance component for the estimate's sensitivity to it
SIGMA_LOG_STEP = 0.05


def _huber_levenberg_marquardt(
    fun, jac, x, iterations: int = 30, scale: float = 3.0, info: dict | None = None
):
    """Minimise Huber's loss (``scale`` in the residuals' units) of ``fun`` by
    Levenberg-Marquardt on the reweighted normal equations (the unknowns are few, the
    residuals many: the normal matrix is small where a trust region's SVD of the Jacobian is
    not). Stops when a step changes the cost by less than 1e-8 of it (converged) or no step
    lowers it; ``info`` (a dict, when given) gets ``iterations`` and ``converged``."""
    if info is None:
        info = {}
    info.update(iterations=0, converged=False)

    def cost(r):
        a = np.abs(r)
        return float(np.sum(np.where(a <= scale, 0.5 * a * a, scale * a - 0.5 * scale * scale)))

    from scipy import sparse

    r = fun(x)
    c = cost(r)
    damping = 1e-3
    for _ in range(iterations):
        w = np.minimum(1.0, scale / np.maximum(np.abs(r), 1e-300))
        J = jac(x)
        if sparse.issparse(J):  # a Jacobian of mostly zeros: its normal matrix from its entries
            Jw = sparse.csr_matrix(J.multiply(w[:, None]))
            N = (J.T @ Jw).toarray()
        else:
            Jw = J * w[:, None]
            N = J.T @ Jw
        g = Jw.T @ r
        diag = np.maximum(np.diag(N), 1e-30)
        while True:
            step = np.linalg.solve(N + damping * np.diag(diag), -g)
            r_new = fun(x + step)
            c_new = cost(r_new)
            if c_new <= c:
                break
            damping *= 10.0
            if damping > 1e12:  # no step lowers the cost: a minimum to the step's precision
                info["converged"] = True
                return x
        x, r, done = x + step, r_new, c - c_new <= 1e-8 * max(c, 1e-300)
        c = c_new
        damping = max(damping / 10.0, 1e-9)
        info["iterations"] += 1
        if done:
            info["converged"] = True
            break
    return x


def _fit_flange_errors(
    problem: _Problem,
    theta0: np.ndarray,
    free: np.ndarray,
    sigma_px: float,
    correlation: np.ndarray | None = None,
    start: tuple[np.ndarray, list[float]] | None = None,
):
    """Fit the 21 parameters with each view's flange pose error as a random effect
    (``e_i ~ N(0, diag(s_r^2 I, s_t^2 I))``; with ``correlation`` (V, V) each component's
    errors over the views correlated by it), the three sigmas (pixels, flange rotation,
    flange translation) estimated by variance components (Forstner's redundancy form).
    ``start``: the errors (V, 6) and sigmas to start from.

    Returns ``theta, e (V, 6), covariances of (theta[free], e) (nf + 6 V square: the model's
    and the sandwich clustered by view), sigmas (px, rad, m), residuals (px), Huber
    weights, (moves, variances)``: how ``(theta[free], e)`` moves with the log of each of the
    three sigmas (3, nf + 6 V; a Gauss-Newton step from the solution, central differences)
    and the variances of those logs as estimated (``1 / 2r``, ``r`` each group's redundancy).
    """
    from scipy import sparse

    V = len(problem.F)
    m = 2 * len(problem.observed)
    nf = len(free)
    rows = np.repeat(problem.view_of, 2)
    sig = [max(sigma_px, 1e-6), np.radians(0.01), 1e-4] if start is None else list(start[1])
    # the prior's rows whitened: L^-1 e / sigma for each component, C = L L^T
    whiten = np.eye(V) if correlation is None else np.linalg.inv(np.linalg.cholesky(correlation))

    def split(x):
        theta = theta0.copy()
        theta[free] = x[:nf]
        return theta, x[nf:].reshape(V, 6)

    def fun(x):
        theta, e = split(x)
        r = problem.residuals(theta, e) / sig[0]
        w = whiten @ e
        return np.r_[r, (w[:, :3] / sig[1]).ravel(), (w[:, 3:] / sig[2]).ravel()]

    # the Jacobian's pattern (scipy.sparse): the corners' rows hold the 21 parameters' columns
    # and their own view's 6 error columns; the prior's rows one error component's columns
    # over the views (the whitening's triangle) - 3 % of a dense one's entries on 66 views
    views = np.arange(V)
    corner_rows = np.arange(m)
    a, b = np.nonzero(whiten)
    pattern_rows = [np.repeat(corner_rows, nf)]
    pattern_cols = [np.tile(np.arange(nf), m)]
    for j in range(6):
        pattern_rows.append(corner_rows)
        pattern_cols.append(nf + 6 * rows + j)
    for j in range(6):
        prior = m + (3 * views + j if j < 3 else 3 * V + 3 * views + j - 3)
        pattern_rows.append(prior[a])
        pattern_cols.append(nf + 6 * b + j)
    pattern = (np.concatenate(pattern_rows), np.concatenate(pattern_cols))
    shape = (m + 6 * V, nf + 6 * V)

    def jac(x):
        # forward differences (the residuals are all but linear over the steps: a focal
        # length's 1e-4, a pose's 1e-8): 28 evaluations for central differences' 54
        theta, e = split(x)
        values = []
        steps = _steps(theta)
        here = problem.residuals(theta, e)
        dense = np.empty((m, nf))
        for c, k in enumerate(free):
            d = np.zeros_like(theta)
            d[k] = steps[k]
            dense[:, c] = (problem.residuals(theta + d, e) - here) / (steps[k] * sig[0])
        values.append(dense.ravel())
        for j in range(6):  # each view's error moves its own corners only: all views at once
            d = np.zeros_like(e)
            d[:, j] = 1e-8
            values.append((problem.residuals(theta, e + d) - here) / (1e-8 * sig[0]))
        for j in range(6):
            values.append(whiten[a, b] / (sig[1] if j < 3 else sig[2]))
        return sparse.csr_matrix((np.concatenate(values), pattern), shape=shape)

    x = np.r_[theta0[free], np.zeros(6 * V) if start is None else start[0].ravel()]
    groups = [
        np.arange(m),
        m + np.arange(3 * V),
        m + 3 * V + np.arange(3 * V),
    ]
    for _ in range(VARIANCE_ROUNDS):
        x = _huber_levenberg_marquardt(fun, jac, x)
        r = fun(x)
        w = np.minimum(1.0, 3.0 / np.maximum(np.abs(r), 1e-300))
        J = sparse.csr_matrix(jac(x).multiply(np.sqrt(w)[:, None]))
        rw = r * np.sqrt(w)
        N_inv = np.linalg.inv((J.T @ J).toarray())
        leverage = np.asarray(J.multiply(J @ N_inv).sum(axis=1)).ravel()
        factors = []
        redundancies = np.array([len(g) - leverage[g].sum() for g in groups])
        for g, redundancy in zip(groups, redundancies):
            factors.append(float(rw[g] @ rw[g]) / max(redundancy, 1e-9))
        sig = [
            max(sig[0] * np.sqrt(factors[0]), 1e-6),
            max(sig[1] * np.sqrt(factors[1]), SMALLEST_FLANGE_SIGMA[0]),
            max(sig[2] * np.sqrt(factors[2]), SMALLEST_FLANGE_SIGMA[1]),
        ]
        if all(abs(f - 1.0) < VARIANCE_TOLERANCE for f in factors):
            break
    theta, e = split(x)
    residuals = problem.residuals(theta, e)
    # the sandwich clustered by view (a view's corners and its prior rows): a view's corners
    # share more than its flange error (the corners' noise is not white on real images)
    cluster = np.r_[rows, np.repeat(np.arange(V), 3), np.repeat(np.arange(V), 3)]
    by_cluster = sparse.csr_matrix(
        (np.ones(len(cluster)), (cluster, np.arange(len(cluster)))), shape=(V, len(cluster))
    )
    scores = (by_cluster @ J.multiply(rw[:, None])).toarray()
    clustered = N_inv @ (scores.T @ scores) @ N_inv * (V / max(V - 1, 1))
    # the sigmas are estimates too (a log sigma's variance 1 / 2r from r redundant residuals):
    # where the views are few, their ratio moves the fit (the prior's weight against the
    # corners') and the errors' shared part (the fold's weights: _through_robot_errors)
    moves = np.empty((3, len(x)))
    for k, g in enumerate(groups):
        step = []
        for sign in (1.0, -1.0):
            scale = np.ones(len(rw))
            scale[g] = np.exp(-sign * SIGMA_LOG_STEP)  # the rows over sigma e^(sign step)
            Js = sparse.diags(scale) @ J
            step.append(-np.linalg.solve((Js.T @ Js).toarray(), Js.T @ (rw * scale)))
        moves[k] = (step[0] - step[1]) / (2.0 * SIGMA_LOG_STEP)
    log_variances = 1.0 / (2.0 * np.maximum(redundancies, 1.0))
    return theta, e, (N_inv, clustered), sig, residuals, w[:m], (moves, log_variances)


def _through_robot_errors(
    problem: _Problem,
    theta: np.ndarray,
    free: np.ndarray,
    e: np.ndarray,
    covariances: tuple[np.ndarray, np.ndarray],
    sigmas: tuple[float, float],
    sigma_moves: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The camera and the board seen through the part of the robot's errors the views cannot
    tell from them, and each view's error without that part.

    Two fields of flange errors move every view's corners exactly as the two poses do: one
    error ``c`` shared in the flange's frame (``F exp(c)``: the flange-side pose, the camera
    eye-in-hand or the board eye-to-hand) and one ``b`` shared in the base's frame
    (``exp(b) F``: the base-side pose). Only the prior tells them apart from the poses. They
    are taken out of the errors (``(c, b)`` by least squares on the errors over their sigmas,
    to first order; then exactly: ``exp(e_i') = F_i^-1 B F_i exp(e_i) C^-1`` with
    ``B = exp(b)^-1``, ``C = exp(c)``) and put into the poses (eye-in-hand ``C X`` and
    ``B Z``, eye-to-hand ``B X`` and ``C Z``), the corners unchanged. The poses are then
    what a program on the robot's nominal poses sees, and their covariance no longer holds
    the prior's guess of those parts: it is the views' own - the fit's (``covariances`` of
    ``(theta[free], e)``, the model's and the sandwich clustered by view, carried through the
    map: :func:`_larger_covariance`), the part from which poses the views are at, and,
    with ``sigma_moves`` (:func:`_fit_flange_errors`' moves of ``(theta[free], e)`` with the
    log of each sigma - the pixels', the rotation's, the translation's - and those logs'
    variances), the part from the sigmas' own estimation error: they weigh the prior against
    the corners and the errors' components against each other in the part taken out.

    Returns ``theta', e' (V, 6), covariance of theta'[free], B, C`` (4, 4).
    """
    F = problem.F
    V, nf = len(F), len(free)
    R, p = F[:, :3, :3], F[:, :3, 3]
    RT = np.transpose(R, (0, 2, 1))
    # first order: e_i = c + Ad(F_i^-1) g, Ad(F^-1) g = (R^T g_r, R^T (g_t + g_r x p))
    G = np.zeros((V, 6, 12))
    G[:, :3, :3] = G[:, 3:, 3:6] = np.eye(3)
    G[:, :3, 6:9] = RT
    G[:, 3:, 9:] = RT
    cross_p = np.transpose(np.cross(p[:, None, :], np.eye(3)[None]), (0, 2, 1))  # [p]x
    G[:, 3:, 6:9] = -RT @ cross_p

    def weights(sigma_r, sigma_t):
        return np.r_[np.full(3, 1.0 / sigma_r), np.full(3, 1.0 / sigma_t)]

    # each pose's parameters and the pose they perturb: the flange's side and the base's
    camera, board = (slice(9, 15), problem.X0), (slice(15, 21), problem.Z0)
    flange_side, base_side = (camera, board) if problem.setup == EYE_IN_HAND else (board, camera)

    def moved(th, side, M):
        """``th`` with the pose of ``side`` (its parameters, its start) moved to ``M P``."""
        block, P0 = side
        P = M @ _perturbed(P0, th[block])
        th[block] = np.r_[spatial.rotation_vector(P[:3, :3] @ P0[:3, :3].T), P[:3, 3] - P0[:3, 3]]

    def gauge(errors, weight):
        G_w = (G * weight[None, :, None]).reshape(6 * V, 12)
        cg = np.linalg.lstsq(G_w, (errors * weight).ravel(), rcond=None)[0]
        C, base = _with_errors(np.broadcast_to(np.eye(4), (2, 4, 4)), cg.reshape(2, 6))
        return spatial.invert_transform(base), C

    def fold(x, weight=weights(*sigmas)):
        th = theta.copy()
        th[free] = x[:nf]
        errors = x[nf:].reshape(V, 6)
        B, C = gauge(errors, weight)
        E = spatial.invert_transform(F) @ B @ _with_errors(F, errors) @ spatial.invert_transform(C)
        # eye-in-hand: X^-1 (F E)^-1 Z = (C X)^-1 (F E')^-1 (B Z); eye-to-hand: X^-1 F E Z =
        # (B X)^-1 F E' (C Z)
        moved(th, flange_side, C)
        moved(th, base_side, B)
        e_folded = np.c_[spatial.rotation_vector(E[:, :3, :3]), E[:, :3, 3]]
        return np.r_[th[free], e_folded.ravel()]

    x = np.r_[theta[free], e.ravel()]
    folded = fold(x)
    B, C = gauge(e, weights(*sigmas))
    # the map's Jacobian by central differences (the errors are small: 1e-9 steps)
    A = np.empty((len(x), len(x)))
    for k in range(len(x)):
        d = np.zeros_like(x)
        d[k] = 1e-9
        A[:, k] = (fold(x + d) - fold(x - d)) / 2e-9
    theta_folded = theta.copy()
    theta_folded[free] = folded[:nf]
    e_folded = folded[nf:].reshape(V, 6)
    # the views a sample of the robot's poses: the part taken out depends on which were drawn.
    # Each view's remaining error its own draw (the sandwich of the least squares over views,
    # 12 unknowns off the 6 V errors' degrees of freedom), its second moment the estimate's
    # square and its uncertainty (the estimates alone are shrunk toward 0 by the prior)
    model, clustered = (A @ c @ A.T for c in covariances)
    A_e = A[:nf, nf:].reshape(nf, V, 6)
    blocks = model[nf:, nf:].reshape(V, 6, V, 6)[np.arange(V), :, np.arange(V), :]
    moments = np.einsum("vk,vl->vkl", e_folded, e_folded) + blocks
    sampling = np.einsum("avk,vkl,bvl->ab", A_e, moments, A_e) * (6 * V / max(6 * V - 12, 1))
    cov = _larger_covariance(model[:nf, :nf], clustered[:nf, :nf], V) + sampling
    if sigma_moves is not None:
        moves, log_variances = sigma_moves
        sensitivity = moves @ A[:nf].T  # (3, nf): through the fit
        for k in (1, 2):  # and through the fold's weights (the flange errors' sigmas)
            d = np.zeros(2)
            d[k - 1] = SIGMA_LOG_STEP
            plus = fold(x, weights(*(np.asarray(sigmas) * np.exp(d))))
            minus = fold(x, weights(*(np.asarray(sigmas) * np.exp(-d))))
            sensitivity[k] += (plus - minus)[:nf] / (2.0 * SIGMA_LOG_STEP)
        cov = cov + np.einsum("ka,k,kb->ab", sensitivity, log_variances, sensitivity)
    return theta_folded, e_folded, cov, B, C


def _larger_covariance(P: np.ndarray, Q: np.ndarray, clusters: int) -> np.ndarray:
    """``P`` (n, n), the model's covariance, each parameter's variance raised to that of
    ``Q``, a sandwich clustered over ``clusters`` groups, where ``Q``'s is larger beyond its
    own sampling error (the ratio over the 95 % point of a chi-square of ``clusters - 1``
    degrees of freedom over them: 1.59 for 20 views); ``P``'s correlations kept.

    Where the model holds, the sandwich of few clusters scatters about it; taking the larger
    of the two everywhere would make the sigmas too large by that scatter."""
    from scipy.stats import chi2

    threshold = chi2.ppf(0.95, max(clusters - 1, 1)) / max(clusters - 1, 1)
    ratio = np.diag(Q) / np.diag(P)
    scale = np.sqrt(np.where(ratio > threshold, ratio, 1.0))
    return P * np.outer(scale, scale)


def _pixel_noise(views: BoardViews, camera: CameraModel, C: np.ndarray, fixed: bool) -> float:
    """The corners' noise per coordinate [px] in the views' own pictures of the board: the
    residuals of each view's own pose ``C`` (V, 4, 4) with ``camera``'s intrinsics (OpenCV's
    ``calibrateCamera``), 6 unknowns a view (and the 9 intrinsics unless ``fixed``) off the
    degrees of freedom. No robot pose enters: its errors are not in it."""
    d = project(camera.intrinsics, transform_points(C, views.board.points)) - views.corners
    seen = np.isfinite(d[..., 0])
    dof = 2 * int(seen.sum()) - 6 * len(C) - (0 if fixed else 9)
    return float(np.sqrt(np.sum(d[seen] ** 2) / max(dof, 1)))


def calibrate_views(
    views: BoardViews,
    fix_intrinsics: bool = False,
    start: str = "shah",
    flange_errors: bool | None = False,
) -> CameraCalibration:
    """Calibrate the camera from board views: intrinsics, ``T_mount_camera``,
    ``T_holder_board``.

    Parameters
    ----------
    views : BoardViews
        Views with the board found (each at least 6 corners seen).
    fix_intrinsics : bool
        Keep the camera's intrinsics as given (hand-eye and board only).
    start : str
        ``shah`` or ``li`` (OpenCV's robot-world methods) for the start.
    flange_errors : bool or None
        Give each view's flange pose an error of its own (a random effect whose sigmas, with
        the pixels', are estimated from the data): the intrinsics then come from each view's
        own picture of the board, not bent to absorb the robot's pose errors, and the sigmas
        include those errors. Without it the robot's poses are taken as exact and the
        parameters fit the corners as predicted through the robot (the sigmas clustered by
        view). None: chosen by the data - the flange errors where the exact-robot fit's
        corners are more than :data:`ROBOT_ERRORS_DOMINATE` times as far off as each view's
        own picture's (``exact_ratio``). ``docs/vision.md`` compares the two on real data.

    Raises
    ------
    CalibrationRefused
        Too few views, a degenerate motion, or an estimate the views leave undetermined.
    """
    import cv2
    from scipy.optimize import least_squares

    check_motion(views)
    if fix_intrinsics:
        camera0 = views.camera
        C = view_poses(views, camera0)
    else:
        camera0, C = intrinsics_start(views, use_guess=views.camera.fx > 0)
    method = {
        "shah": cv2.CALIB_ROBOT_WORLD_HAND_EYE_SHAH,
        "li": cv2.CALIB_ROBOT_WORLD_HAND_EYE_LI,
    }[start]
    X0, Z0 = robot_world_start(views, C, method)
    problem = _Problem(views, X0, Z0)
    theta0 = np.r_[camera0.intrinsics, np.zeros(12)]
    free = np.arange(9 if fix_intrinsics else 0, 21)

    def fun(x):
        theta = theta0.copy()
        theta[free] = x
        return problem.residuals(theta)

    first = least_squares(fun, theta0[free], method="lm", x_scale="jac")
    r = first.fun.reshape(-1, 2)
    # a robust sigma from the corners' residual lengths (Rayleigh: median = 1.1774 sigma)
    sigma_robust = float(np.median(np.linalg.norm(r, axis=1)) / 1.1774)
    final = least_squares(
        fun,
        first.x,
        loss="huber",
        f_scale=3.0 * max(sigma_robust, 1e-6),
        x_scale="jac",
        method="trf",
    )
    theta = theta0.copy()
    theta[free] = final.x
    res = problem.residuals(theta)
    J = problem.jacobian(theta)[:, free]
    # Huber's weights on each residual: the covariance of the reweighted problem
    f = 3.0 * max(sigma_robust, 1e-6)
    w = np.minimum(1.0, f / np.maximum(np.abs(res), 1e-300))
    Jw, rw = J * np.sqrt(w)[:, None], res * np.sqrt(w)
    m, n = len(rw), len(free)
    s2 = float(rw @ rw) / max(m - n, 1)
    A = Jw.T @ Jw
    try:
        A_inv = np.linalg.inv(A)
    except np.linalg.LinAlgError as exc:
        raise CalibrationRefused("the views leave the estimate undetermined") from exc
    cond = np.linalg.cond(A * np.outer(1 / np.sqrt(np.diag(A)), 1 / np.sqrt(np.diag(A))))
    if not np.isfinite(cond) or cond > 1e14:
        raise CalibrationRefused(
            f"the views leave the estimate undetermined (normal matrix's condition {cond:.3g})"
        )
    # the exact fit's corners against each view's own picture's: the data's choice of model
    # (pictures as exact as rendered ones' taken as 0.01 px: no robot error to model there)
    pixel_noise = _pixel_noise(views, camera0, C, fix_intrinsics)
    d = problem.predicted(theta) - views.corners
    exact_rms = float(np.sqrt(np.nanmean(np.sum(d * d, axis=-1))))
    exact_ratio = exact_rms / max(float(np.sqrt(2.0) * pixel_noise), 0.01)
    model_chosen = flange_errors is None
    if model_chosen:
        flange_errors = exact_ratio > ROBOT_ERRORS_DOMINATE
    flange_sigma = None
    errors = None
    field_ = None
    if flange_errors:
        theta, errors, fit_covariances, sig, res, w, sigma_moves = _fit_flange_errors(
            problem, theta, free, sigma_robust
        )
        # the errors' correlation over the poses, from the independent fit's errors; then the
        # fit again with it (a robot's errors are mostly its kinematics': alike at near poses)
        F = views.T_base_flange
        lever, length, share = fit_error_correlation(
            F, np.c_[errors[:, :3] / sig[1], errors[:, 3:] / sig[2]]
        )
        if share > 0.0:
            prior = FlangeErrorField(lever, length, share, F, errors).prior()
            theta, errors, fit_covariances, sig, res, w, sigma_moves = _fit_flange_errors(
                problem, theta, free, sig[0], correlation=prior, start=(errors, sig)
            )
        theta, folded, cov_flange, B_shared, C_shared = _through_robot_errors(
            problem, theta, free, errors, fit_covariances, (sig[1], sig[2]), sigma_moves
        )
        field_ = FlangeErrorField(lever, length, share, F, errors, B_shared, C_shared)
        errors = folded
        flange_sigma = (float(sig[1]), float(sig[2]))
        J = problem.jacobian(theta)[:, free]
        Jw = J * np.sqrt(w)[:, None]
        A_inv = np.linalg.inv(Jw.T @ Jw)
        s2 = float(sig[0]) ** 2
    # the sandwich clustered by view: a view's residuals share its robot pose's error
    view_of_residual = np.repeat(problem.view_of, 2)
    V = len(views.names)
    scores = np.zeros((V, n))
    np.add.at(scores, view_of_residual, Jw * rw[:, None])
    meat = scores.T @ scores * (V / max(V - 1, 1)) * ((m - 1) / max(m - n, 1))
    cov_free = A_inv @ meat @ A_inv if errors is None else cov_flange
    covariance = np.zeros((21, 21))
    covariance_pixels = np.zeros((21, 21))
    covariance[np.ix_(free, free)] = cov_free
    covariance_pixels[np.ix_(free, free)] = s2 * A_inv
    X, Z = problem.poses(theta)
    d = problem.predicted(theta) - views.corners
    per_corner = np.sum(d * d, axis=-1)
    view_rms = np.sqrt(np.nanmean(per_corner, axis=1))
    camera = views.camera.with_intrinsics(theta[:9])
    return CameraCalibration(
        setup=views.setup,
        camera=camera,
        T_mount_camera=X,
        T_holder_board=Z,
        covariance=covariance,
        covariance_pixels=covariance_pixels,
        sigma0=float(np.sqrt(s2)),
        rms=float(np.sqrt(np.nanmean(per_corner))),
        view_rms=view_rms,
        names=views.names,
        observations=int(len(problem.observed)),
        downweighted=int(np.count_nonzero(w < 1.0)),
        start={
            "camera": camera0,
            "T_mount_camera": X0,
            "T_holder_board": Z0,
            "pixel_noise": pixel_noise,
        },
        flange_sigma=flange_sigma,
        flange_errors=errors,
        flange_field=field_,
        exact_ratio=exact_ratio,
        model_chosen=model_chosen,
    )


def joint_errors_determined(
    robot: RobotModel, J_camera: np.ndarray, J_joints: np.ndarray, sigma: float
) -> tuple[list[int], dict[int, float], np.ndarray]:
    """The robot's joint-frame parameters that corners determine beside the camera's: decided
    as ``calibrate-robot`` decides it (:func:`~rworld_cli.calibration.robot.select`, in its
    order) on the joints' Jacobian ``J_joints`` (R, 6 n; each column per typical error) with
    the camera's columns ``J_camera`` (R, C) projected out; ``sigma`` the rows' noise.
    Returns (taken, {let go: its sigma in typical errors}, the projected Jacobian (R, 6 n))."""
    from ..calibration.robot import preference, select

    basis, _ = np.linalg.qr(J_camera)
    J = J_joints - basis @ (basis.T @ J_joints)
    order = [k for k in preference(robot) if k < J_joints.shape[1]]
    chosen, dropped = select(J, order, sigma)
    return chosen, dropped, J


def calibrate_views_with_robot(
    views: BoardViews,
    robot: RobotModel,
    joints: np.ndarray,
    fix_intrinsics: bool = False,
    iterations: int = 50,
) -> CameraCalibration:
    """Intrinsics, hand-eye, the board's place and the robot's own kinematic errors in one
    bundle adjustment on the reprojection errors.

    Each view's flange pose is the robot's at its joint values, ``F_i = T_base_flange(p,
    q_i)`` (:meth:`RobotModel.poses`: the joint frames' small pose errors ``p``, 6 a joint),
    not the controller's; the corners are seen at ``project(intrinsics, X^-1 H_i(p) Z)``.
    The start is the exact-robot fit (:func:`calibrate_views` with the nominal ``F_i``); the
    noise is that of the views' own pictures of the board (``calibrateCamera``'s rms
    reprojection, per coordinate). Which robot parameters the views determine is decided as
    ``calibrate-robot`` decides it (:func:`~rworld_cli.calibration.robot.select`, in its
    order, 1 mm / 1 mrad the typical error) on the Jacobian with the camera's 21 (or 12)
    parameters projected out: a joint-1 error the board's pose absorbs, a tilt a chain's
    other joints hold, stays nominal and is listed. The target's own offset is not estimated
    (it is ``X``'s). Levenberg-Marquardt on Huber's loss (3 sigmas), then the covariance
    ``s^2 (J^T W J)^-1`` of every parameter together, ``s`` the residuals' a-posteriori sigma
    (scaled up only: never below the pictures' noise).

    Parameters
    ----------
    views : BoardViews
        Views with the board found; their ``T_base_flange`` the nominal robot's at ``joints``
        (the start's).
    robot : RobotModel
        The flange frame (the camera's mount, or the board's holder eye-to-hand) on its link,
        6-DoF (``R_link_target`` set), in the robot's base (``T_frame_base`` the identity).
    joints : ndarray, shape (V, n)
        Each view's joint values [rad or m].

    Returns
    -------
    CameraCalibration
        With ``robot`` set; ``covariance`` the camera's 21 parameters' block of the joint
        covariance.

    Raises
    ------
    CalibrationRefused
        As :func:`calibrate_views`.
    """
    from ..calibration.robot import Unidentifiable, observability_index

    exact = calibrate_views(views, fix_intrinsics=fix_intrinsics)
    noise = max(float(exact.start["pixel_noise"]), 1e-6)
    problem = _Problem(views, exact.T_mount_camera, exact.T_holder_board)
    theta0 = np.r_[exact.camera.intrinsics, np.zeros(12)]
    free = np.arange(9 if fix_intrinsics else 0, 21)
    nf = len(free)
    P = len(robot.names)
    scales = robot.scales
    n6 = 6 * robot.device.dof
    joints = np.asarray(joints, dtype=float)

    def flanges(p):
        return robot.poses(p, joints)

    def split(x):
        theta = theta0.copy()
        theta[free] = x[:nf]
        p = np.zeros(P)
        p[taken] = x[nf:] * scales[taken]
        return theta, p

    def fun(x):
        theta, p = split(x)
        return problem.residuals(theta, F=flanges(p)) / noise

    def jacobian(theta, p, columns) -> np.ndarray:
        """d residuals / d [theta[free], p[columns] / scale] [px per unit]."""
        F = flanges(p)
        out = np.empty((2 * len(problem.observed), nf + len(columns)))
        steps = _steps(theta)
        for c, k in enumerate(free):
            d = np.zeros_like(theta)
            d[k] = steps[k]
            out[:, c] = (problem.residuals(theta + d, F=F) - problem.residuals(theta - d, F=F)) / (
                2 * steps[k]
            )
        for c, k in enumerate(columns):  # 1e-3 of a typical error: 1 um, 1 urad
            d = np.zeros(P)
            d[k] = 1e-3 * scales[k]
            up = problem.residuals(theta, F=flanges(p + d))
            down = problem.residuals(theta, F=flanges(p - d))
            out[:, nf + c] = (up - down) / 2e-3
        return out

    J0 = jacobian(theta0, np.zeros(P), np.arange(n6))
    chosen, dropped, J_robot = joint_errors_determined(robot, J0[:, :nf], J0[:, nf:], noise)
    taken = np.array(sorted(chosen), dtype=int)

    def scaled_jacobian(x):
        theta, p = split(x)
        return jacobian(theta, p, taken) / noise

    fit: dict = {}
    x = _huber_levenberg_marquardt(
        fun,
        scaled_jacobian,
        np.r_[theta0[free], np.zeros(len(taken))],
        iterations=iterations,
        info=fit,
    )
    theta, p = split(x)
    F = flanges(p)
    residuals = problem.residuals(theta, F=F)
    J = jacobian(theta, p, taken)
    w = np.minimum(1.0, 3.0 * noise / np.maximum(np.abs(residuals), 1e-300))
    Jw, rw = J * np.sqrt(w)[:, None], residuals * np.sqrt(w)
    m, n = len(rw), J.shape[1]
    s2 = float(rw @ rw) / max(m - n, 1)
    factor = float(np.sqrt(s2) / noise)
    A = Jw.T @ Jw
    try:
        A_inv = np.linalg.inv(A)
    except np.linalg.LinAlgError as exc:
        raise CalibrationRefused("the views leave the estimate undetermined") from exc
    cov = max(s2, noise**2) * A_inv  # (theta[free], p[taken] / scale)
    covariance = np.zeros((21, 21))
    covariance[np.ix_(free, free)] = cov[:nf, :nf]
    covariance_pixels = covariance.copy()
    robot_cov = np.zeros((P, P))
    robot_cov[np.ix_(taken, taken)] = cov[nf:, nf:] * np.outer(scales[taken], scales[taken])
    cross = np.zeros((21, P))
    cross[np.ix_(free, taken)] = cov[:nf, nf:] * scales[taken]
    names = robot.names
    before = problem.residuals(theta0, F=flanges(np.zeros(P))).reshape(-1, 2)
    device, _, T = robot.apply(p)
    robot_result = RobotCalibration(
        robot,
        p,
        np.sqrt(np.maximum(np.diag(robot_cov), 0.0)),
        robot_cov,
        len(taken),
        [
            Unidentifiable([(names[k], 1.0)], dropped.get(k, float("inf")))
            for k in range(n6)
            if k not in taken
        ],
        observability_index(J_robot[:, taken], len(joints)),
        residuals.reshape(-1, 2),
        before,
        int(fit["iterations"]),
        device,
        T,
        noise,
        taken,
        bool(fit["converged"]),
        factor,
    )
    d = problem.predicted(theta, F=F) - views.corners
    per_corner = np.sum(d * d, axis=-1)
    X, Z = problem.poses(theta)
    return CameraCalibration(
        setup=views.setup,
        camera=views.camera.with_intrinsics(theta[:9]),
        T_mount_camera=X,
        T_holder_board=Z,
        covariance=covariance,
        covariance_pixels=covariance_pixels,
        sigma0=float(np.sqrt(s2)),
        rms=float(np.sqrt(np.nanmean(per_corner))),
        view_rms=np.sqrt(np.nanmean(per_corner, axis=1)),
        names=views.names,
        observations=int(len(problem.observed)),
        downweighted=int(np.count_nonzero(w < 1.0)),
        start=exact.start,
        robot=robot_result,
        robot_cross=cross,
    )


# --------------------------------------------------------------------------- checks on views


def pictures_rms(result: CameraCalibration) -> float | None:
    """The fitted views' corners against each view's own pose of the board (OpenCV's
    ``calibrateCamera``: no robot pose in it), rms a corner [px]: the corners' own noise."""
    noise = result.start.get("pixel_noise")
    return None if noise is None else float(np.sqrt(2.0) * noise)


def reprojection_rms(result_camera: CameraModel, X, Z, views: BoardViews) -> float:
    """RMS [px] of the corners predicted through the robot (``X^-1 H_i Z``, the intrinsics)
    against the detected ones - any method's estimate on any views."""
    C = spatial.invert_transform(X) @ views.H @ Z
    d = project(result_camera.intrinsics, transform_points(C, views.board.points)) - views.corners
    return float(np.sqrt(np.nanmean(np.sum(d * d, axis=-1))))


def axxb_residuals(X, views: BoardViews, C: np.ndarray) -> tuple[float, float]:
    """RMS rotation [rad] and translation [m] of ``A X`` against ``X B`` over every pair of
    views: ``A`` the mount's motion between them (``H_i H_j^-1``), ``B`` the camera's
    (``C_i C_j^-1``, from each view's own PnP)."""
    H = views.H
    i, j = np.triu_indices(len(H), 1)
    A = H[i] @ spatial.invert_transform(H[j])
    B = C[i] @ spatial.invert_transform(C[j])
    # the mount's motion seen from the camera, X^-1 A X, against the camera's own, B
    lhs = spatial.invert_transform(X)[None] @ A @ X[None]
    E = spatial.invert_transform(lhs) @ B
    dr = np.linalg.norm(spatial.rotation_vector(E[:, :3, :3]), axis=1)
    dt = np.linalg.norm(lhs[:, :3, 3] - B[:, :3, 3], axis=1)
    return float(np.sqrt(np.mean(dr**2))), float(np.sqrt(np.mean(dt**2)))
