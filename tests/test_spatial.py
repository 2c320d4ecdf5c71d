"""SE(3) helpers against closed forms and round trips."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from rworld_cli import spatial

angles = arrays(float, 3, elements=st.floats(-np.pi, np.pi))


@settings(max_examples=200)
@given(angles)
def test_rpy_round_trip(rpy):
    R = spatial.rpy_to_matrix(rpy)
    assert spatial.rotation_error(R) < 1e-12
    np.testing.assert_allclose(spatial.rpy_to_matrix(spatial.matrix_to_rpy(R)), R, atol=1e-9)


@settings(max_examples=200)
@given(angles)
def test_quaternion_round_trip(rpy):
    R = spatial.rpy_to_matrix(rpy)
    q = spatial.matrix_to_quat(R)
    assert np.isclose(np.linalg.norm(q), 1.0) and q[0] >= 0
    np.testing.assert_allclose(spatial.quat_to_matrix(q), R, atol=1e-12)


def test_closed_forms():
    np.testing.assert_allclose(spatial.rot_z(np.pi / 2) @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(spatial.rpy_to_matrix([0, 0, np.pi / 2]), spatial.rot_z(np.pi / 2))
    # quaternion of 90 deg about x: (cos 45, sin 45, 0, 0)
    np.testing.assert_allclose(
        spatial.quat_to_matrix([np.cos(np.pi / 4), np.sin(np.pi / 4), 0, 0]),
        spatial.rot_x(np.pi / 2),
        atol=1e-15,
    )
    np.testing.assert_allclose(
        spatial.matrix_to_rpy(spatial.rpy_to_matrix([0.1, np.pi / 2, 0.3]))[1], np.pi / 2
    )


def test_batched_invert_and_compose():
    rng = np.random.default_rng(1)
    T = spatial.make_transform(
        spatial.rpy_to_matrix(rng.uniform(-3, 3, (50, 3))), rng.normal(size=(50, 3))
    )
    np.testing.assert_allclose(
        T @ spatial.invert_transform(T), np.broadcast_to(np.eye(4), (50, 4, 4)), atol=1e-12
    )
    np.testing.assert_allclose(spatial.invert_transform(T), np.linalg.inv(T), atol=1e-12)


def test_dh_closed_forms():
    # standard: Rz(theta) Tz(d) Tx(a) Rx(alpha)
    a, alpha, d, theta = 0.3, 0.4, 0.2, 0.7
    expected = (
        spatial.make_transform(spatial.rot_z(theta))
        @ spatial.make_transform(p=[0, 0, d])
        @ spatial.make_transform(p=[a, 0, 0])
        @ spatial.make_transform(spatial.rot_x(alpha))
    )
    np.testing.assert_allclose(spatial.dh_standard(a, alpha, d, theta), expected, atol=1e-15)
    # modified: Rx(alpha) Tx(a) Rz(theta) Tz(d)
    expected = (
        spatial.make_transform(spatial.rot_x(alpha))
        @ spatial.make_transform(p=[a, 0, 0])
        @ spatial.make_transform(spatial.rot_z(theta))
        @ spatial.make_transform(p=[0, 0, d])
    )
    np.testing.assert_allclose(spatial.dh_modified(a, alpha, d, theta), expected, atol=1e-15)


def test_one_rotation_takes_the_batched_codes_answer():
    """matrix_to_quat and rotation_vector of a single (3, 3) run on floats; they give the batched
    code's bits, on random rotations and on the branch edges (identity, half turns, tiny angles)."""
    from scipy.spatial.transform import Rotation

    R = np.concatenate(
        [
            Rotation.random(3000, random_state=5).as_matrix(),
            np.array([np.eye(3), np.diag([1.0, -1, -1]), np.diag([-1.0, 1, -1])]),
            np.array([np.diag([-1.0, -1, 1]), Rotation.from_rotvec([1e-13, 0, 0]).as_matrix()]),
            Rotation.from_rotvec(np.pi * np.eye(3) * (1 - 1e-12)).as_matrix(),
        ]
    )
    for batched_fn in (spatial.matrix_to_quat, spatial.rotation_vector):
        batched = batched_fn(R)
        single = np.array([batched_fn(r) for r in R])
        assert np.array_equal(single, batched), batched_fn.__name__
    np.testing.assert_allclose(
        spatial.rotation_vector(R), Rotation.from_matrix(R).as_rotvec(), atol=1e-12
    )
