"""Tool pose and geometric Jacobian of a serial chain, batched, from generated code.

Rows of the Jacobian: linear velocity of a point (default the TCP origin),
then angular velocity, both in the device's base frame (or world, by
rotating with the base orientation).  Column *i*: revolute
``[z_i x (p - o_i); z_i]``, prismatic ``[z_i; 0]`` with ``z_i`` the joint
axis and ``o_i`` a point on it.
"""

from __future__ import annotations

import numpy as np

from ..codegen import Emitter, Generated, Num, snap
from ..model.cell import DeviceModel
from .chain import chain_steps, device_key

__all__ = [
    "ToolMount",
    "reach_bound",
    "tool_pose",
    "tool_pose_and_jacobian",
    "jacobian",
    "manipulability",
    "condition_number",
    "shift_jacobian",
]


class ToolMount:
    """Where a tool frame sits on a device: on link ``link`` (1..n; 0 = base) at ``T_link_tool``."""

    def __init__(self, link: int, T_link_tool=None):
        self.link = int(link)
        self.T_link_tool = (
            np.eye(4) if T_link_tool is None else np.asarray(T_link_tool, dtype=float)
        )

    def generated_values(self) -> tuple[tuple, tuple]:
        """(rotation rows, translation) as the generated code embeds them: rotation elements
        within 1e-14 of 0 or +-1 snapped to them, the translation rounded to 1e-13 m (a tenth
        of a picometre), with no negative zeros.  Mounts computed along different frame paths
        differ by rounding only (-0.0, 2e-15 m); so they share one kernel, and the kernel's
        results depend on these values alone."""
        T = self.T_link_tool
        R = tuple(tuple(snap(float(v)) + 0.0 for v in row) for row in T[:3, :3])
        t = tuple(float(v) + 0.0 for v in np.round(T[:3, 3], 13) + 0.0)
        return R, t

    def key(self) -> str:
        """A short key of the mount, computed once (kernels are looked up by it)."""
        key = self.__dict__.get("_key")
        if key is None:
            key = self._key = repr((self.link, self.generated_values()))
        return key


def reach_bound(device: DeviceModel, mount: ToolMount | None = None) -> float:
    """An upper bound on the distance from the device's base origin to the tool frame [m]:
    every offset of the chain, prismatic travel and the tool, added up (the triangle
    inequality; turns keep lengths).  A target farther than this is out of reach whatever
    the joints."""
    frames = device.joint_frames()
    total = float(np.linalg.norm(frames[-1][2][:3, 3]))  # the last link frame from its joint's
    for (origin, _, _), joint in zip(frames, device.joints):
        total += float(np.linalg.norm(origin[:3, 3]))
        if joint.kind == "prismatic":
            total += max(abs(joint.limits.lower), abs(joint.limits.upper))
    tool = np.eye(4) if mount is None else mount.T_link_tool
    return total + float(np.linalg.norm(tool[:3, 3]))


def _generate(device: DeviceModel, mount: ToolMount, with_jacobian: bool) -> Generated:
    n = device.dof
    link = mount.link
    R_link_tool, p_link_tool = mount.generated_values()
    em = Emitter()
    names = [f"q{i}" for i in range(n)]
    q: list[Num] = list(names)
    steps = chain_steps(em, device, q)
    R0 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    p0 = (0.0, 0.0, 0.0)
    axes = []
    for step in steps[:link]:
        R1 = em.matmul(R0, step.R)
        p1 = em.vadd(p0, em.matvec(R0, em.vadd(step.A, em.matvec(step.R, step.e))))  # eq. 11
        axis = em.matvec(R1, step.u)
        point = em.vsub(p1, em.matvec(R1, step.e))
        axes.append((axis, point, step.prismatic))
        R0, p0 = R1, p1
    Rt = em.matmul(R0, R_link_tool)
    pt = em.vadd(p0, em.matvec(R0, p_link_tool))
    outputs: list[Num] = []
    for i in range(3):  # the 4 x 4 pose, row by row
        outputs += [Rt[i][0], Rt[i][1], Rt[i][2], pt[i]]
    outputs += [0.0, 0.0, 0.0, 1.0]
    if with_jacobian:
        cols = []
        for i in range(n):
            if i >= link:
                cols.append((0.0,) * 6)
                continue
            axis, point, prismatic = axes[i]
            if prismatic:
                cols.append(tuple(axis) + (0.0, 0.0, 0.0))
            else:
                cols.append(tuple(em.cross(axis, em.vsub(pt, point))) + tuple(axis))
        outputs += [cols[c][r] for r in range(6) for c in range(n)]  # row-major 6 x n
    # a single state's results come as T (4, 4) and J (6, n)
    shapes = [(4, 4), (6, n)] if with_jacobian else [(4, 4)]
    return em.compile("fk_jacobian" if with_jacobian else "fk", [("q", n)], outputs, shapes)


_CACHE: dict[tuple, Generated] = {}


def generated(device: DeviceModel, mount: ToolMount | None, with_jacobian: bool) -> Generated:
    """The compiled tool-pose (and Jacobian) code of ``device``, generated once per geometry."""
    # looked up on the device first: a single state pays for every dictionary here
    programs = device.__dict__.get("_tool_programs")
    if programs is None:
        programs = {}
        object.__setattr__(device, "_tool_programs", programs)  # a cache, not a field
    local_key = (None if mount is None else mount.key(), with_jacobian)
    program = programs.get(local_key)
    if program is None:
        if mount is None:
            mount = ToolMount(device.dof)
        key = (device_key(device), mount.key(), with_jacobian)
        program = _CACHE.get(key)
        if program is None:
            program = _CACHE[key] = _generate(device, mount, with_jacobian)
        programs[local_key] = program
    return program


def _check_q(device: DeviceModel, q) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if len(q.shape) > 2 or q.shape[-1:] != (device.dof,):
        raise ValueError(
            f"joint values of '{device.name}' must have shape (n,) or (N, n) with n = "
            f"{device.dof}, got {q.shape}"
        )
    return q


def tool_pose(device: DeviceModel, q, mount: ToolMount | None = None) -> np.ndarray:
    """Pose of the tool frame in the device's base frame, ``T_base_tool``.

    Parameters
    ----------
    device : DeviceModel
    q : array_like, shape (n,) or (N, n)
        Joint values [rad or m].
    mount : ToolMount, optional
        Tool frame on its link; default the last link's frame (the flange).

    Returns
    -------
    ndarray, shape (4, 4) or (N, 4, 4)
    """
    program = generated(device, mount, False)
    T = program.direct(q)  # one state of floats, checked by the kernel
    if T is not None:
        return T
    q = _check_q(device, q)
    flat = program.evaluate([q])
    return flat.reshape(flat.shape[:-1] + (4, 4))


def tool_pose_and_jacobian(
    device: DeviceModel, q, mount: ToolMount | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """``T_base_tool`` and the geometric Jacobian at the tool origin, in the base frame.

    Parameters
    ----------
    device : DeviceModel
    q : array_like, shape (n,) or (N, n)
    mount : ToolMount, optional

    Returns
    -------
    T : ndarray, shape (4, 4) or (N, 4, 4)
    J : ndarray, shape (6, n) or (N, 6, n)
        Rows ``[vx, vy, vz, wx, wy, wz]`` of the tool origin, base frame.
    """
    program = generated(device, mount, True)
    pose_and_jacobian = program.direct(q)  # one state of floats, checked by the kernel
    if pose_and_jacobian is not None:
        return pose_and_jacobian
    q = _check_q(device, q)
    flat = program.evaluate([q])
    n = device.dof
    if q.ndim == 1:
        return flat[:16].reshape(4, 4), flat[16:].reshape(6, n)
    return flat[:, :16].reshape(-1, 4, 4), flat[:, 16:].reshape(-1, 6, n)


def jacobian(
    device: DeviceModel, q, mount: ToolMount | None = None, point_in_tool=None
) -> np.ndarray:
    """Geometric Jacobian in the base frame, at the tool origin or at a point on the tool.

    Parameters
    ----------
    point_in_tool : array_like, shape (3,), optional
        The point whose linear velocity the top rows give, in tool coordinates [m].

    Returns
    -------
    ndarray, shape (6, n) or (N, 6, n)
    """
    T, J = tool_pose_and_jacobian(device, q, mount)
    if point_in_tool is None:
        return J
    return shift_jacobian(
        J, np.einsum("...ij,j->...i", T[..., :3, :3], np.asarray(point_in_tool, dtype=float))
    )


def shift_jacobian(J: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """Move the reference point of a Jacobian by ``offset`` (same frame as J): ``v' = v + w x r``.

    Parameters
    ----------
    J : ndarray, shape (..., 6, n)
    offset : ndarray, shape (..., 3)
        From the old point to the new one [m].
    """
    J = J.copy()
    r = np.asarray(offset, dtype=float)[..., :, None]
    w = J[..., 3:, :]
    J[..., 0, :] += w[..., 1, :] * r[..., 2, :] - w[..., 2, :] * r[..., 1, :]
    J[..., 1, :] += w[..., 2, :] * r[..., 0, :] - w[..., 0, :] * r[..., 2, :]
    J[..., 2, :] += w[..., 0, :] * r[..., 1, :] - w[..., 1, :] * r[..., 0, :]
    return J


def manipulability(J: np.ndarray) -> np.ndarray:
    """Yoshikawa's measure ``sqrt(det(J J^T))`` = product of singular values; shape
    ``J.shape[:-2]``.
    """
    s = np.linalg.svd(J, compute_uv=False)
    return np.prod(s, axis=-1)


def condition_number(J: np.ndarray) -> np.ndarray:
    """Ratio of the largest to the smallest singular value (``inf`` at a singularity)."""
    s = np.linalg.svd(J, compute_uv=False)
    with np.errstate(divide="ignore"):
        return np.where(s[..., -1] > 0, s[..., 0] / np.maximum(s[..., -1], 1e-300), np.inf)
