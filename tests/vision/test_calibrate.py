"""The camera's calibration: on the real KUKA data against OpenCV's closed forms, on simulated
views against the truth and the bound, and its refusals."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from rworld_cli import spatial
from rworld_cli.model.vision import BoardModel, CameraModel
from rworld_cli.vision import calibrate as vc
from rworld_cli.vision.emulate import random_views

cv2 = pytest.importorskip("cv2")

DATA = Path(__file__).resolve().parents[1] / "data" / "vision" / "kuka2"
CAMERA = CameraModel(
    "cam", 1280, 1024, 1000.0, 1002.0, 641.0, 511.0, np.array([-0.12, 0.08, 0.0005, -0.0003, -0.02])
)
UNKNOWN = CameraModel("cam", 1280, 1024, 0.0, 0.0, 0.0, 0.0)
BOARD = BoardModel("board", "chessboard", 9, 6, 0.03)
X_TRUE = spatial.make_transform(spatial.rpy_to_matrix(np.radians([2, -3, 90])), [0.05, -0.08, 0.1])
Z_TRUE = spatial.make_transform(spatial.rpy_to_matrix(np.radians([180, 0, 30])), [0.8, 0.1, 0.02])


def _errors(result, X, Z) -> np.ndarray:
    """Estimate minus truth in the order of the parameters (px, rad, m)."""
    return np.r_[
        result.camera.intrinsics - CAMERA.intrinsics,
        spatial.rotation_vector(result.T_mount_camera[:3, :3] @ X[:3, :3].T),
        result.T_mount_camera[:3, 3] - X[:3, 3],
        spatial.rotation_vector(result.T_holder_board[:3, :3] @ Z[:3, :3].T),
        result.T_holder_board[:3, 3] - Z[:3, 3],
    ]


def _unknown(views: vc.BoardViews) -> vc.BoardViews:
    return dataclasses.replace(views, camera=UNKNOWN)


@pytest.mark.parametrize("setup", [vc.EYE_IN_HAND, vc.EYE_TO_HAND])
def test_exact_views_give_the_truth(setup):
    X, Z = X_TRUE, Z_TRUE
    if setup == vc.EYE_TO_HAND:  # a camera over the cell, the board on the flange
        X = spatial.make_transform(spatial.rpy_to_matrix(np.radians([180, 5, 0])), [0.7, 0, 1.4])
        Z = spatial.make_transform(spatial.rpy_to_matrix(np.radians([0, 0, 45])), [0, 0, 0.05])
    views = random_views(np.random.default_rng(1), CAMERA, BOARD, X, Z, 12, setup=setup)
    result = vc.calibrate_views(_unknown(views))
    e = _errors(result, X, Z)
    assert np.abs(e[:4]).max() < 1e-6 and np.abs(e[4:9]).max() < 1e-9
    assert np.abs(e[9:]).max() < 1e-9
    assert result.rms < 1e-7


def test_simulated_errors_match_the_predicted_sigma_and_the_bound():
    """16 seeds of 20 noisy views (0.3 px): each parameter's error spread against the
    pixel-noise bound (the Cramer-Rao bound of this model) and against the sigma the
    calibration reports (the clustered one)."""
    errors, bound, reported = [], [], []
    for seed in range(16):
        views = random_views(
            np.random.default_rng(100 + seed), CAMERA, BOARD, X_TRUE, Z_TRUE, 20, noise_px=0.3
        )
        result = vc.calibrate_views(_unknown(views))
        errors.append(_errors(result, X_TRUE, Z_TRUE))
        bound.append(np.sqrt(np.diag(result.covariance_pixels)))
        reported.append(result.sigma)
    spread = np.sqrt(np.mean(np.square(errors), axis=0))
    rms = lambda a: np.sqrt(np.mean(np.square(a), axis=0))  # noqa: E731
    # 16 seeds: a spread's own relative error is about 1/sqrt(32) = 18 %, so each parameter
    # lies within 0.4-1.6 of the bound (3 such errors); their mean ratio within 15 %
    ratio = spread / rms(bound)
    assert np.all((ratio > 0.4) & (ratio < 1.6)), ratio.round(2)
    assert 0.85 < np.mean(ratio) < 1.15
    assert 0.8 < np.mean(rms(reported) / rms(bound)) < 1.1


def test_the_robots_pose_errors_are_estimated_with_the_camera():
    """Views whose flange poses are off by 0.02 deg and 0.2 mm (each axis): the flange-error
    model finds those sigmas and its own sigmas hold its errors (6 seeds)."""
    truth = (np.radians(0.02), 0.2e-3)
    found, z2 = [], []
    for seed in range(6):
        views = random_views(np.random.default_rng(200 + seed), CAMERA, BOARD, X_TRUE, Z_TRUE,
                             20, noise_px=0.1, flange_noise=truth)  # fmt: skip
        result = vc.calibrate_views(_unknown(views), flange_errors=True)
        found.append(result.flange_sigma)
        # independent errors: none of a view's in its nearest view's
        assert result.flange_field.neighbour_correlation < 0.2
        z2.append((_errors(result, X_TRUE, Z_TRUE) / result.sigma) ** 2)
        assert 0.07 < result.sigma0 < 0.13
    ratio = np.mean(found, axis=0) / truth
    assert np.all((ratio > 0.75) & (ratio < 1.25)), ratio
    # the errors in their reported sigmas: a chi-square of 1 a parameter (these 6 seeds give
    # 1.65, 20 others 1.04: a seed's 21 parameters move together)
    assert 0.5 < np.mean(z2) < 1.8, np.mean(z2)


@pytest.mark.parametrize("setup", [vc.EYE_IN_HAND, vc.EYE_TO_HAND])
def test_the_shared_errors_move_into_the_poses_with_every_corner_where_it_was(setup):
    """Views' flange errors holding a large error shared in the base's frame and one in the
    flange's (1 mm and 0.1 deg each) beside their own: moved into the poses, every corner is
    predicted where it was (1e-6 px), the two found are the shared ones, and the errors left
    hold no shared part."""
    X, Z = X_TRUE, Z_TRUE
    if setup == vc.EYE_TO_HAND:
        X = spatial.make_transform(spatial.rpy_to_matrix(np.radians([180, 5, 0])), [0.7, 0, 1.4])
        Z = spatial.make_transform(spatial.rpy_to_matrix(np.radians([0, 0, 45])), [0, 0, 0.05])
    rng = np.random.default_rng(3)
    views = random_views(rng, CAMERA, BOARD, X, Z, 12, setup=setup)
    problem = vc._Problem(views, X, Z)
    theta = np.r_[CAMERA.intrinsics, np.zeros(12)]
    free = np.arange(21)
    V = len(views.names)

    def small(scale):
        return np.r_[rng.normal(0, np.radians(0.1 * scale), 3), rng.normal(0, 1e-3 * scale, 3)]

    b, c = small(1), small(1)
    E = vc._with_errors(
        np.broadcast_to(np.eye(4), (V, 4, 4)), np.array([small(0.05) for _ in range(V)])
    )
    B, C = (vc._with_errors(np.eye(4)[None], v[None])[0] for v in (b, c))
    F = views.T_base_flange
    total = spatial.invert_transform(F) @ B @ F @ E @ C  # F exp(e) = B F E C
    e = np.c_[spatial.rotation_vector(total[:, :3, :3]), total[:, :3, 3]]
    covariance = np.eye(21 + 6 * V) * 1e-8
    theta2, e2, _, B_in, C_in = vc._through_robot_errors(
        problem, theta, free, e, (covariance, covariance), (np.radians(0.005), 5e-5)
    )
    before = problem.predicted(theta, e)
    after = problem.predicted(theta2, e2)
    assert np.abs(after - before).max() < 1e-6
    # the parts found: exp(b)^-1 and exp(c), to the views' own errors' share of them
    assert np.linalg.norm(spatial.rotation_vector((B_in @ B)[:3, :3])) < np.radians(0.02)
    assert np.linalg.norm((B_in @ B)[:3, 3]) < 0.2e-3
    assert np.linalg.norm(
        spatial.rotation_vector((C_in @ spatial.invert_transform(C))[:3, :3])
    ) < np.radians(0.02)
    assert np.linalg.norm((C_in @ spatial.invert_transform(C))[:3, 3]) < 0.2e-3
    assert np.abs(e2.mean(axis=0)).max() < 0.2 * np.abs(e.mean(axis=0)).max()


@pytest.mark.parametrize("setup", [vc.EYE_IN_HAND, vc.EYE_TO_HAND])
def test_the_poses_written_hold_the_robots_errors_the_views_cannot_tell_from_them(setup):
    """A controller whose every pose is off by one error in the base's frame and one in the
    flange's (0.2 deg and 2 mm each: a base and a tool badly measured), and each view by a
    small error of its own: the flange-error model writes the camera and the board as the
    controller's poses see them (those two errors in them, within 4 sigma); the views' errors
    it reports hold neither, and with them the written poses give the corners to their noise."""
    X, Z = X_TRUE, Z_TRUE
    if setup == vc.EYE_TO_HAND:
        X = spatial.make_transform(spatial.rpy_to_matrix(np.radians([180, 5, 0])), [0.7, 0, 1.4])
        Z = spatial.make_transform(spatial.rpy_to_matrix(np.radians([0, 0, 45])), [0, 0, 0.05])
    rng = np.random.default_rng(8)
    views = random_views(rng, CAMERA, BOARD, X, Z, 20, noise_px=0.1, setup=setup,
                         flange_noise=(np.radians(0.02), 0.2e-3))  # fmt: skip
    B, C = (
        spatial.make_transform(
            spatial.rotation_from_vector(rng.normal(size=3) * np.radians(0.2 / np.sqrt(3))),
            rng.normal(size=3) * 2e-3 / np.sqrt(3),
        )
        for _ in range(2)
    )
    # the controller reports F' where the flange is at F = B F' C: through it the camera and the
    # board are (C X, B^-1 Z) eye-in-hand - X^-1 F^-1 Z = (C X)^-1 F'^-1 (B^-1 Z) - and
    # (B^-1 X, C Z) eye-to-hand
    F = spatial.invert_transform(B) @ views.T_base_flange @ spatial.invert_transform(C)
    reported = dataclasses.replace(_unknown(views), T_base_flange=F)
    B_inv = spatial.invert_transform(B)
    X_seen, Z_seen = (C @ X, B_inv @ Z) if setup == vc.EYE_IN_HAND else (B_inv @ X, C @ Z)
    result = vc.calibrate_views(reported, flange_errors=True)
    z = _errors(result, X_seen, Z_seen)[9:] / result.sigma[9:]
    assert np.all(np.abs(z) < 4), z.round(2)
    e = result.flange_errors
    # no error shared by all views is left in them (mean under 5 % of their spread)
    assert np.all(np.abs(e.mean(axis=0)) < 0.05 * e.std(axis=0)), (e.mean(axis=0), e.std(axis=0))
    E = spatial.make_transform(spatial.rotation_from_vector(e[:, :3]), e[:, 3:])
    moved = dataclasses.replace(reported, T_base_flange=F @ E)
    rms = vc.reprojection_rms(result.camera, result.T_mount_camera, result.T_holder_board, moved)
    assert rms < 0.15, rms  # 0.1 px a coordinate: 0.14 px a corner


def _views_of(name: str) -> vc.BoardViews:
    """A vendored real set's views (``tests/data/vision/NAME``), its corners as vendored."""
    from rworld_cli.api.vision import capture_views
    from rworld_cli.schema.captures import read_captures

    return capture_views(read_captures(str(DATA.parent / name / "captures.yaml")))


@pytest.fixture(scope="module")
def kuka2():
    return _views_of("kuka2")


def test_the_real_kuka_views_held_out_are_predicted_better_than_by_opencvs_methods(kuka2):
    index = np.arange(28)
    held, fit = index[3::4], np.setdiff1d(index, index[3::4])
    train, test = kuka2.subset(fit), kuka2.subset(held)
    ours = vc.calibrate_views(train)
    our_rms = vc.reprojection_rms(ours.camera, ours.T_mount_camera, ours.T_holder_board, test)
    assert our_rms < 1.3
    # OpenCV: calibrateCamera's intrinsics, each hand-eye method's X and the board from it,
    # each robot-world method's X and Z
    camera, C = vc.intrinsics_start(train, use_guess=False)
    theirs = {}
    for name in ("TSAI", "PARK", "HORAUD", "ANDREFF", "DANIILIDIS"):
        X, Z = vc.hand_eye_start(train, C, getattr(cv2, f"CALIB_HAND_EYE_{name}"))
        theirs[name] = vc.reprojection_rms(camera, X, Z, test)
    for name in ("SHAH", "LI"):
        X, Z = vc.robot_world_start(train, C, getattr(cv2, f"CALIB_ROBOT_WORLD_HAND_EYE_{name}"))
        theirs[name] = vc.reprojection_rms(camera, X, Z, test)
    assert our_rms < min(theirs.values()), (our_rms, theirs)
    # the camera 137 mm from the flange's origin: the same within 5 mm by Park's method
    X, _ = vc.hand_eye_start(train, C, cv2.CALIB_HAND_EYE_PARK)
    assert abs(np.linalg.norm(ours.T_mount_camera[:3, 3]) - 0.137) < 0.001
    assert np.linalg.norm(ours.T_mount_camera[:3, 3] - X[:3, 3]) < 0.005


def test_a_motion_about_one_axis_or_none_is_refused(kuka2):
    # the real set's first three views turn about the base's x axis only
    with pytest.raises(vc.CalibrationRefused, match="about one axis"):
        vc.calibrate_views(kuka2.subset([0, 1, 2]))
    # the flange translated only: every view's rotation the first one's
    T = kuka2.T_base_flange.copy()
    T[:, :3, :3] = T[0, :3, :3]
    moved = dataclasses.replace(kuka2, T_base_flange=T)
    with pytest.raises(vc.CalibrationRefused, match="pure translations"):
        vc.calibrate_views(moved)
    with pytest.raises(vc.CalibrationRefused, match="too few views: 2"):
        vc.calibrate_views(kuka2.subset([0, 5]))


def _ground_truth(path: Path) -> dict[str, np.ndarray]:
    """The 4 x 4 matrices of Ali et al.'s GroundTruth.txt (``base2grid``, ``hand2eye``; m)."""
    out: dict[str, np.ndarray] = {}
    name, numbers = "", []
    for word in path.read_text().replace("=", " ").split():
        try:
            numbers.append(float(word))
        except ValueError:
            name, numbers = word, []
        if len(numbers) == 16:
            out[name] = np.array(numbers).reshape(4, 4)
    return out


@pytest.mark.parametrize("number", [1, 2, 3])
def test_someone_elses_rendered_views_give_their_truth_closer_than_opencvs_methods(number):
    from rworld_cli.api.vision import capture_views
    from rworld_cli.schema.captures import read_captures

    folder = DATA.parent / f"cs_synthetic{number}"
    truth = _ground_truth(folder / "GroundTruth.txt")
    views = capture_views(read_captures(str(folder / "captures.yaml")))
    ours = vc.calibrate_views(views)
    X = ours.T_mount_camera

    def position_error(T):
        return float(np.linalg.norm(T[:3, 3] - truth["hand2eye"][:3, 3]))

    # the truth is given to 4 decimals (0.05 mm, 0.003 deg): the camera in the flange within
    # 0.4 mm and 0.005 deg of it, the board 7.6 m away within 0.4 mm and 0.01 deg. (Not in
    # the reported sigmas: the corners' rms is 0.013-0.019 px, where the renderer's and the
    # detector's own biases are no longer white noise; set 1 is 5.8 sigma off in one axis.)
    turn = spatial.rotation_vector(X[:3, :3] @ truth["hand2eye"][:3, :3].T)
    assert position_error(X) < 4e-4 and np.degrees(np.linalg.norm(turn)) < 0.005
    Z = ours.T_holder_board
    assert np.linalg.norm(Z[:3, 3] - truth["base2grid"][:3, 3]) < 4e-4
    turn = spatial.rotation_vector(Z[:3, :3] @ truth["base2grid"][:3, :3].T)
    assert np.degrees(np.linalg.norm(turn)) < 0.01
    # OpenCV's seven from calibrateCamera's poses: each over 2.5x as far from the camera's place
    # (1.3-13.6 mm on these sets)
    _camera, C = vc.intrinsics_start(views, use_guess=False)
    theirs = {
        name: position_error(vc.hand_eye_start(views, C, getattr(cv2, f"CALIB_HAND_EYE_{name}"))[0])
        for name in ("TSAI", "PARK", "HORAUD", "ANDREFF", "DANIILIDIS")
    } | {
        name: position_error(
            vc.robot_world_start(views, C, getattr(cv2, f"CALIB_ROBOT_WORLD_HAND_EYE_{name}"))[0]
        )
        for name in ("SHAH", "LI")
    }
    assert min(theirs.values()) > 2.5 * position_error(X), (position_error(X), theirs)


def test_a_robots_errors_alike_at_near_poses_are_predicted_at_held_out_views():
    """The robot's reported flange poses off by a smooth function of the pose (a field linear
    in the flange's position, about 0.1 deg and 1 mm): the flange-error model finds most of
    the errors correlated and predicts the held-out views where the robot really is."""
    rng = np.random.default_rng(5)
    views = random_views(rng, CAMERA, BOARD, X_TRUE, Z_TRUE, 40, noise_px=0.1)
    F = views.T_base_flange
    p = F[:, :3, 3] - F[:, :3, 3].mean(axis=0)
    p /= np.sqrt(np.mean(np.sum(p * p, axis=1)))
    gradient = rng.normal(size=(2, 3, 3))
    field = np.c_[p @ gradient[0].T * np.radians(0.1), p @ gradient[1].T * 1e-3] / np.sqrt(3)
    E = spatial.make_transform(spatial.rotation_from_vector(field[:, :3]), field[:, 3:])
    reported = dataclasses.replace(views, T_base_flange=F @ spatial.invert_transform(E))
    index = np.arange(40)
    held, fit = index[3::4], np.setdiff1d(index, index[3::4])
    result = vc.calibrate_views(_unknown(reported.subset(fit)), flange_errors=True)
    assert result.flange_field is not None and result.flange_field.neighbour_correlation > 0.5
    test = reported.subset(held)
    nominal = vc.reprojection_rms(result.camera, result.T_mount_camera, result.T_holder_board, test)
    expected = vc.reprojection_rms(
        result.camera, result.T_mount_camera, result.T_holder_board, result.robot_views(test)
    )
    # predicted through where the robot is expected (this seed: 0.44 px against 1.67)
    assert expected < 0.3 * nominal, (expected, nominal)


def test_a_chessboards_views_counted_from_another_corner_are_renumbered_by_the_robots_motion():
    # Tabb and Ahmad Yousef's set: a chessboard of 9 x 7 squares looks the same turned by half
    # a turn; five views' corners numbered from the opposite corner, as a detector may
    views = _views_of("tabb1")
    corners = views.corners.copy()
    for i in (5, 17, 40, 41, 42):
        corners[i] = corners[i][::-1]
    oriented, turned = vc.orient_to_robot(dataclasses.replace(views, corners=corners))
    assert turned == {f"image{i:02d}.png": 180.0 for i in (5, 17, 40, 41, 42)}
    np.testing.assert_array_equal(oriented.corners, views.corners)
    # the views as shipped agree with the robot already: nothing renumbered, here or in the
    # other vendored chessboard sets (real and rendered)
    for name in ("tabb1", "kuka1", "kuka2", "cs_synthetic1", "cs_synthetic2", "cs_synthetic3"):
        assert vc.orient_to_robot(views if name == "tabb1" else _views_of(name))[1] == {}, name


@pytest.mark.parametrize("setup", [vc.EYE_IN_HAND, vc.EYE_TO_HAND])
def test_a_square_boards_views_are_renumbered_by_quarter_turns_too(setup):
    board = BoardModel("board", "chessboard", 7, 7, 0.03)
    X, Z = X_TRUE, Z_TRUE
    if setup == vc.EYE_TO_HAND:
        X = spatial.make_transform(spatial.rpy_to_matrix(np.radians([180, 5, 0])), [0.7, 0, 1.4])
        Z = spatial.make_transform(spatial.rpy_to_matrix(np.radians([0, 0, 45])), [0, 0, 0.05])
    views = random_views(np.random.default_rng(3), CAMERA, board, X, Z, 16, setup=setup)
    perms = vc.board_turns(board)
    assert len(perms) == 4
    # the quarter turn: the first row's corners (along x) become the first column's
    p = board.points
    centre = p.mean(axis=0)
    np.testing.assert_allclose(
        p[perms[1]] - centre, (p - centre) @ spatial.rot_z(np.pi / 2).T, atol=1e-12
    )
    corners = views.corners.copy()
    turns = {2: 1, 5: 2, 9: 3, 12: 1}
    for i, t in turns.items():
        corners[i] = views.corners[i][perms[t]]  # numbered as the board turned back by t
    oriented, turned = vc.orient_to_robot(dataclasses.replace(views, corners=corners))
    assert set(turned) == {views.names[i] for i in turns}
    np.testing.assert_allclose(oriented.corners, views.corners, atol=1e-12)
    # a rectangular chessboard has the half turn only, a ChArUco board none
    assert len(vc.board_turns(BOARD)) == 2
    assert len(vc.board_turns(BoardModel("b", "charuco", 5, 7, 0.04, 0.03, "DICT_4X4_50"))) == 1


def test_the_fit_moves_with_its_sigmas_as_its_one_step_says(monkeypatch):
    """The flange-error model's sigmas are estimates: its covariance carries how the fit moves
    with the log of each (``_fit_flange_errors``' moves: one Gauss-Newton step from the
    solution) times that log's variance (``1 / 2r``). The moves against the fit solved again
    with each sigma 10 % larger and smaller, in the parameters' own sigmas."""
    views = random_views(np.random.default_rng(203), CAMERA, BOARD, X_TRUE, Z_TRUE, 12,
                         noise_px=0.1, flange_noise=(np.radians(0.02), 0.2e-3))  # fmt: skip
    problem = vc._Problem(views, X_TRUE, Z_TRUE)
    free = np.arange(21)
    theta0 = np.r_[CAMERA.intrinsics, np.zeros(12)]
    theta, e, covariances, sig, _, _, (moves, log_variances) = vc._fit_flange_errors(
        problem, theta0, free, 0.1
    )
    # r: the corners' redundancy (about 1200) and each flange error component's (3 x 12
    # views, less what the fit takes)
    assert log_variances[0] < 1e-3 and 1 / 72 < log_variances[1] < 1 / 30
    assert 1 / 72 < log_variances[2] < 1 / 30
    sd = np.sqrt(np.diag(covariances[0]))
    monkeypatch.setattr(vc, "VARIANCE_ROUNDS", 1)  # solved at the sigmas given, not re-estimated
    step = 0.1
    camera_moves = []  # the camera in the flange as written (the shared errors taken out)
    for k, tolerance in ((0, 0.4), (1, 0.05), (2, 0.05)):
        solved, written = [], []
        for sign in (1.0, -1.0):
            s = np.array(sig, dtype=float)
            s[k] *= np.exp(sign * step)
            th, ek, *_ = vc._fit_flange_errors(problem, theta, free, s[0], start=(e, list(s)))
            solved.append(np.r_[th, ek.ravel()])
            cov = (np.eye(21 + 6 * len(ek)),) * 2
            written.append(vc._through_robot_errors(problem, th, free, ek, cov, s[1:])[0])
        moved = (solved[0] - solved[1]) / (2 * step)
        # each move over a sigma (1.6-1.8 at most); the pixels' least closely: the corners
        # Huber takes down change with their sigma (its log's variance is 4e-4 here)
        assert np.abs(moves[k] / sd).max() > 1.0
        assert np.abs((moved - moves[k]) / sd).max() < tolerance, k
        camera_moves.append((written[0] - written[1])[9:15] / (2 * step))
    # the covariance written holds those moves of the camera times the logs' variances
    args = (problem, theta, free, e, covariances, sig[1:])
    added = (
        vc._through_robot_errors(*args, (moves, log_variances))[2]
        - vc._through_robot_errors(*args)[2]
    )[9:15, 9:15]
    expected = np.einsum("ka,k,kb->ab", np.array(camera_moves), log_variances, camera_moves)
    # in the camera's own sigmas: 0.01-0.24 here (the fold's weights' part half of rx's)
    a, b = (np.sqrt(np.diag(c)) / sd[9:15] for c in (added, expected))
    assert b.max() > 0.1
    assert np.all(np.abs(a - b) < 0.1 * b + 0.01), (a, b)
