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

__all__ = ["joint_link_transforms", "link_poses"]


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
