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

Joint-frame devices (URDF) fit the same pieces: with the joint origin ``(R_o, p_o)`` and the
unit axis ``k`` in the joint frame, ``R = R_o Rot(k, q)`` (or ``R_o`` for prismatic joints),
``u = k``, ``A = p_o`` and ``e = 0`` (revolute) or ``k q`` (prismatic).  ``Rot`` is written
entry by entry so that a coordinate axis folds to the familiar ``Rz(q)``: its diagonal is
``k_i^2 + (1 - k_i^2) cos q`` and its off-diagonal terms ``k_i k_j (1 - cos q) -+ k_m sin q``.
"""

from __future__ import annotations

import hashlib
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
    if device.convention == "frames":
        return [_frame_step(em, joint, qi) for joint, qi in zip(device.joints, q)]
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
        if joint.correction is not None:  # A_i' = E A_i: R' = R_E R, A' = p_E + R_E A
            E = np.asarray(joint.correction, dtype=float)
            R_E = tuple(tuple(snap(float(x)) for x in row) for row in E[:3, :3])
            R = em.matmul(R_E, R)
            moved = E[:3, 3] + E[:3, :3] @ np.asarray(A, dtype=float)
            A = (snap(float(moved[0])), snap(float(moved[1])), snap(float(moved[2])))
        steps.append(ChainStep(R, u, A, e, prismatic))
    return steps


def _frame_step(em: Emitter, joint, qi: Num) -> ChainStep:
    """The pieces of one joint given by its frame (origin and axis)."""
    R_o = tuple(tuple(snap(float(x)) for x in row) for row in joint.origin[:3, :3])
    p_o = tuple(snap(float(x)) for x in joint.origin[:3, 3])
    k = tuple(snap(float(x)) for x in joint.axis)
    if joint.kind == "prismatic":
        return ChainStep(R_o, k, p_o, tuple(em.mul(x, qi) for x in k), True)
    c, s = em.call("cos", qi), em.call("sin", qi)
    one_minus_c = em.sub(1.0, c)

    def entry(i: int, j: int) -> Num:
        if i == j:
            return em.add(k[i] * k[i], em.mul(1.0 - k[i] * k[i], c))
        m = 3 - i - j
        sign = -1.0 if (i, j) in ((0, 1), (1, 2), (2, 0)) else 1.0
        return em.add(em.mul(k[i] * k[j], one_minus_c), em.mul(sign * k[m], s))

    rot = tuple(tuple(entry(i, j) for j in range(3)) for i in range(3))
    return ChainStep(em.matmul(R_o, rot), k, p_o, (0.0, 0.0, 0.0), False)


def device_key(device: DeviceModel) -> str:
    """A short key of everything the generated code of ``device`` depends on.

    A digest of the joints and the link mass properties, kept on the (frozen) model after the
    first call: hot single-state calls look their kernels up by it in well under a microsecond.
    """
    key = device.__dict__.get("_generated_key")
    if key is None:
        rows = tuple(
            (
                j.kind,
                j.a,
                j.alpha,
                j.d,
                j.theta,
                None if j.origin is None else tuple(np.asarray(j.origin).ravel().tolist()),
                None if j.axis is None else tuple(np.asarray(j.axis).tolist()),
                None if j.correction is None else tuple(np.asarray(j.correction).ravel().tolist()),
            )
            for j in device.joints
        )
        links = tuple(
            (
                l.inertial.mass,
                tuple(np.asarray(l.inertial.com).tolist()),
                tuple(np.asarray(l.inertial.inertia).ravel().tolist()),
            )
            for l in device.links
        )
        key = hashlib.sha256(repr((device.convention, rows, links)).encode()).hexdigest()
        object.__setattr__(device, "_generated_key", key)  # a cache, not a field: frozen stays true
    return key
