"""Joint compliance under gravity: a joint yields by its compliance times the torque that holds
the arm still, so the arm's joint values are not the commanded ones.

The model (``calibrate-robot --model compliance``, docs/calibration.md)::

    q_arm = q + c * g(q)

with ``q`` the commanded (encoder) joint values, ``c`` each joint's compliance [rad/(N m), m/N]
(:attr:`rworld_cli.model.cell.Joint.compliance`) and ``g`` the holding torques of the cell's own
dynamics: the links' masses and what the arm carries, gravity in the base's axes.  ``g`` is taken
at the commanded values: the difference to the arm's is of second order in ``c``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..model.cell import DeviceModel

COMMAND_TOLERANCE = 1e-13  # [rad, m]: the commanded values' fixed point is solved to this


def compliances(device: DeviceModel) -> np.ndarray:
    """Each joint's compliance, (n,) [rad/(N m), m/N]; zeros for a stiff arm."""
    return np.array([j.compliance for j in device.joints], dtype=float)


def holding_torques(
    device: DeviceModel, link_loads: dict | None, gravity_base: np.ndarray
) -> Callable[[np.ndarray], np.ndarray]:
    """The torques that hold ``device`` still, as a function of joint values.

    Parameters
    ----------
    device : DeviceModel
    link_loads : dict or None
        What rides on its links (:meth:`rworld_cli.world.tree.World.carried_loads`).
    gravity_base : ndarray, shape (3,)
        Gravity in the device's base axes [m/s^2].

    Returns
    -------
    callable
        ``q`` (n,) or (N, n) [rad, m] -> torques of the same shape [N m, N].
    """
    from .core import DeviceDynamics

    dynamics = DeviceDynamics(device, link_loads=link_loads)
    g = np.asarray(gravity_base, dtype=float)
    return lambda q: dynamics.gravity_torques(q, g)


def arm_values(device: DeviceModel, q: np.ndarray, holding) -> np.ndarray:
    """The arm's joint values at commanded ``q`` (n,) or (N, n): ``q + c g(q)``."""
    c = compliances(device)
    q = np.asarray(q, dtype=float)
    return q + c * holding(q) if c.any() else q


def commanded(device: DeviceModel, q_arm: np.ndarray, holding, iterations: int = 50) -> np.ndarray:
    """The commanded joint values that put the arm at ``q_arm`` (n,) or (N, n): the fixed point
    of ``q = q_arm - c g(q)``, solved to :data:`COMMAND_TOLERANCE` (a contraction: ``c dg/dq``
    is of order 1e-4 on industrial arms).

    Raises
    ------
    ValueError
        No fixed point within ``iterations``: compliance too large for the torques.
    """
    c = compliances(device)
    q_arm = np.asarray(q_arm, dtype=float)
    if not c.any():
        return q_arm
    q = q_arm.copy()
    for _ in range(iterations):
        new = q_arm - c * holding(q)
        if np.abs(new - q).max(initial=0.0) <= COMMAND_TOLERANCE:
            return new
        q = new
    raise ValueError(
        f"the commanded joint values of '{device.name}' do not settle: its compliance "
        f"({', '.join(f'{x:.3g}' for x in c)}) is too large for the torques that hold it"
    )
