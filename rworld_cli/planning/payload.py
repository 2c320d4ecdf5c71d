"""Dynamic load-carrying capacity of a trajectory: exact, since torque is affine in the payload mass.

With a payload of mass m at a fixed point (or with fixed mass properties
scaled by m), tau(m) = tau_0 + m tau_1 at every sample; the largest m with
|tau| <= tau_max everywhere is the smallest margin ratio
(tau_max - tau_0) / tau_1 (tau_1 > 0) or (tau_max + tau_0) / -tau_1 (tau_1 < 0)
over samples and joints.  It is negative when the trajectory overloads a
joint without any payload.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics import DeviceDynamics, Payload


@dataclass
class Capacity:
    mass: float  # [kg]
    joint: int  # 0-based binding joint
    sample: int  # index of the binding sample
    side: str  # "upper" | "lower": which torque limit binds


def payload_capacity(device, q, qd, qdd, gravity, com_in_tool, mount=None, armature=True, friction=False, unit_payload=None) -> Capacity:
    """The largest point-mass payload (at ``com_in_tool``) the samples can carry within the effort limits.

    ``unit_payload`` overrides the point mass: a 1 kg-scaled Payload (an object's mass properties per kg).
    """
    bare = DeviceDynamics(device, None, mount, armature, friction)
    one = unit_payload if unit_payload is not None else Payload.point_mass(1.0, com_in_tool)
    loaded = DeviceDynamics(device, one, mount, armature, friction)
    tau0 = bare.inverse(q, qd, qdd, gravity)
    tau1 = loaded.inverse(q, qd, qdd, gravity) - tau0
    tmax = device.limit_array("effort")
    with np.errstate(divide="ignore", invalid="ignore"):
        up = np.where(tau1 > 1e-12, (tmax - tau0) / tau1, np.inf)
        low = np.where(tau1 < -1e-12, (tmax + tau0) / -tau1, np.inf)
    ratios = np.minimum(up, low)
    k, j = np.unravel_index(int(np.argmin(ratios)), ratios.shape)
    return Capacity(float(ratios[k, j]), int(j), int(k), "upper" if up[k, j] <= low[k, j] else "lower")


def quintic_timing(duration: float, samples: int):
    """s, sdot, sddot of the rest-to-rest quintic s = 10 r^3 - 15 r^4 + 6 r^5, r = t / T."""
    t = np.linspace(0.0, duration, samples)
    r = t / duration
    s = 10 * r**3 - 15 * r**4 + 6 * r**5
    sd = (30 * r**2 - 60 * r**3 + 30 * r**4) / duration
    sdd = (60 * r - 180 * r**2 + 120 * r**3) / duration**2
    return t, s, sd, sdd
