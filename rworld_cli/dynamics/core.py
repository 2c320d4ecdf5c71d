"""Device dynamics: inverse (RNEA), mass matrix, bias and gravity terms,
forward dynamics, time integration, energy, payloads.

All functions take joint arrays of shape ``(n,)`` (one state) or ``(N, n)``
(a batch, vectorised - no Python loop over samples) in SI units, and gravity
as the acceleration vector **in the device's base frame** (the API converts
from world).  Torques are what the actuators apply: ``tau = M qdd + C qd + g``
(plus armature ``Jm G^2 qdd`` and friction when enabled).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..codegen import Generated
from ..kinematics.forward import link_poses
from ..kinematics.jacobian import ToolMount
from ..model.cell import DeviceModel, Inertial
from .rnea import generate_rnea

DEFAULT_GRAVITY = np.array([0.0, 0.0, -9.81])


@dataclass(frozen=True)
class Payload:
    """A load carried at a tool frame: the report's dual representation.

    Attributes
    ----------
    mass : float
        [kg]
    com : ndarray, shape (3,)
        Centre of mass in the tool frame [m].
    inertia : ndarray, shape (3, 3)
        About the centre of mass, tool-frame axes [kg m^2]; zero for a lumped point mass.
    """

    mass: float
    com: np.ndarray
    inertia: np.ndarray

    @staticmethod
    def point_mass(mass: float, com=(0.0, 0.0, 0.0)) -> Payload:
        """A lumped mass at ``com`` (tool frame)."""
        return Payload(float(mass), np.asarray(com, dtype=float), np.zeros((3, 3)))

    @staticmethod
    def rigid_body(inertial: Inertial, T_tool_body=None) -> Payload:
        """A body with mass properties ``inertial`` (in its own frame) held at ``T_tool_body``."""
        T = np.eye(4) if T_tool_body is None else np.asarray(T_tool_body, dtype=float)
        R = T[:3, :3]
        return Payload(inertial.mass, R @ inertial.com + T[:3, 3], R @ inertial.inertia @ R.T)

    def in_link_frame(self, T_link_tool) -> Inertial:
        """The payload as an :class:`Inertial` in the frame of the link that carries the tool."""
        T = np.asarray(T_link_tool, dtype=float)
        R = T[:3, :3]
        return Inertial(self.mass, R @ self.com + T[:3, 3], R @ self.inertia @ R.T)


def combine_inertials(a: Inertial, b: Inertial) -> Inertial:
    """Mass properties of two bodies fixed together (both given in the same frame).

    Uses the parallel-axis theorem about the combined centre of mass.
    """
    return Inertial.combine([(a, np.eye(4)), (b, np.eye(4))])


def _as_batch(*arrays) -> tuple[bool, list[np.ndarray]]:
    out = [np.asarray(a, dtype=float) for a in arrays]
    return out[0].ndim == 1, out


def _columns(x: np.ndarray, single: bool) -> list:
    return x.tolist() if single else list(np.ascontiguousarray(x.T))


def _gravity(gravity) -> list[float]:
    g = np.asarray(gravity, dtype=float)
    if g.shape != (3,) or not np.all(np.isfinite(g)):
        raise ValueError(f"gravity must be a finite 3-vector, got {g.tolist()}")
    return [float(x) for x in g]


class DeviceDynamics:
    """Dynamics of one device with its options fixed (payload, armature, friction).

    Parameters
    ----------
    device : DeviceModel
    payload : Payload, optional
        Carried at ``mount`` (default: at the last link's frame).
    mount : ToolMount, optional
        Where the payload's tool frame sits.
    armature : bool
        Add motor inertia reflected to the joints, ``Jm G^2``, when declared.
    friction : bool
        Add viscous and Coulomb friction torques, when declared.
    link_loads : dict, optional
        Link index (1..n) -> list of (Inertial, T_link_body): bodies riding on
        that link (grasped objects, aggregated devices), folded into its mass properties.

    Notes
    -----
    Coulomb friction uses ``sign(qd)`` with ``sign(0) = 0``: no stiction.
    """

    def __init__(
        self,
        device: DeviceModel,
        payload: Payload | None = None,
        mount: ToolMount | None = None,
        armature: bool = True,
        friction: bool = True,
        link_loads: dict | None = None,
    ):
        self.device = device
        self.n = device.dof
        mount = mount or ToolMount(device.dof)
        inertials = [link.inertial for link in device.links]
        if payload is not None and payload.mass > 0:
            if mount.link == 0:
                raise ValueError("a payload on the base does not load the joints")
            k = mount.link - 1
            inertials[k] = combine_inertials(inertials[k], payload.in_link_frame(mount.T_link_tool))
        for link, bodies in (link_loads or {}).items():
            if not 1 <= link <= self.n:
                raise ValueError(f"link_loads: link {link} is not in 1..{self.n}")
            for inertial, T in bodies:
                inertials[link - 1] = combine_inertials(
                    inertials[link - 1], Payload.rigid_body(inertial, T).in_link_frame(np.eye(4))
                )
        self.inertials = inertials
        self.payload = payload
        self.armature = (
            np.array([j.armature for j in device.joints]) if armature else np.zeros(self.n)
        )
        if friction:
            self.viscous = np.array([j.viscous for j in device.joints])
            self.coulomb_positive = np.array([j.coulomb_positive for j in device.joints])
            self.coulomb_negative = np.array([j.coulomb_negative for j in device.joints])
        else:
            self.viscous = self.coulomb_positive = self.coulomb_negative = np.zeros(self.n)
        self._has_friction = bool(
            np.any(self.viscous) or np.any(self.coulomb_positive) or np.any(self.coulomb_negative)
        )

    def _gen(self, mode: str) -> Generated:
        return generate_rnea(self.device, self.inertials, mode)

    def _check(self, *arrays):
        single, arrays = _as_batch(*arrays)
        for a in arrays:
            if a.shape != arrays[0].shape or a.shape[-1] != self.n or a.ndim not in (1, 2):
                raise ValueError(
                    f"joint arrays of '{self.device.name}' must all have shape (n,) or (N, n), n "
                    f"= {self.n}; got {[x.shape for x in arrays]}"
                )
        return single, arrays

    def friction_torque(self, qd) -> np.ndarray:
        """Actuator torque that overcomes friction: ``B qd + Tc+ [qd > 0] - Tc- [qd < 0]``."""
        qd = np.asarray(qd, dtype=float)
        if not self._has_friction:
            return np.zeros_like(qd)
        return (
            self.viscous * qd
            + np.where(qd > 0, self.coulomb_positive, 0.0)
            - np.where(qd < 0, self.coulomb_negative, 0.0)
        )

    def inverse(self, q, qd, qdd, gravity=DEFAULT_GRAVITY) -> np.ndarray:
        """Joint torques for a motion, by recursive Newton-Euler.

        Parameters
        ----------
        q, qd, qdd : array_like, shape (n,) or (N, n)
            Positions [rad, m], velocities [/s], accelerations [/s^2].
        gravity : array_like, shape (3,) or (N, 3)
            Acceleration of gravity in the base frame [m/s^2]; per sample for
            a base that accelerates (``g - a_base``, in base axes).

        Returns
        -------
        ndarray, shape (n,) or (N, n)
            Actuator torques [N m] / forces [N].
        """
        single, (q, qd, qdd) = self._check(q, qd, qdd)
        cols = _columns(q, single) + _columns(qd, single) + _columns(qdd, single)
        g = np.asarray(gravity, dtype=float)
        if g.ndim == 2 and not single:
            if g.shape != (q.shape[0], 3) or not np.all(np.isfinite(g)):
                raise ValueError(
                    f"per-sample gravity must be finite with shape ({q.shape[0]}, 3), got {g.shape}"
                )
            tau = self._gen("full").evaluate(
                cols + list(np.ascontiguousarray(g.T)), (), self.n, single
            )
        else:
            tau = self._gen("full").evaluate(cols, _gravity(g), self.n, single)
        tau += self.armature * qdd
        if self._has_friction:
            tau += self.friction_torque(qd)
        return tau

    def gravity_torques(self, q, gravity=DEFAULT_GRAVITY) -> np.ndarray:
        """``g(q)``: the torques that hold the device still; shape like ``q``."""
        single, (q,) = self._check(q)
        return self._gen("gravity").evaluate(_columns(q, single), _gravity(gravity), self.n, single)

    def nonlinear_torques(self, q, qd, gravity=DEFAULT_GRAVITY) -> np.ndarray:
        """``C(q, qd) qd + g(q)`` (rigid body, no friction); shape like ``q``."""
        single, (q, qd) = self._check(q, qd)
        cols = _columns(q, single) + _columns(qd, single)
        return self._gen("bias").evaluate(cols, _gravity(gravity), self.n, single)

    def coriolis_torques(self, q, qd) -> np.ndarray:
        """``C(q, qd) qd``: centrifugal and Coriolis torques."""
        return self.nonlinear_torques(q, qd, np.zeros(3))

    def mass_matrix(self, q) -> np.ndarray:
        """Joint-space inertia ``M(q)`` including the armature; shape (n, n) or (N, n, n)."""
        single, (q,) = self._check(q)
        n = self.n
        upper = self._gen("mass").evaluate(_columns(q, single), (), n * (n + 1) // 2, single)
        M = np.empty(upper.shape[:-1] + (n, n))
        k = 0
        for j in range(n):
            for i in range(j + 1):
                M[..., i, j] = upper[..., k]
                M[..., j, i] = upper[..., k]
                k += 1
        M[..., np.arange(n), np.arange(n)] += self.armature
        return M

    def forward(self, q, qd, tau, gravity=DEFAULT_GRAVITY) -> np.ndarray:
        """Accelerations from torques: ``qdd = M(q)^-1 (tau - C qd - g - friction)``.

        Returns
        -------
        ndarray, shape (n,) or (N, n)
        """
        single, (q, qd, tau) = self._check(q, qd, tau)
        rhs = tau - self.nonlinear_torques(q, qd, gravity) - self.friction_torque(qd)
        M = self.mass_matrix(q)
        return np.linalg.solve(M, rhs[..., None])[..., 0]

    def energy(self, q, qd, gravity=DEFAULT_GRAVITY) -> tuple[np.ndarray, np.ndarray | float]:
        """Kinetic ``qd^T M qd / 2`` and potential ``-sum m_i g . c_i`` energy [J] (base frame)."""
        single, (q, qd) = self._check(q, qd)
        M = self.mass_matrix(q)
        kinetic = 0.5 * np.einsum("...i,...ij,...j->...", qd, M, qd)
        T = link_poses(self.device, q)
        potential = 0.0
        for i, inertial in enumerate(self.inertials):
            com = np.einsum("...ij,j->...i", T[..., i, :3, :3], inertial.com) + T[..., i, :3, 3]
            potential = potential - inertial.mass * (com @ np.asarray(gravity, dtype=float))
        return kinetic, potential


def integrate(
    dynamics: DeviceDynamics,
    q0,
    qd0,
    times,
    tau,
    gravity=DEFAULT_GRAVITY,
    method: str = "rk4",
    substeps: int = 1,
    rtol: float = 1e-9,
    atol: float = 1e-9,
) -> tuple[np.ndarray, np.ndarray]:
    """Simulate the device under a torque profile.

    Parameters
    ----------
    q0, qd0 : array_like, shape (n,)
        Initial state.
    times : array_like, shape (T,)
        Increasing sample times [s]; the state is returned at these times.
    tau : array_like, shape (T, n)
        Actuator torques at ``times``, linearly interpolated in between.
    method : {"rk4", "RK45", "DOP853", "Radau", "LSODA", ...}
        ``rk4``: fixed-step classical Runge-Kutta on the time grid (``substeps``
        steps per interval); anything else is passed to ``scipy.integrate.solve_ivp``.

    Returns
    -------
    q, qd : ndarray, shape (T, n)
    """
    times = np.asarray(times, dtype=float)
    tau = np.asarray(tau, dtype=float)
    n = dynamics.n
    if times.ndim != 1 or len(times) < 2 or np.any(np.diff(times) <= 0):
        raise ValueError("times must be a strictly increasing 1-D array of at least 2 samples")
    if tau.shape != (len(times), n):
        raise ValueError(f"tau must have shape ({len(times)}, {n}), got {tau.shape}")

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        torque = np.array([np.interp(t, times, tau[:, k]) for k in range(n)])
        return np.concatenate([y[n:], dynamics.forward(y[:n], y[n:], torque, gravity)])

    y0 = np.concatenate([np.asarray(q0, dtype=float), np.asarray(qd0, dtype=float)])
    if method == "rk4":
        out = np.empty((len(times), 2 * n))
        out[0] = y = y0
        for k in range(len(times) - 1):  # time stepping is inherently sequential
            h = (times[k + 1] - times[k]) / substeps
            t = times[k]
            for _ in range(substeps):
                k1 = rhs(t, y)
                k2 = rhs(t + h / 2, y + h / 2 * k1)
                k3 = rhs(t + h / 2, y + h / 2 * k2)
                k4 = rhs(t + h, y + h * k3)
                y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
                t += h
            out[k + 1] = y
        return out[:, :n], out[:, n:]
    from scipy.integrate import solve_ivp

    sol = solve_ivp(
        rhs, (times[0], times[-1]), y0, method=method, t_eval=times, rtol=rtol, atol=atol
    )
    if not sol.success:
        raise RuntimeError(f"integration failed: {sol.message}")
    return sol.y[:n].T, sol.y[n:].T
