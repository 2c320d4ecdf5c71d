"""One DH joint as the generated recursions see it, for standard and modified tables.

For joint *i* the link transform ``T_{i-1}_{i}`` is written as

* ``R`` - the rotation ``R_{i-1}_{i}`` (standard: ``Rz(theta) Rx(alpha)``;
  modified: ``Rx(alpha) Rz(theta)``), entries folded by the emitter;
* ``u`` - the joint axis, a constant unit vector in frame *i*
  (standard: ``z_{i-1}`` seen from frame *i* = ``(0, sin alpha, cos alpha)``;
  modified: ``z_i = (0, 0, 1)``);
* ``A`` - a point on the joint axis fixed in link *i-1*, in frame *i-1*
  (standard: the origin of frame *i-1*; modified: ``(a, 0, 0)``);
* ``e`` - the vector from ``A`` to the origin of frame *i*, in frame *i*
  (standard: the report's ``r*`` of eq. 10, ``(a, d sin alpha, d cos alpha)``;
  modified: ``(0, 0, d)``), with ``d = q + d`` for prismatic joints.

So the origin of frame *i* in frame *i-1* is ``A + R e``, and one set of
recursions covers both conventions and both joint types.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..codegen import Emitter, Num, Vec, snap
from ..model.cell import DeviceModel


@dataclass(frozen=True)
class ChainStep:
    R: tuple  # 3x3 of Num
    u: Vec
    A: Vec
    e: Vec
    prismatic: bool


def chain_steps(em: Emitter, device: DeviceModel, q: list[Num]) -> list[ChainStep]:
    """The generated pieces of every joint of ``device`` for joint values ``q``."""
    steps = []
    standard = device.convention == "standard"
    for joint, qi in zip(device.joints, q):
        ca = snap(math.cos(joint.alpha))
        sa = snap(math.sin(joint.alpha))
        c: Num
        s: Num
        d: Num
        R: tuple
        prismatic = joint.kind == "prismatic"
        if prismatic:
            c, s = snap(math.cos(joint.theta)), snap(math.sin(joint.theta))
            d = em.add(qi, float(joint.d))
        else:
            angle = em.add(qi, float(joint.theta))
            c, s = em.call("cos", angle), em.call("sin", angle)
            d = float(joint.d)
        if standard:
            R = (
                (c, em.neg(em.mul(s, ca)), em.mul(s, sa)),
                (s, em.mul(c, ca), em.neg(em.mul(c, sa))),
                (0.0, sa, ca),
            )
            u, A = (0.0, sa, ca), (0.0, 0.0, 0.0)
            e = (float(joint.a), em.mul(d, sa), em.mul(d, ca))
        else:
            R = (
                (c, em.neg(s), 0.0),
                (em.mul(s, ca), em.mul(c, ca), -sa),
                (em.mul(s, sa), em.mul(c, sa), ca),
            )
            u, A = (0.0, 0.0, 1.0), (float(joint.a), 0.0, 0.0)
            e = (0.0, 0.0, d)
        steps.append(ChainStep(R, u, A, e, prismatic))
    return steps


def device_key(device: DeviceModel) -> tuple:
    """A hashable key of everything the generated code of ``device`` depends on."""
    rows = tuple((j.kind, j.a, j.alpha, j.d, j.theta) for j in device.joints)
    links = tuple(
        (
            l.inertial.mass,
            tuple(np.asarray(l.inertial.com).tolist()),
            tuple(np.asarray(l.inertial.inertia).ravel().tolist()),
        )
        for l in device.links
    )
    return (device.convention, rows, links)
