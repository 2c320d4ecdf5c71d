"""Device dynamics: inverse (RNEA), mass matrix, bias and gravity terms,
forward dynamics, time integration, energy, payloads.

All functions take joint arrays of shape ``(n,)`` (one state) or ``(N, n)``
(a batch, vectorised - no Python loop over samples) in SI units, and gravity
as the acceleration vector **in the device's base frame** (the API converts
from world).  Torques are what the actuators apply: ``tau = M qdd + C qd + g``
(plus armature ``Jm G^2 qdd`` and friction when enabled).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..codegen import Generated
from ..kinematics.forward import link_poses
from ..kinematics.jacobian import ToolMount
from ..model.cell import DeviceModel, Inertial
from .rnea import SingularMassMatrix, generate_rnea

DEFAULT_GRAVITY = np.array([0.0, 0.0, -9.81])
DEFAULT_GRAVITY.flags.writeable = False  # shared by every call that gives no gravity


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


def _finite(x: np.ndarray) -> bool:
    """Whether a short 1-D float array is finite, by its sum (False also when the sum of
    finite entries overflows: callers then take their full check)."""
    return math.isfinite(sum(x.tolist()))


def _gravity(gravity, batch: int | None) -> np.ndarray:
    """Gravity as an input row (3,) or, per sample, (N, 3); checked finite."""
    g = np.asarray(gravity, dtype=float)
    if g.shape == (3,):
        x, y, z = g.tolist()  # three floats: cheaper than a numpy reduction on a single state
        if math.isfinite(x) and math.isfinite(y) and math.isfinite(z):
            return g
    if g.ndim == 2 and batch is not None:
        if g.shape != (batch, 3) or not np.all(np.isfinite(g)):
            raise ValueError(
                f"per-sample gravity must be finite with shape ({batch}, 3), got {g.shape}"
            )
        return g
    raise ValueError(f"gravity must be a finite 3-vector, got {g.tolist()}")


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
        self._generated: dict[str, Generated] = {}

    def _gen(self, mode: str) -> Generated:
        generated = self._generated.get(mode)
        if generated is None:
            generated = self._generated[mode] = generate_rnea(
                self.device,
                self.inertials,
                mode,
                self.armature,
                (self.viscous, self.coulomb_positive, self.coulomb_negative),
            )
        return generated

    def _check(self, *arrays) -> list[np.ndarray]:
        out = [np.asarray(a, dtype=float) for a in arrays]
        shape = out[0].shape
        if len(shape) > 2 or shape[-1:] != (self.n,):
            self._wrong_shapes(out)
        for a in out:
            if a.shape != shape:
                self._wrong_shapes(out)
        return out

    def _wrong_shapes(self, arrays: list[np.ndarray]):
        raise ValueError(
            f"joint arrays of '{self.device.name}' must all have shape (n,) or (N, n), n "
            f"= {self.n}; got {[x.shape for x in arrays]}"
        )

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
            Actuator torques [N m] / forces [N], armature and friction included when enabled.
        """
        # one state of float arrays, their shapes checked by the kernel; gravity finite (a
        # finite sum, taken on floats: numpy's reductions cost a microsecond; an overflow only
        # sends it on to the full check)
        tau = self._gen("full").direct(q, qd, qdd, gravity)
        if tau is not None and (gravity is DEFAULT_GRAVITY or _finite(gravity)):
            return tau
        q, qd, qdd = self._check(q, qd, qdd)
        g = (
            gravity
            if gravity is DEFAULT_GRAVITY
            else _gravity(gravity, len(q) if q.ndim == 2 else None)
        )
        return self._gen("full").evaluate([q, qd, qdd, g])

    def gravity_torques(self, q, gravity=DEFAULT_GRAVITY) -> np.ndarray:
        """``g(q)``: the torques that hold the device still; shape like ``q``."""
        (q,) = self._check(q)
        return self._gen("gravity").evaluate([q, _gravity(gravity, None)])

    def nonlinear_torques(self, q, qd, gravity=DEFAULT_GRAVITY) -> np.ndarray:
        """``C(q, qd) qd + g(q)`` (rigid body, no friction); shape like ``q``."""
        q, qd = self._check(q, qd)
        return self._gen("bias").evaluate([q, qd, _gravity(gravity, None)])

    def coriolis_torques(self, q, qd) -> np.ndarray:
        """``C(q, qd) qd``: centrifugal and Coriolis torques."""
        return self.nonlinear_torques(q, qd, np.zeros(3))

    def mass_matrix(self, q) -> np.ndarray:
        """Joint-space inertia ``M(q)`` including the armature; shape (n, n) or (N, n, n)."""
        M = self._gen("mass").direct(q)  # one state of floats, checked by the kernel
        if M is not None:
            return M
        (q,) = self._check(q)
        flat = self._gen("mass").evaluate([q])
        return flat.reshape(flat.shape[:-1] + (self.n, self.n))

    def forward(self, q, qd, tau, gravity=DEFAULT_GRAVITY) -> np.ndarray:
        """Accelerations from torques: ``qdd = M(q)^-1 (tau - C qd - g - friction)``.

        Solved by a generated Cholesky factorisation of ``M`` (armature included).

        Returns
        -------
        ndarray, shape (n,) or (N, n)

        Raises
        ------
        ValueError
            Where ``M`` is singular: a joint that moves no inertia has no defined acceleration.
        """
        try:
            program = self._gen("forward")
        except SingularMassMatrix as error:  # zero by construction, whatever the state
            raise ValueError(
                f"the mass matrix of '{self.device.name}' is singular (joint {error.joint} "
                "moves no inertia): no forward dynamics"
            ) from None
        # one state of float arrays as in inverse(); finite accelerations mean a regular mass
        # matrix (else the full check below)
        qdd = program.direct(q, qd, tau, gravity)
        if qdd is not None and _finite(qdd) and (gravity is DEFAULT_GRAVITY or _finite(gravity)):
            return qdd
        q, qd, tau = self._check(q, qd, tau)
        qdd = program.evaluate([q, qd, tau, _gravity(gravity, None)])
        if not np.all(np.isfinite(qdd)):
            inputs_finite = np.all(np.isfinite(np.concatenate([q, qd, tau], axis=-1)), axis=-1)
            bad = np.argwhere(
                ~np.isfinite(np.atleast_2d(qdd)) & np.atleast_1d(inputs_finite)[:, None]
            )
            if len(bad):  # non-finite inputs give non-finite results, as numpy would
                where = f" at sample {bad[0][0]}" if q.ndim == 2 else ""
                raise ValueError(
                    f"the mass matrix of '{self.device.name}' is singular{where} (joint "
                    f"{bad[0][1] + 1} moves no inertia): no forward dynamics"
                )
        return qdd

    def energy(self, q, qd, gravity=DEFAULT_GRAVITY) -> tuple[np.ndarray, np.ndarray | float]:
        """Kinetic ``qd^T M qd / 2`` and potential ``-sum m_i g . c_i`` energy [J] (base frame)."""
        q, qd = self._check(q, qd)
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
