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


class SingularMassMatrix(ValueError):
    """M(q) has a zero pivot whatever q is: joint ``joint`` (1-based) moves no inertia."""

    def __init__(self, joint: int):
        super().__init__(f"joint {joint} moves no inertia")
        self.joint = joint


def _cholesky_solve(em: Emitter, M: list[list[Num]], rhs: list[Num]) -> list[Num]:
    """Emit ``M^-1 rhs`` for a symmetric positive definite ``M``, by Cholesky ``M = L L^T``.

    A singular ``M`` (a joint that moves no inertia) gives non-finite values, which the caller
    reports.
    """
    n = len(rhs)
    L: list[list[Num]] = [[0.0] * n for _ in range(n)]
    inverse_diagonal: list[Num] = [0.0] * n
    for j in range(n):
        s = M[j][j]
        for k in range(j):
            s = em.sub(s, em.mul(L[j][k], L[j][k]))
        if isinstance(s, float) and s <= 0.0:
            raise SingularMassMatrix(j + 1)
        L[j][j] = em.call("sqrt", s)
        inverse_diagonal[j] = em.div(1.0, L[j][j])
        for i in range(j + 1, n):
            s = M[i][j]
            for k in range(j):
                s = em.sub(s, em.mul(L[i][k], L[j][k]))
            L[i][j] = em.mul(s, inverse_diagonal[j])
    y: list[Num] = [0.0] * n
    for i in range(n):  # L y = rhs
        s = rhs[i]
        for k in range(i):
            s = em.sub(s, em.mul(L[i][k], y[k]))
        y[i] = em.mul(s, inverse_diagonal[i])
    x: list[Num] = [0.0] * n
    for i in reversed(range(n)):  # L^T x = y
        s = y[i]
        for k in range(i + 1, n):
            s = em.sub(s, em.mul(L[k][i], x[k]))
        x[i] = em.mul(s, inverse_diagonal[i])
    return x


def _mass_matrix(em: Emitter, device, inertials, q, armature) -> list[list[Num]]:
    """Emit M(q) column by column (Newton-Euler with qd = 0, g = 0, qdd = unit vectors)."""
    n = device.dof
    zeros = [0.0] * n
    M: list[list[Num]] = [[0.0] * n for _ in range(n)]
    for j in range(n):
        unit = [1.0 if k == j else 0.0 for k in range(n)]
        column = _rnea_outputs(em, device, inertials, q, zeros, unit, (0.0, 0.0, 0.0))
        for i in range(j + 1):  # the upper triangle; the lower one is its mirror
            M[i][j] = M[j][i] = column[i]
    for j in range(n):
        M[j][j] = em.add(M[j][j], float(armature[j]))
    return M


MODES = ("full", "gravity", "bias", "mass", "forward")


def generate_rnea(
    device: DeviceModel,
    inertials: list[Inertial],
    mode: str,
    armature=None,
    friction=None,
) -> Generated:
    """Generated Newton-Euler code for one device and set of link inertials.

    Parameters
    ----------
    mode : {"full", "gravity", "bias", "mass", "forward"}
        ``full``: actuator torques tau(q, qd, qdd, g), armature and friction included;
        ``gravity``: g(q, g); ``bias``: C(q, qd) qd + g(q) (rigid body, no friction);
        ``mass``: M(q) with the armature on its diagonal, n x n row by row;
        ``forward``: qdd(q, qd, tau, g) = M^-1 (tau - C qd - g - friction), by Cholesky.
    armature : sequence of float, optional
        ``Jm G^2`` per joint [kg m^2]; default none.
    friction : (viscous, coulomb_positive, coulomb_negative), optional
        Per-joint friction coefficients; default none.
    """
    n = device.dof
    armature = tuple(float(x) for x in (armature if armature is not None else [0.0] * n))
    if friction is None:
        friction = ([0.0] * n,) * 3
    viscous, coulomb_positive, coulomb_negative = (
        tuple(float(x) for x in column) for column in friction
    )
    key = (
        device_key(device),
        _inertial_key(inertials),
        mode,
        armature,
        viscous,
        coulomb_positive,
        coulomb_negative,
    )
    if key in _CACHE:
        return _CACHE[key]
    em = Emitter()
    q = [f"q{i}" for i in range(n)]
    qd = [f"qd{i}" for i in range(n)]
    qdd = [f"qdd{i}" for i in range(n)]
    g = ["g0", "g1", "g2"]
    zeros = [0.0] * n

    def friction_torque(i: int) -> Num:
        return em.add(
            em.mul(qd[i], viscous[i]), em.coulomb(qd[i], coulomb_positive[i], coulomb_negative[i])
        )

    outputs: list[Num]
    if mode == "full":
        groups = [("q", n), ("qd", n), ("qdd", n), ("g", 3)]
        rigid = _rnea_outputs(em, device, inertials, q, qd, qdd, g)
        outputs = [
            em.add(em.add(rigid[i], em.mul(qdd[i], armature[i])), friction_torque(i))
            for i in range(n)
        ]
    elif mode == "gravity":
        groups = [("q", n), ("g", 3)]
        outputs = _rnea_outputs(em, device, inertials, q, zeros, zeros, g)
    elif mode == "bias":
        groups = [("q", n), ("qd", n), ("g", 3)]
        outputs = _rnea_outputs(em, device, inertials, q, qd, zeros, g)
    elif mode == "mass":
        groups = [("q", n)]
        M = _mass_matrix(em, device, inertials, q, armature)
        outputs = [M[i][j] for i in range(n) for j in range(n)]
    elif mode == "forward":
        tau = [f"tau{i}" for i in range(n)]
        groups = [("q", n), ("qd", n), ("tau", n), ("g", 3)]
        bias = _rnea_outputs(em, device, inertials, q, qd, zeros, g)
        rhs = [em.sub(em.sub(tau[i], bias[i]), friction_torque(i)) for i in range(n)]
        outputs = _cholesky_solve(em, _mass_matrix(em, device, inertials, q, armature), rhs)
    else:
        raise ValueError(f"unknown mode {mode!r}; one of {', '.join(MODES)}")
    shapes = [(n, n)] if mode == "mass" else None  # a single state's M comes as a matrix
    gen = em.compile(f"rnea_{mode}", groups, outputs, shapes)
    _CACHE[key] = gen
    return gen
