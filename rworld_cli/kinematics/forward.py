"""Forward kinematics of serial chains given by DH tables, batched over samples.

The report (section 4, eqs. 1-3 and 10-11) builds the orientation and origin
of frame *i+1* from frame *i* recursively; a DH link transform
(:func:`rworld_cli.spatial.dh_standard`) is exactly that step written as one
4x4 matrix, and the running product ``T_base_i = T_base_{i-1} @ A_i`` is the
forward recursion (eq. 11).  Backward recursion (eqs. 4, 5, 12) is the same
product read from the tool end; see ``docs/kinematics.md``.
"""

from __future__ import annotations

import numpy as np

from ..model.cell import DeviceModel

__all__ = ["joint_link_transforms", "link_poses", "mounted_frames_program"]


def joint_link_transforms(device: DeviceModel, q) -> np.ndarray:
    """Link transforms ``A_i = T_{i-1}_{i}`` for joint values ``q``: see
    :meth:`DeviceModel.joint_transforms`.
    """
    return device.joint_transforms(q)


def link_poses(device: DeviceModel, q) -> np.ndarray:
    """Poses of all link frames in the device's natural frame, ``T_base_i``.

    Parameters
    ----------
    device : DeviceModel
    q : array_like, shape (n,) or (N, n)

    Returns
    -------
    ndarray, shape (n, 4, 4) or (N, n, 4, 4)
        ``T_base_link[i]`` = pose of DH frame *i+1* (0-based list; the last is the flange).
    """
    A = joint_link_transforms(device, q)
    out = np.empty_like(A)
    acc = A[..., 0, :, :]
    out[..., 0, :, :] = acc
    for i in range(1, A.shape[-3]):  # loop over joints (n <= ~7), vectorised over samples
        acc = acc @ A[..., i, :, :]
        out[..., i, :, :] = acc
    return out


_MOUNTED: dict[tuple, object] = {}


def mounted_frames_program(device: DeviceModel, T_world_base, mounts):
    """A generated program (:class:`rworld_cli.codegen.Generated`) of the poses of frames
    fixed to the device's links, in the world: for joint values q (N, n) [rad or m] it gives
    (N, 12 M), frame k's ``T_world_frame`` as its rotation's rows then its origin [m],

        T_world_frame = T_world_base A_1(q_1) ... A_i(q_i) T_link_frame,

    one compiled loop over the states (a collision check's per-state numpy products cost
    more than its kernels on small batches).  ``mounts``: M pairs (link index i, 0-based:
    the link after joint i+1; ``T_link_frame`` (4, 4)).  Built once per device, base and
    mounts (their values as embedded: rounded as ``ToolMount.generated_values`` rounds a
    tool's)."""
    from ..codegen import Emitter, Num
    from .chain import chain_steps, device_key
    from .jacobian import ToolMount

    def embedded(T) -> tuple[tuple, tuple]:
        return ToolMount(0, T).generated_values()

    base = embedded(T_world_base)
    fixed = tuple((int(i), embedded(T)) for i, T in mounts)
    key = (device_key(device), base, fixed)
    program = _MOUNTED.get(key)
    if program is not None:
        return program
    em = Emitter()
    q: list[Num] = [f"q{i}" for i in range(device.dof)]
    steps = chain_steps(em, device, q)
    deepest = max((i for i, _ in fixed), default=-1)
    R0, p0 = base
    links = []
    for step in steps[: deepest + 1]:  # eq. 11, from the world's frame
        R1 = em.matmul(R0, step.R)
        p1 = em.vadd(p0, em.matvec(R0, em.vadd(step.A, em.matvec(step.R, step.e))))
        links.append((R1, p1))
        R0, p0 = R1, p1
    outputs: list[Num] = []
    for i, (R_link_frame, p_link_frame) in fixed:
        R, p = links[i]
        Rf = em.matmul(R, R_link_frame)
        pf = em.vadd(p, em.matvec(R, p_link_frame))
        outputs += [Rf[r][c] for r in range(3) for c in range(3)] + list(pf)
    program = _MOUNTED[key] = em.compile("mounted_frames", [("q", device.dof)], outputs)
    return program
