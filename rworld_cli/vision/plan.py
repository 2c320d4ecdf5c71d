"""Views to calibrate a camera from: candidate camera poses around a board, each view's
information about the calibration's 21 parameters, and the D-optimal choice of N
(``docs/vision.md``)."""

from __future__ import annotations

import numpy as np

from .. import spatial
from ..model.vision import BoardModel, CameraModel
from .calibrate import BoardViews, _Problem
from .emulate import look_at


def camera_candidates(
    rng: np.random.Generator,
    board: BoardModel,
    count: int,
    distance: tuple[float, float],
    tilt: float,
    roll: float,
) -> np.ndarray:
    """``count`` camera poses in the board's frame, ``T_board_camera`` (count, 4, 4) [m]: each
    looks at a point near the board's centre from the printed side (-z), from a direction
    within ``tilt`` [rad] of the board's normal, at a distance in ``distance`` [m], turned
    about its axis by up to ``roll`` [rad]."""
    centre = board.centre
    span = board.span
    out = np.empty((count, 4, 4))
    for k in range(count):
        t = tilt * np.sqrt(rng.uniform())
        a = rng.uniform(0, 2 * np.pi)
        d = rng.uniform(*distance)
        direction = np.array([np.sin(t) * np.cos(a), np.sin(t) * np.sin(a), -np.cos(t)])
        aim = centre + rng.normal(0, 0.15 * span, 3) * [1, 1, 0]
        T = look_at(aim + d * direction, aim, up=(0.0, -1.0, 0.0))
        out[k] = T @ spatial.make_transform(spatial.rot_z(rng.uniform(-roll, roll)))
    return out


#: the spread of the candidates drawn around a chosen view: a turn about each of the camera's
#: axes [rad] and a shift along each, as a fraction of the candidates' middle distance
REFINE_TURN = np.radians(4.0)
REFINE_SHIFT = 0.05
#: the rounds the candidates around the choice are drawn in, each around the last choice
REFINE_ROUNDS = 2


def refined_candidates(
    rng: np.random.Generator,
    board: BoardModel,
    chosen: np.ndarray,
    count: int,
    distance: tuple[float, float],
    tilt: float,
) -> np.ndarray:
    """About ``count`` camera poses near the chosen ones ``chosen`` (K, 4, 4)
    (``T_board_camera``) [m]: each turned about its own axes by N(0, :data:`REFINE_TURN`) and
    shifted by N(0, :data:`REFINE_SHIFT` x the middle distance), kept where it still looks at
    the board's printed side within ``tilt`` [rad] of its normal from within ``distance`` [m]
    of its centre (the first candidates' bounds). Shape (<= count, 4, 4)."""
    per = max(1, int(np.ceil(count / len(chosen))))
    base = np.repeat(chosen, per, axis=0)
    turn = spatial.rotation_from_vector(rng.normal(0.0, REFINE_TURN, (len(base), 3)))
    shift = rng.normal(0.0, REFINE_SHIFT * float(np.mean(distance)), (len(base), 3))
    out = base.copy()
    out[:, :3, :3] = base[:, :3, :3] @ turn
    out[:, :3, 3] = base[:, :3, 3] + np.einsum("kij,kj->ki", base[:, :3, :3], shift)
    axis = out[:, :3, 2]  # the optical axis in the board's frame: toward +z from the -z side
    away = np.linalg.norm(out[:, :3, 3] - board.centre, axis=1)
    keep = (
        (np.arccos(np.clip(axis[:, 2], -1.0, 1.0)) <= tilt)
        & (out[:, 2, 3] < 0.0)
        & (away >= distance[0])
        & (away <= distance[1])
    )
    return out[keep][:count]


def view_information(
    camera: CameraModel,
    board: BoardModel,
    X: np.ndarray,
    Z: np.ndarray,
    T_base_flange: np.ndarray,
    sigma_px: float,
    setup: str = "eye-in-hand",
) -> np.ndarray:
    """Each view's whitened Jacobian of its corners' pixels by the calibration's 21
    parameters (``calibrate.PARAMETER_NAMES``) at the nominal values: shape (M, 2N, 21); a
    view's information is ``G_k^T G_k`` (px / sigma_px).

    ``X`` is the camera in its mount and ``Z`` the board in its holder (4, 4) [m]: eye-in-hand
    ``T_flange_camera`` and ``T_base_board``, eye-to-hand ``T_base_camera`` and
    ``T_flange_board``; ``T_base_flange`` (M, 4, 4) the flange at each view."""
    from .emulate import seen_corners

    H = spatial.invert_transform(T_base_flange) if setup == "eye-in-hand" else T_base_flange
    C = spatial.invert_transform(X) @ H @ Z
    corners = seen_corners(camera, board, C)
    views = BoardViews(board, camera, setup, tuple(map(str, range(len(C)))),
                       T_base_flange, np.nan_to_num(corners, nan=0.0))  # fmt: skip
    problem = _Problem(views, X, Z)
    theta = np.r_[camera.intrinsics, np.zeros(12)]
    J = problem.jacobian(theta) / sigma_px  # (M * 2N, 21), view by view
    return J.reshape(len(C), -1, J.shape[1])


def robot_information(
    camera: CameraModel,
    board: BoardModel,
    X: np.ndarray,
    Z: np.ndarray,
    robot,
    joints: np.ndarray,
    sigma_px: float,
    setup: str = "eye-in-hand",
) -> np.ndarray:
    """Each view's whitened Jacobian of its corners' pixels by the robot's joint-frame errors
    (``robot``: a :class:`~rworld_cli.calibration.robot.RobotModel` whose target is the frame
    on the flange; its first ``6 n`` parameters, each in units of its typical error, 1 mm or
    1 mrad) at the nominal robot and the nominal ``X`` and ``Z`` (as in
    :func:`view_information`), the views at ``joints`` (M, n): shape (M, 2N, 6 n)."""
    n6 = 6 * robot.device.dof
    P = len(robot.names)
    F0 = robot.poses(np.zeros(P), joints)
    # only predicted corners are differenced: any observed corners (every one seen) serve
    observed = np.zeros((len(joints), board.points.shape[0], 2))
    views = BoardViews(board, camera, setup, tuple(map(str, range(len(joints)))), F0, observed)
    problem = _Problem(views, X, Z)
    theta = np.r_[camera.intrinsics, np.zeros(12)]
    scales = robot.scales
    out = np.empty((len(joints), 2 * board.points.shape[0], n6))
    for k in range(n6):  # 1e-3 of a typical error: 1 um, 1 urad (calibrate's step)
        d = np.zeros(P)
        d[k] = 1e-3 * scales[k]
        up = problem.predicted(theta, F=robot.poses(d, joints))
        down = problem.predicted(theta, F=robot.poses(-d, joints))
        out[:, :, k] = (up - down).reshape(len(joints), -1) / (2e-3 * sigma_px)
    return out


def place_weight(
    camera: CameraModel,
    X: np.ndarray,
    Z: np.ndarray,
    robot,
    joints: np.ndarray,
    columns: np.ndarray,
    lever: float,
    setup: str = "eye-in-hand",
) -> np.ndarray:
    """The weight ``W`` (21 + C, 21 + C) whose ``trace(W Cov)`` is the mean, over the robot at
    ``joints`` (K, n), of the camera-to-board pose's predicted squared error: its position's
    variance plus its rotation's times ``lever`` squared [m^2] - ``Cov`` the covariance of
    the calibration's 21 parameters and the robot's parameters ``columns`` (C, in units of
    their typical errors). The pose a program on that robot meets: the camera in the board's
    frame through the robot's flange (``Z^-1 H(q)^-1 X``; the place of bench/vision.py's
    sections 7)."""
    from .calibrate import _perturbed, _steps

    P = len(robot.names)
    theta0 = np.r_[camera.intrinsics, np.zeros(12)]

    nominal = robot.poses(np.zeros(P), joints)

    def place(theta, p=None):  # the camera in the board's frame (K, 4, 4); X, Z moved as the fit's
        Xt, Zt = _perturbed(X, theta[9:15]), _perturbed(Z, theta[15:21])
        F = nominal if p is None else robot.poses(p, joints)
        H_inv = F if setup == "eye-in-hand" else spatial.invert_transform(F)
        return spatial.invert_transform(Zt) @ H_inv @ Xt

    base = place(theta0)

    def moved(T):  # (K, 6): the position's change, the rotation's (times the lever) [m]
        turn = spatial.rotation_vector(np.swapaxes(base[:, :3, :3], 1, 2) @ T[:, :3, :3])
        return np.hstack([T[:, :3, 3] - base[:, :3, 3], lever * turn])

    n = 21 + len(columns)
    L = np.zeros((len(joints), 6, n))
    steps = _steps(theta0)
    for k in range(9, 21):  # the intrinsics move no pose
        d = np.zeros(21)
        d[k] = steps[k]
        L[:, :, k] = (moved(place(theta0 + d)) - moved(place(theta0 - d))) / (2 * steps[k])
    for c, k in enumerate(columns):
        d = np.zeros(P)
        d[k] = 1e-3 * robot.scales[k]
        L[:, :, 21 + c] = (moved(place(theta0, d)) - moved(place(theta0, -d))) / 2e-3
    return np.einsum("kai,kaj->ij", L, L) / len(joints)


def _covariance(G: np.ndarray, ridge: float) -> np.ndarray:
    N = np.einsum("kai,kaj->ij", G, G)
    return np.linalg.inv(N + ridge * np.eye(N.shape[0]))


def camera_sigma(G: np.ndarray, ridge: float = 0.0) -> tuple[float, float]:
    """The predicted sigma of the camera in its mount (the flange, or the base) from views
    ``G`` (K, 2N, 21): its position's (root of the translation block's trace) [m] and its
    rotation's [rad]."""
    cov = _covariance(G, ridge)
    return float(np.sqrt(np.trace(cov[12:15, 12:15]))), float(np.sqrt(np.trace(cov[9:12, 9:12])))


def _criterion(covariances: np.ndarray, lever: float) -> np.ndarray:
    """The camera-in-flange pose's expected squared error (..., 21, 21) -> (...): its
    position's variance plus its rotation's, times ``lever`` squared (a point that far away
    moves by the angle times it) [m^2]."""
    position = np.trace(covariances[..., 12:15, 12:15], axis1=-2, axis2=-1)
    rotation = np.trace(covariances[..., 9:12, 9:12], axis1=-2, axis2=-1)
    return position + lever**2 * rotation


def _ridge(info: np.ndarray) -> np.ndarray:
    """A ridge that keeps sums of the views' information ``info`` (M, P, P) invertible."""
    scale = float(np.mean(np.trace(info, axis1=1, axis2=2))) / info.shape[1]
    return 1e-9 * scale * np.eye(info.shape[1])


def _covariance_of(info: np.ndarray, ridge: np.ndarray, chosen) -> np.ndarray:
    """The inverse of the views ``chosen``'s summed information (of ``info`` (M, P, P))."""
    return np.linalg.inv(ridge + info[chosen].sum(axis=0))


def weighted_error(G: np.ndarray, chosen: np.ndarray, weight: np.ndarray) -> float:
    """The root of ``trace(weight Cov)`` [m] for the views ``chosen`` of ``G`` (M, 2N, P),
    ``Cov`` their information's inverse (with :func:`select_views`' ridge)."""
    info = np.einsum("kai,kaj->kij", G, G)
    cov = _covariance_of(info, _ridge(info), chosen)
    return float(np.sqrt(np.einsum("ij,ji->", cov, weight)))


def select_views(
    G: np.ndarray,
    count: int,
    seed: int = 0,
    lever: float = 0.3,
    passes: int = 8,
    random_from: int | None = None,
    weight: np.ndarray | None = None,
) -> tuple[np.ndarray, dict]:
    """``count`` of the candidates' views: greedily D-optimal (the determinant of the 21
    parameters' information) until the information is whole, then exchanges that lower the
    camera-in-flange pose's predicted error (:func:`_criterion`, ``lever`` [m]) most; and the
    choice's predicted sigma against random choices of as many from the first
    ``random_from`` views (default all: the ones after are candidates drawn around an earlier
    choice, not views a user would draw).

    ``weight`` (P, P): the views' Jacobians ``G`` (M, 2N, P) hold more parameters than the
    camera's 21 (the robot's, :func:`robot_information`), and the exchanges lower
    ``trace(weight Cov)`` instead (:func:`place_weight`: the camera-to-board pose's error at
    the robot's poses); ``error`` and ``random_error`` are its root.

    Returns
    -------
    chosen : ndarray of int, shape (count,)
    figures : dict
        ``error`` (the camera-in-flange pose's predicted error at a point ``lever`` ahead,
        root of :func:`_criterion`, m) and ``random_error`` (the median of 50 random choices'
        of as many); ``position`` and ``rotation`` (the choice's predicted sigmas, m and rad),
        ``random_position`` and ``random_rotation`` (the random choices' medians),
        ``d_optimal_position`` and ``d_optimal_rotation`` (the greedy D-optimal choice's,
        before the exchanges).
    """
    M = len(G)
    info = np.einsum("kai,kaj->kij", G, G)  # (M, 21, 21)
    ridge = _ridge(info)
    total = ridge.copy()
    chosen: list[int] = []
    free = np.ones(M, dtype=bool)
    for _ in range(count):
        score = np.linalg.slogdet(total[None] + info)[1]
        score[~free] = -np.inf
        best = int(np.argmax(score))
        chosen.append(best)
        free[best] = False
        total = total + info[best]
    d_optimal_choice = list(chosen)

    def criterion(covariances):
        if weight is None:
            return _criterion(covariances, lever)
        return np.einsum("...ij,ji->...", covariances, weight)

    for _ in range(passes):  # exchanges: a chosen view for the one that lowers the error most
        improved = False
        for slot in range(count):
            rest = total - info[chosen[slot]]
            error = criterion(np.linalg.inv(rest[None] + info))
            error[~free] = np.inf
            error[chosen[slot]] = criterion(np.linalg.inv(rest + info[chosen[slot]]))
            best = int(np.argmin(error))
            if best != chosen[slot] and error[best] < error[chosen[slot]] * (1 - 1e-9):
                free[chosen[slot]], free[best] = True, False
                chosen[slot] = best
                improved = True
            total = rest + info[chosen[slot]]
        if not improved:
            break
    rng = np.random.default_rng(seed)
    pool = M if random_from is None else random_from
    picks = [rng.choice(pool, count, replace=False) for _ in range(50)]
    if weight is None:
        d_optimal = camera_sigma(G[d_optimal_choice])
        position, rotation = camera_sigma(G[chosen])
        draws = [camera_sigma(G[pick]) for pick in picks]
        error = float(np.hypot(position, lever * rotation))
        errors = [float(np.hypot(p, lever * r)) for p, r in draws]
    else:  # the robot's parameters beside the camera's: the same ridge as the exchanges'

        def covariance(pick):
            return _covariance_of(info, ridge, pick)

        def sigmas(cov):
            return float(np.sqrt(np.trace(cov[12:15, 12:15]))), float(
                np.sqrt(np.trace(cov[9:12, 9:12]))
            )

        cov = covariance(chosen)
        position, rotation = sigmas(cov)
        error = float(np.sqrt(criterion(cov)))
        covs = [covariance(pick) for pick in picks]
        draws = [sigmas(c) for c in covs]
        errors = [float(np.sqrt(criterion(c))) for c in covs]
        d_optimal = sigmas(covariance(d_optimal_choice))
    figures = {
        "lever": lever,
        "error": error,
        "random_error": float(np.median(errors)),
        "position": position,
        "rotation": rotation,
        "random_position": float(np.median([d[0] for d in draws])),
        "random_rotation": float(np.median([d[1] for d in draws])),
        "d_optimal_position": d_optimal[0],
        "d_optimal_rotation": d_optimal[1],
    }
    return np.array(chosen), figures
