"""The camera model against OpenCV's own projection, and what the camera can see."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rworld_cli import spatial
from rworld_cli.model.vision import BoardModel, CameraModel
from rworld_cli.vision.camera import project, radial_limit, visible
from rworld_cli.vision.emulate import look_at, seen_corners

cv2 = pytest.importorskip("cv2")

finite = dict(allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(
    f=st.floats(200, 5000, **finite),
    aspect=st.floats(0.9, 1.1, **finite),
    c=st.tuples(st.floats(100, 2000, **finite), st.floats(100, 1500, **finite)),
    k=st.tuples(
        *[st.floats(-0.5, 0.5, **finite)] * 2,
        *[st.floats(-0.01, 0.01, **finite)] * 2,
        st.floats(-0.2, 0.2, **finite),
    ),
    seed=st.integers(0, 2**31),
)
def test_projection_is_opencvs_to_a_nanopixel(f, aspect, c, k, seed):
    intrinsics = np.r_[f, f * aspect, c, k]
    rng = np.random.default_rng(seed)
    # points in the camera's view (a sensor twice the principal point), up to 4 m away
    z = rng.uniform(0.3, 4.0, 300)
    x = z * rng.uniform(-1, 1, 300) * c[0] / intrinsics[0]
    y = z * rng.uniform(-1, 1, 300) * c[1] / intrinsics[1]
    in_camera = np.column_stack([x, y, z])
    rvec, tvec = rng.normal(0, 0.3, 3), rng.normal(0, 0.1, 3) + [0, 0, 1]
    R = spatial.rotation_from_vector(rvec)
    points = (in_camera - tvec) @ R  # the same points in the frame OpenCV is given
    K = np.array([[intrinsics[0], 0, c[0]], [0, intrinsics[1], c[1]], [0, 0, 1]])
    theirs = cv2.projectPoints(points, rvec, tvec, K, np.array(k))[0][:, 0]
    ours = project(intrinsics, points @ R.T + tvec)
    cam = CameraModel("c", int(2 * c[0]), int(2 * c[1]), *intrinsics[:4], np.array(k))
    seen = visible(cam, in_camera)  # a strong distortion folds some out of the image
    assert seen.any()
    assert np.abs(ours - theirs)[seen].max(initial=0.0) < 1e-9


def test_rotation_vectors_are_opencvs_rodrigues():
    w = np.random.default_rng(3).normal(0, 1.5, (50, 3))
    ours = spatial.rotation_from_vector(w)
    theirs = np.array([cv2.Rodrigues(v)[0] for v in w])
    assert np.abs(ours - theirs).max() < 1e-14


def test_the_distortions_fold_is_where_the_radius_stops_growing():
    k = np.array([-0.4, 0.1, 0.0, 0.0, -0.05])
    r = radial_limit(k)
    s = np.linspace(0, 1.5 * r, 10_000)
    rd = s * (1 + k[0] * s**2 + k[1] * s**4 + k[4] * s**6)
    turn = s[np.argmax(rd)]
    assert abs(turn - r) < 2 * (s[1] - s[0])
    assert radial_limit(np.zeros(5)) == np.inf
    cam = CameraModel("c", 1000, 1000, 500, 500, 500, 500, k)
    # a point far past the fold lands back inside the image: it must not count as seen
    far = np.array([1.15 * r, 0.0, 1.0])
    u = project(cam.intrinsics, far)
    assert 0 <= u[0] < 1000 and 0 <= u[1] < 1000
    assert not visible(cam, far)
    assert not visible(cam, [0.0, 0.0, -1.0])  # behind the lens
    assert visible(cam, [0.0, 0.0, 1.0])


def test_a_board_seen_head_on_fills_the_middle_of_the_image():
    cam = CameraModel("c", 1280, 1024, 1000, 1000, 639.5, 511.5)
    board = BoardModel("b", "chessboard", 9, 6, 0.03)
    centre = [(9 - 1) * 0.03 / 2, (6 - 1) * 0.03 / 2, 0.0]
    T_board_camera = look_at(np.add(centre, [0, 0, -0.5]), centre, up=(0, -1, 0))
    uv = seen_corners(cam, board, spatial.invert_transform(T_board_camera))
    assert np.all(np.isfinite(uv))
    # 0.24 m wide at 0.5 m with f = 1000 px: 480 px, centred
    assert np.allclose(uv.mean(axis=0), [639.5, 511.5], atol=1e-9)
    assert np.isclose(np.ptp(uv[:, 0]), 480.0) and np.isclose(np.ptp(uv[:, 1]), 300.0)
    # the first corner on the image's left, +x of the board to the right, +y down
    assert uv[1, 0] > uv[0, 0] and uv[9, 1] > uv[0, 1]
    # turned away: nothing seen
    assert np.all(np.isnan(seen_corners(cam, board, T_board_camera)))
