"""Recursive Newton-Euler inverse dynamics, generated per device and batched.

The report (section 4, eqs. 13-18) computes link velocities and
accelerations outward from the base and forces inward from the tool, each in
the link's own frame.  Here (``u``, ``A``, ``e`` and ``R`` as in
:mod:`rworld_cli.kinematics.chain`, all vectors in frame *i*):

Outward, from ``w_0 = dw_0 = 0`` and ``dv_0 = -g`` (gravity as a base
acceleration)::

    w'   = R^T w_{i-1}
    w_i  = w' + u qd_i                      (revolute; prismatic: w')
    dw_i = R^T dw_{i-1} + w' x u qd_i + u qdd_i      (eq. 16; prismatic: R^T dw_{i-1}, eq. 17)
    dv_i = R^T (dv_{i-1} + dw_{i-1} x A + w_{i-1} x (w_{i-1} x A))
           + dw_i x e + w_i x (w_i x e)     (eq. 18)
           [+ 2 w_i x u qd_i + u qdd_i for prismatic joints]
    dv_ci = dv_i + dw_i x c_i + w_i x (w_i x c_i)
    F_i = m_i dv_ci,  N_i = I_i dw_i + w_i x I_i w_i           (eqs. 13, 14)

Inward, from ``f_{n+1} = n_{n+1} = 0``, with ``P`` the origin of frame *i+1*
in frame *i*::

    f_i = R_{i+1} f_{i+1} + F_i
    n_i = R_{i+1} n_{i+1} + P x R_{i+1} f_{i+1} + c_i x F_i + N_i
    tau_i = u . (n_i + e x f_i)   (revolute),   u . f_i   (prismatic)

The code is emitted once per device (and payload), with every constant
folded, and compiled; see :mod:`rworld_cli.codegen`.
"""

from __future__ import annotations

import numpy as np

from ..codegen import Emitter, Generated, Num
from ..kinematics.chain import chain_steps, device_key
from ..model.cell import DeviceModel, Inertial

_CACHE: dict[tuple, Generated] = {}


def _inertial_key(inertials: list[Inertial]) -> tuple:
    return tuple(
        (
            float(i.mass),
            tuple(np.asarray(i.com, float).tolist()),
            tuple(np.asarray(i.inertia, float).ravel().tolist()),
        )
        for i in inertials
    )


def _rnea_outputs(
    em: Emitter, device: DeviceModel, inertials: list[Inertial], q, qd, qdd, g
) -> list[Num]:
    """Emit one Newton-Euler pass; returns the n joint torques (symbolic)."""
    steps = chain_steps(em, device, q)
    zero = (0.0, 0.0, 0.0)
    w, dw, dv = zero, zero, tuple(em.neg(x) for x in g)
    forward = []
    for i, st in enumerate(steps):
        wp = em.mattvec(st.R, w)
        a_axis = em.vadd(dv, em.vadd(em.cross(dw, st.A), em.cross(w, em.cross(w, st.A))))
        if st.prismatic:
            wi, dwi = wp, em.mattvec(st.R, dw)
        else:
            uqd = em.vscale(qd[i], st.u)
            wi = em.vadd(wp, uqd)
            dwi = em.vadd(em.vadd(em.mattvec(st.R, dw), em.cross(wp, uqd)), em.vscale(qdd[i], st.u))
        dvi = em.vadd(
            em.mattvec(st.R, a_axis), em.vadd(em.cross(dwi, st.e), em.cross(wi, em.cross(wi, st.e)))
        )
        if st.prismatic:
            uqd = em.vscale(qd[i], st.u)
            dvi = em.vadd(dvi, em.vadd(em.vscale(2.0, em.cross(wi, uqd)), em.vscale(qdd[i], st.u)))
        inertial = inertials[i]
        c = tuple(float(x) for x in inertial.com)
        I = tuple(tuple(float(x) for x in row) for row in inertial.inertia)
        dvc = em.vadd(dvi, em.vadd(em.cross(dwi, c), em.cross(wi, em.cross(wi, c))))
        F = em.vscale(float(inertial.mass), dvc)
        N = em.vadd(em.matvec(I, dwi), em.cross(wi, em.matvec(I, wi)))
        forward.append((F, N, c))
        w, dw, dv = wi, dwi, dvi
    taus: list[Num] = [0.0] * len(steps)
    f_next, n_next = zero, zero
    for i in reversed(range(len(steps))):
        st = steps[i]
        F, N, c = forward[i]
        if i + 1 < len(steps):
            nxt = steps[i + 1]
            f_child = em.matvec(nxt.R, f_next)
            n_child = em.matvec(nxt.R, n_next)
            P = em.vadd(nxt.A, em.matvec(nxt.R, nxt.e))
            n_child = em.vadd(n_child, em.cross(P, f_child))
        else:
            f_child, n_child = zero, zero
        fi = em.vadd(f_child, F)
        ni = em.vadd(em.vadd(n_child, em.cross(c, F)), N)
        if st.prismatic:
            taus[i] = em.dot(st.u, fi)
        else:
            taus[i] = em.dot(st.u, em.vadd(ni, em.cross(st.e, fi)))
        f_next, n_next = fi, ni
    return taus


def generate_rnea(device: DeviceModel, inertials: list[Inertial], mode: str) -> Generated:
    """Compiled Newton-Euler code for one device and set of link inertials.

    Parameters
    ----------
    mode : {"full", "gravity", "bias", "mass"}
        ``full``: tau(q, qd, qdd, g); ``gravity``: g(q, g); ``bias``:
        C(q, qd) qd + g(q) (qdd = 0); ``mass``: the upper triangle of M(q),
        row by row (qd = 0, g = 0, qdd = unit vectors).
    """
    key = (device_key(device), _inertial_key(inertials), mode)
    if key in _CACHE:
        return _CACHE[key]
    n = device.dof
    em = Emitter()
    q = [f"q{i}" for i in range(n)]
    qd = [f"qd{i}" for i in range(n)]
    qdd = [f"qdd{i}" for i in range(n)]
    g = ["g0", "g1", "g2"]
    zeros = [0.0] * n
    if mode == "full":
        args, outputs = q + qd + qdd + g, _rnea_outputs(em, device, inertials, q, qd, qdd, g)
    elif mode == "gravity":
        args, outputs = q + g, _rnea_outputs(em, device, inertials, q, zeros, zeros, g)
    elif mode == "bias":
        args, outputs = q + qd + g, _rnea_outputs(em, device, inertials, q, qd, zeros, g)
    elif mode == "mass":
        args, outputs = q, []
        for j in range(n):
            unit = [1.0 if k == j else 0.0 for k in range(n)]
            column = _rnea_outputs(em, device, inertials, q, zeros, unit, (0.0, 0.0, 0.0))
            outputs += column[: j + 1]  # M[i, j] for i <= j
    else:
        raise ValueError(f"unknown mode {mode!r}")
    gen = em.compile(f"rnea_{mode}", args, outputs)
    _CACHE[key] = gen
    return gen
