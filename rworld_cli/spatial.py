"""SE(3) helpers on numpy arrays, and Denavit-Hartenberg link transforms.

Conventions (``docs/conventions.md``):

* ``T_a_b`` is the 4x4 pose of frame *b* expressed in frame *a*; it maps
  b-coordinates to a-coordinates, so ``T_world_tool = T_world_base @ T_base_tool``.
* Quaternions are ``(w, x, y, z)``.
* ``rpy = (roll, pitch, yaw)`` are rotations about the *fixed* x, y, z axes in
  that order, ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)`` (ROS / URDF convention).
* Every function accepts a leading batch shape ``(..., )`` and vectorises over it.

This module never imports the schema or the CLI.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "rot_x",
    "rot_y",
    "rot_z",
    "rpy_to_matrix",
    "matrix_to_rpy",
    "quat_to_matrix",
    "matrix_to_quat",
    "make_transform",
    "invert_transform",
    "dh_standard",
    "dh_modified",
    "axis_rotation",
    "joint_frame",
    "rotation_error",
    "rotation_vector",
    "rotation_from_vector",
]


def _axis_rotation(angle, i: int, j: int) -> np.ndarray:
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle), np.sin(angle)
    R = np.zeros(angle.shape + (3, 3))
    k = 3 - i - j
    R[..., k, k] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def rot_x(angle) -> np.ndarray:
    """Rotation about x by ``angle`` [rad]; shape ``angle.shape + (3, 3)``."""
    return _axis_rotation(angle, 1, 2)


def rot_y(angle) -> np.ndarray:
    """Rotation about y by ``angle`` [rad]; shape ``angle.shape + (3, 3)``."""
    return _axis_rotation(angle, 2, 0)


def rot_z(angle) -> np.ndarray:
    """Rotation about z by ``angle`` [rad]; shape ``angle.shape + (3, 3)``."""
    return _axis_rotation(angle, 0, 1)


def rpy_to_matrix(rpy) -> np.ndarray:
    """Rotation matrix from fixed-axis roll, pitch, yaw.

    Parameters
    ----------
    rpy : array_like, shape (..., 3)
        ``(roll, pitch, yaw)`` [rad] about the fixed x, y, z axes.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``Rz(yaw) @ Ry(pitch) @ Rx(roll)``.
    """
    rpy = np.asarray(rpy, dtype=float)
    return rot_z(rpy[..., 2]) @ rot_y(rpy[..., 1]) @ rot_x(rpy[..., 0])


def matrix_to_rpy(R) -> np.ndarray:
    """Inverse of :func:`rpy_to_matrix`; pitch in ``[-pi/2, pi/2]``.

    At the singularity (pitch = +-pi/2) roll is set to 0 and yaw takes the
    whole rotation about the vertical.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3)
        ``(roll, pitch, yaw)`` [rad].
    """
    R = np.asarray(R, dtype=float)
    pitch = np.arctan2(-R[..., 2, 0], np.hypot(R[..., 0, 0], R[..., 1, 0]))
    singular = np.hypot(R[..., 0, 0], R[..., 1, 0]) < 1e-12
    roll = np.where(singular, 0.0, np.arctan2(R[..., 2, 1], R[..., 2, 2]))
    yaw = np.where(
        singular,
        np.arctan2(-R[..., 0, 1], R[..., 1, 1]),
        np.arctan2(R[..., 1, 0], R[..., 0, 0]),
    )
    return np.stack([roll, pitch, yaw], axis=-1)


def quat_to_matrix(q) -> np.ndarray:
    """Rotation matrix of a unit quaternion ``(w, x, y, z)``; shape ``(..., 3, 3)``.

    The quaternion is normalised first (callers validate that it is not zero).
    """
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - z * w)
    R[..., 0, 2] = 2 * (x * z + y * w)
    R[..., 1, 0] = 2 * (x * y + z * w)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - x * w)
    R[..., 2, 0] = 2 * (x * z - y * w)
    R[..., 2, 1] = 2 * (y * z + x * w)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def matrix_to_quat(R) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` with ``w >= 0`` of a rotation matrix.

    Uses the numerically stable branch on the largest diagonal term.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 4)
    """
    R = np.asarray(R, dtype=float)
    if R.shape == (3, 3):  # one rotation: the same branches on floats (IK calls this per step)
        return np.array(_matrix_to_quat_single(R.tolist()))
    batch = R.shape[:-2]
    Rf = R.reshape(-1, 3, 3)
    out = np.empty((Rf.shape[0], 4))
    tr = np.trace(Rf, axis1=1, axis2=2)
    diag = np.stack([Rf[:, 0, 0], Rf[:, 1, 1], Rf[:, 2, 2]], axis=1)
    choice = np.where(tr > diag.max(axis=1), 3, diag.argmax(axis=1))
    for case in range(4):
        m = choice == case
        if not m.any():
            continue
        r = Rf[m]
        if case == 3:
            s = 2.0 * np.sqrt(1.0 + tr[m])
            out[m] = np.stack(
                [
                    0.25 * s,
                    (r[:, 2, 1] - r[:, 1, 2]) / s,
                    (r[:, 0, 2] - r[:, 2, 0]) / s,
                    (r[:, 1, 0] - r[:, 0, 1]) / s,
                ],
                axis=1,
            )
        else:
            i, j, k = case, (case + 1) % 3, (case + 2) % 3
            s = 2.0 * np.sqrt(1.0 + r[:, i, i] - r[:, j, j] - r[:, k, k])
            q = np.empty((r.shape[0], 4))
            q[:, 0] = (r[:, k, j] - r[:, j, k]) / s
            q[:, 1 + i] = 0.25 * s
            q[:, 1 + j] = (r[:, j, i] + r[:, i, j]) / s
            q[:, 1 + k] = (r[:, k, i] + r[:, i, k]) / s
            out[m] = q
    out *= np.where(out[:, :1] < 0, -1.0, 1.0)
    return out.reshape(batch + (4,))


def _matrix_to_quat_single(r: list) -> tuple[float, float, float, float]:
    """:func:`matrix_to_quat` of one matrix given as nested lists: the same branch and the same
    operations in the same order as the batched code, so the same bits, ~30x faster."""
    tr = r[0][0] + r[1][1] + r[2][2]
    diag = (r[0][0], r[1][1], r[2][2])
    top = max(diag)
    case = 3 if tr > top else diag.index(top)  # argmax: the first of equal values
    if case == 3:
        s = 2.0 * math.sqrt(1.0 + tr)
        q = [0.25 * s, (r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s]
    else:
        i, j, k = case, (case + 1) % 3, (case + 2) % 3
        s = 2.0 * math.sqrt(1.0 + r[i][i] - r[j][j] - r[k][k])
        q = [0.0] * 4
        q[0] = (r[k][j] - r[j][k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (r[j][i] + r[i][j]) / s
        q[1 + k] = (r[k][i] + r[i][k]) / s
    sign = -1.0 if q[0] < 0 else 1.0
    return (q[0] * sign, q[1] * sign, q[2] * sign, q[3] * sign)


def make_transform(R=None, p=None) -> np.ndarray:
    """Homogeneous transform from a rotation ``(..., 3, 3)`` and a translation ``(..., 3)``.

    Either may be omitted (identity rotation / zero translation); the batch
    shape is taken from the one given.
    """
    if R is None and p is None:
        return np.eye(4)
    if R is None:
        p = np.asarray(p, dtype=float)
        R = np.broadcast_to(np.eye(3), p.shape[:-1] + (3, 3))
    R = np.asarray(R, dtype=float)
    if p is None:
        p = np.zeros(R.shape[:-2] + (3,))
    p = np.asarray(p, dtype=float)
    batch = np.broadcast_shapes(R.shape[:-2], p.shape[:-1])
    T = np.zeros(batch + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = p
    T[..., 3, 3] = 1.0
    return T


def invert_transform(T) -> np.ndarray:
    """Inverse of rigid transforms ``(..., 4, 4)``: ``[R^T, -R^T p; 0, 1]``."""
    T = np.asarray(T, dtype=float)
    R = T[..., :3, :3]
    p = T[..., :3, 3]
    Rt = np.swapaxes(R, -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, p)
    out[..., 3, 3] = 1.0
    return out


def dh_standard(a, alpha, d, theta) -> np.ndarray:
    """Standard (distal) DH link transform ``Rz(theta) Tz(d) Tx(a) Rx(alpha)``.

    This is ``T_{i-1}_{i}``, the pose of link frame *i* in frame *i-1*.  In the
    report's terms (eqs. 1, 3, 10): the new x axis is
    ``x_{i+1} = x_i cos(theta) + y_i sin(theta)``, the new z axis is ``z_i``
    turned by ``alpha`` about it, and the origin moves by ``r* = s z_i + a x_{i+1}``
    (``s`` is the report's name for the offset ``d``).

    Parameters
    ----------
    a, alpha, d, theta : array_like, broadcastable
        Link length [m], twist [rad], offset [m], joint angle [rad].

    Returns
    -------
    ndarray, shape (broadcast shape) + (4, 4)
    """
    a, alpha, d, theta = np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (a, alpha, d, theta))
    )
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    T = np.zeros(a.shape + (4, 4))
    T[..., 0, 0] = ct
    T[..., 0, 1] = -st * ca
    T[..., 0, 2] = st * sa
    T[..., 0, 3] = a * ct
    T[..., 1, 0] = st
    T[..., 1, 1] = ct * ca
    T[..., 1, 2] = -ct * sa
    T[..., 1, 3] = a * st
    T[..., 2, 1] = sa
    T[..., 2, 2] = ca
    T[..., 2, 3] = d
    T[..., 3, 3] = 1.0
    return T


def dh_modified(a, alpha, d, theta) -> np.ndarray:
    """Modified (proximal, Craig) DH link transform ``Rx(alpha) Tx(a) Rz(theta) Tz(d)``.

    Row *i* of a modified table holds ``a_{i-1}``, ``alpha_{i-1}`` (the link
    before joint *i*) with ``d_i``, ``theta_i``; joint *i* moves about/along
    the z axis of frame *i* itself.

    Parameters
    ----------
    a, alpha, d, theta : array_like, broadcastable
        Link length [m], twist [rad], offset [m], joint angle [rad].

    Returns
    -------
    ndarray, shape (broadcast shape) + (4, 4)
    """
    a, alpha, d, theta = np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (a, alpha, d, theta))
    )
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    T = np.zeros(a.shape + (4, 4))
    T[..., 0, 0] = ct
    T[..., 0, 1] = -st
    T[..., 0, 3] = a
    T[..., 1, 0] = st * ca
    T[..., 1, 1] = ct * ca
    T[..., 1, 2] = -sa
    T[..., 1, 3] = -sa * d
    T[..., 2, 0] = st * sa
    T[..., 2, 1] = ct * sa
    T[..., 2, 2] = ca
    T[..., 2, 3] = ca * d
    T[..., 3, 3] = 1.0
    return T


def axis_rotation(axis, angle) -> np.ndarray:
    """Rotation by ``angle`` [rad] about the unit vector ``axis`` (Rodrigues).

    Parameters
    ----------
    axis : array_like, shape (3,)
        Unit rotation axis.
    angle : array_like, shape (...)

    Returns
    -------
    ndarray, shape (...) + (3, 3)
    """
    u = np.asarray(axis, dtype=float)
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle)[..., None, None], np.sin(angle)[..., None, None]
    K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    outer = np.outer(u, u)
    return c * np.eye(3) + s * K + (1.0 - c) * outer


def joint_frame(T_parent_joint, axis, q, prismatic: bool) -> np.ndarray:
    """Link transform of a joint given by its frame (URDF convention).

    ``T_{i-1}_{i} = T_parent_joint @ motion(q)``, where the motion is a rotation by ``q``
    about ``axis`` (revolute) or a translation by ``q`` along it (prismatic); the child link's
    frame is the joint frame moved by ``q``.

    Parameters
    ----------
    T_parent_joint : ndarray, shape (4, 4)
        Pose of the joint frame in the parent link's frame at ``q = 0``.
    axis : array_like, shape (3,)
        Unit joint axis in the joint frame.
    q : array_like, shape (...)
        Joint value [rad or m].

    Returns
    -------
    ndarray, shape (...) + (4, 4)
    """
    q = np.asarray(q, dtype=float)
    motion = np.zeros(q.shape + (4, 4))
    motion[..., 3, 3] = 1.0
    if prismatic:
        motion[..., :3, :3] = np.eye(3)
        motion[..., :3, 3] = q[..., None] * np.asarray(axis, dtype=float)
    else:
        motion[..., :3, :3] = axis_rotation(axis, q)
    return np.asarray(T_parent_joint, dtype=float) @ motion


def rotation_error(R) -> np.ndarray:
    """``||R^T R - I||_F`` and ``|det R - 1|`` combined: max of the two, shape ``(...)``.

    A proper rotation gives ~1e-16; used to validate user matrices.
    """
    R = np.asarray(R, dtype=float)
    orth = np.linalg.norm(np.swapaxes(R, -1, -2) @ R - np.eye(3), axis=(-2, -1))
    det = np.abs(np.linalg.det(R) - 1.0)
    return np.maximum(orth, det)


def rotation_vector(R) -> np.ndarray:
    """Axis-angle vector ``theta * axis`` of rotations ``(..., 3, 3)``; ``theta`` in ``[0, pi]``.

    Via the quaternion, so it stays accurate near 0 and near pi.
    """
    R = np.asarray(R, dtype=float)
    if R.shape == (3, 3):  # one rotation, on floats (IK calls this per step)
        w, x, y, z = _matrix_to_quat_single(R.tolist())
        half = math.sqrt(x * x + y * y + z * z)
        # numpy's arctan2, not math.atan2: on CPUs with AVX-512 numpy vectorises it and differs
        # from libm in the last bit, and the single path must give the batched path's bits
        factor = 2.0 * float(np.arctan2(half, w)) / half if half > 1e-12 else 2.0  # small: 2 v
        return np.array((x * factor, y * factor, z * factor))
    q = matrix_to_quat(R)
    v = q[..., 1:]
    s = np.linalg.norm(v, axis=-1)
    angle = 2.0 * np.arctan2(s, q[..., 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(s > 1e-12, angle / np.maximum(s, 1e-300), 2.0)  # small angles: 2 v
    return v * scale[..., None]


def rotation_from_vector(w) -> np.ndarray:
    """Rotations ``(..., 3, 3)`` from axis-angle vectors ``theta * axis`` ``(..., 3)`` [rad]
    (Rodrigues' formula; the inverse of :func:`rotation_vector`, exact near zero).
    """
    w = np.asarray(w, dtype=float)
    theta2 = np.sum(w * w, axis=-1)[..., None, None]
    theta = np.sqrt(theta2)
    small = theta2 < 1e-16
    safe = np.where(small, 1.0, theta)
    a = np.where(small, 1.0 - theta2 / 6.0, np.sin(safe) / safe)  # sin t / t
    b = np.where(small, 0.5 - theta2 / 24.0, (1.0 - np.cos(safe)) / (safe * safe))  # (1-cos t)/t^2
    K = np.zeros(w.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    return np.eye(3) + a * K + b * (K @ K)
