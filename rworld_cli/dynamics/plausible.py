"""Dynamics that cannot be a real robot's: what an import warns about (issue 62).

Vendors' descriptions sometimes ship placeholders - DENSO's VS060 package gives every link
1 kg with 1 kg m^2 inertias and every joint a 1 N m effort - that import silently and fail much
later (an overload on the first move, a dynamics fit that cannot converge).  Two tests, each a
bound no real body breaks:

* **Inertia against size.**  A body of mass ``m`` whose points all lie within ``R`` of its
  centre of mass has, about any axis through that centre, ``I = sum m_i d_i^2 <= m R^2``.  So
  the largest principal moment can be at most ``m R^2``, ``R`` the farthest point of the
  link's geometry from its centre of mass.
* **Efforts against gravity.**  Holding the arm still takes the gravity torques; a joint whose
  effort limit is below what it needs at some state of its range cannot hold the arm there.
  The states are the zero state and a few seeded ones within the limits (a stretched arm is
  near the worst for the shoulder).
"""

from __future__ import annotations

import numpy as np

from .core import DeviceDynamics

GRAVITY_STATES = 64  # seeded states within the limits, besides zero, for the gravity test


def inertia_beyond_size(
    mass: float, inertia: np.ndarray, reach: float
) -> tuple[float, float] | None:
    """(largest principal moment [kg m^2], the most a body of ``mass`` [kg] within ``reach``
    [m] of its centre of mass can have) when the first is above the second (beyond rounding),
    else None.  ``inertia`` (3, 3) about the centre of mass."""
    largest = float(np.linalg.eigvalsh(np.asarray(inertia, dtype=float))[-1])
    most = mass * reach * reach
    if mass > 0 and largest > most * (1.0 + 1e-6) + 1e-12:
        return largest, most
    return None


def efforts_below_gravity(device, seed: int = 0) -> list[tuple[int, float, np.ndarray]]:
    """The joints whose effort limit is below the torque (force) that holding ``device`` still
    against gravity takes at some state sampled (zero and :data:`GRAVITY_STATES` seeded ones
    within the limits; a joint without limits samples one turn): ``(joint index, that torque
    [N m or N], the state (n,))`` each, the largest over the states; [] when none, or when the
    device declares no efforts or no masses."""
    effort = device.limit_array("effort")
    if not np.isfinite(effort).any():
        return []
    if not any(link.inertial is not None and link.inertial.mass > 0 for link in device.links):
        return []
    lower = np.where(np.isfinite(device.limit_array("lower")), device.limit_array("lower"), -np.pi)
    upper = np.where(np.isfinite(device.limit_array("upper")), device.limit_array("upper"), np.pi)
    rng = np.random.default_rng(seed)
    q = np.concatenate(
        [
            np.clip(np.zeros((1, device.dof)), lower, upper),
            rng.uniform(lower, upper, (GRAVITY_STATES, device.dof)),
        ]
    )
    dynamics = DeviceDynamics(device, armature=False, friction=False)
    hold = np.abs(dynamics.gravity_torques(q))  # (N, n)
    worst = np.argmax(hold, axis=0)
    need = hold[worst, np.arange(device.dof)]
    out = []
    for j in np.flatnonzero(np.isfinite(effort) & (need > effort * (1.0 + 1e-9))):
        out.append((int(j), float(need[j]), q[worst[j]]))
    return out
