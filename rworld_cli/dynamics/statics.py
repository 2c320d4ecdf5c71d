"""Static force transmission: joint torques for a tool wrench, and the wrench the limits allow.

The report (section 4): "the Jacobian matrix allows computation of the joint
torques (or forces) necessary to apply a desired set of forces and/or
torques at the TCP frame" - ``tau = J^T w``, with ``w = [f; m]`` the wrench
the tool exerts on its surroundings, at the tool origin, in the same frame
as the Jacobian.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def wrench_torques(J, wrench) -> np.ndarray:
    """``tau = J^T w``.

    Parameters
    ----------
    J : array_like, shape (6, n) or (N, 6, n)
        Geometric Jacobian at the tool origin.
    wrench : array_like, shape (6,) or (N, 6)
        Force [N] then moment [N m] the tool applies, same frame as ``J``.

    Returns
    -------
    ndarray, shape (n,) or (N, n)
    """
    J = np.asarray(J, dtype=float)
    return np.einsum(
        "...ji,...j->...i", J, np.broadcast_to(np.asarray(wrench, dtype=float), J.shape[:-2] + (6,))
    )


@dataclass
class WrenchCapacity:
    """How far a wrench direction can be scaled before a joint reaches its effort limit.

    Attributes
    ----------
    scale : ndarray, shape (N,)
        Largest ``s >= 0`` with ``|tau_hold + s J^T w| <= tau_max`` on every
        joint (``inf`` if no joint is loaded by the wrench; 0 if holding the
        device already exceeds a limit).
    limiting_joint : ndarray of int, shape (N,)
        The joint that binds (-1 when none does).
    """

    scale: np.ndarray
    limiting_joint: np.ndarray


def wrench_capacity(J, wrench, tau_max, tau_hold=None) -> WrenchCapacity:
    """Largest multiple of ``wrench`` the effort limits allow in each configuration.

    Parameters
    ----------
    J : array_like, shape (N, 6, n)
    wrench : array_like, shape (6,)
        The direction (and unit) of the tool wrench.
    tau_max : array_like, shape (n,)
        Effort limits (``inf`` where none).
    tau_hold : array_like, shape (N, n), optional
        Torques already needed, e.g. gravity ``g(q)``; default 0.
    """
    J = np.asarray(J, dtype=float)
    per_unit = wrench_torques(J, wrench)  # (N, n)
    hold = np.zeros_like(per_unit) if tau_hold is None else np.asarray(tau_hold, dtype=float)
    tau_max = np.asarray(tau_max, dtype=float)
    room = np.where(
        per_unit > 0, tau_max - hold, tau_max + hold
    )  # distance to the limit in the loading direction
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(np.abs(per_unit) > 1e-12, room / np.abs(per_unit), np.inf)
    s = np.where(np.isnan(s), np.inf, s)
    s = np.maximum(s, 0.0)
    overloaded = np.any(np.abs(hold) > tau_max, axis=-1)
    limiting = np.where(np.isfinite(s.min(axis=-1)), np.argmin(s, axis=-1), -1)
    scale = np.where(overloaded, 0.0, s.min(axis=-1))
    limiting = np.where(overloaded, np.argmax(np.abs(hold) - tau_max, axis=-1), limiting)
    return WrenchCapacity(scale, limiting)
