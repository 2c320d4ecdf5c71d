"""Joint-space trajectories: synchronised trapezoidal moves and sampled (linear) moves.

A move is a :class:`Segment` - ``q(t)`` on ``[t0, t1]`` that samples itself
on any array of times.  Between segments a device holds still.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .. import spatial


@dataclass
class TrapezoidProfile:
    """Normalised path parameter s(tau) in [0, 1]: accelerate at A, cruise at V, decelerate.

    Attributes
    ----------
    V, A : float
        Peak speed [1/s] and acceleration [1/s^2] of s.
    T : float
        Duration [s].
    ta : float
        Duration of the acceleration (and deceleration) phase.
    """

    V: float
    A: float
    T: float
    ta: float

    @staticmethod
    def fit(V: float, A: float) -> TrapezoidProfile:
        """Fastest profile for s from 0 to 1 under speed V and acceleration A."""
        if V * V / A >= 1.0:  # never reaches V: triangle
            ta = np.sqrt(1.0 / A)
            return TrapezoidProfile(A * ta, A, 2 * ta, ta)
        return TrapezoidProfile(V, A, 1.0 / V + V / A, V / A)

    def evaluate(self, tau: np.ndarray):
        """s, ds/dt, d2s/dt2 at times ``tau`` (clipped to [0, T])."""
        tau = np.clip(np.asarray(tau, dtype=float), 0.0, self.T)
        V, A, T, ta = self.V, self.A, self.T, self.ta
        rise = tau < ta
        fall = tau > T - ta
        s = np.where(
            rise,
            0.5 * A * tau**2,
            np.where(fall, 1.0 - 0.5 * A * (T - tau) ** 2, V * (tau - 0.5 * ta)),
        )
        ds = np.where(rise, A * tau, np.where(fall, A * (T - tau), V))
        dds = np.where(rise, A, np.where(fall, -A, 0.0))
        return s, ds, dds


class Segment:
    """A move on ``[t0, t1]``."""

    t0: float
    t1: float
    q_end: np.ndarray

    def sample(self, t: np.ndarray):  # pragma: no cover - interface
        raise NotImplementedError


@dataclass
class JointMove(Segment):
    """All joints on one trapezoidal profile, so they start and stop together."""

    t0: float
    q_start: np.ndarray
    q_end: np.ndarray
    profile: TrapezoidProfile

    @property
    def t1(self) -> float:
        return self.t0 + self.profile.T

    def sample(self, t):
        s, ds, dds = self.profile.evaluate(np.asarray(t) - self.t0)
        delta = self.q_end - self.q_start
        return self.q_start + s[:, None] * delta, ds[:, None] * delta, dds[:, None] * delta


class UntimedMove(ValueError):
    """No moving joint has an acceleration limit, so nothing bounds how fast the move could be."""

    def __init__(self, joints: list[int]):
        super().__init__(f"no acceleration limit on the moving joints {joints}")
        self.joints = joints


def joint_move(
    t0: float, q_start, q_end, v_max, a_max, speed: float = 1.0, acceleration: float = 1.0
) -> JointMove | None:
    """Synchronised trapezoidal move within velocity and acceleration limits (scaled), or None if no
    motion.

    Parameters
    ----------
    q_start, q_end : array_like, shape (n,)
    v_max, a_max : array_like, shape (n,)
        Joint velocity and acceleration limits (> 0); ``inf`` for a joint that has none, which
        is then unlimited in that kind while the other joints keep theirs.
    speed, acceleration : float
        Fractions (0, 1] of those limits.

    Raises
    ------
    UntimedMove
        None of the moving joints has an acceleration limit.
    """
    q_start = np.asarray(q_start, dtype=float)
    q_end = np.asarray(q_end, dtype=float)
    delta = np.abs(q_end - q_start)
    moving = delta > 1e-12
    if not moving.any():
        return None
    V = np.min(np.asarray(v_max, dtype=float)[moving] * speed / delta[moving])
    A = np.min(np.asarray(a_max, dtype=float)[moving] * acceleration / delta[moving])
    if not np.isfinite(A):
        raise UntimedMove(np.flatnonzero(moving).tolist())
    return JointMove(t0, q_start, q_end, TrapezoidProfile.fit(V, A))


@dataclass
class SampledMove(Segment):
    """A move given by samples (a linear TCP move solved by IK), interpolated linearly."""

    t0: float
    times: np.ndarray  # (K,) from t0
    q: np.ndarray  # (K, n)
    qd: np.ndarray
    qdd: np.ndarray

    @property
    def t1(self) -> float:
        return float(self.times[-1])

    @property
    def q_end(self) -> np.ndarray:
        return self.q[-1]

    def sample(self, t):
        t = np.asarray(t, dtype=float)
        cols = [
            np.stack([np.interp(t, self.times, a[:, k]) for k in range(a.shape[1])], axis=1)
            for a in (self.q, self.qd, self.qdd)
        ]
        return tuple(cols)


@dataclass
class PathLeg(Segment):
    """One leg of a timed joint path (a planned path driven without stopping at its via
    points): ``sampler(times)`` gives q, qd, qdd (each (N, n)) of the whole path at absolute
    times; this leg is its stretch [t0, t1]."""

    t0: float
    t1: float
    sampler: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]

    def __post_init__(self) -> None:
        self._q_end = self.sampler(np.array([self.t1]))[0][0]

    @property
    def q_end(self) -> np.ndarray:
        return self._q_end

    def sample(self, t):
        return self.sampler(np.asarray(t, dtype=float))


@dataclass
class StoppedMove(Segment):
    """A move cut short at ``t_stop`` (a guarded move whose sensor triggered): it holds there."""

    inner: Segment
    t_stop: float

    def __post_init__(self) -> None:
        self._q_end = self.inner.sample(np.array([self.t_stop]))[0][0]

    @property
    def t0(self) -> float:
        return self.inner.t0

    @property
    def t1(self) -> float:
        return self.t_stop

    @property
    def q_end(self) -> np.ndarray:
        return self._q_end

    def sample(self, t):
        return self.inner.sample(t)


def sample_track(segments: list[Segment], q_init: np.ndarray, times: np.ndarray):
    """q, qd, qdd of a device over ``times`` from its time-ordered segments (holding between
    them).
    """
    times = np.asarray(times, dtype=float)
    N, n = len(times), len(q_init)
    q = np.tile(np.asarray(q_init, dtype=float), (N, 1))
    qd = np.zeros((N, n))
    qdd = np.zeros((N, n))
    for seg in segments:  # loop over moves, each vectorised over its samples
        after = times >= seg.t1
        q[after] = seg.q_end
        qd[after] = 0.0
        qdd[after] = 0.0
        during = (times >= seg.t0) & (times < seg.t1)
        if during.any():
            q[during], qd[during], qdd[during] = seg.sample(times[during])
    return q, qd, qdd


def interpolate_poses(T0: np.ndarray, T1: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Straight-line position and constant-axis rotation between two poses at parameters ``s``
    (K,).
    """
    s = np.asarray(s, dtype=float)
    R0, R1 = T0[:3, :3], T1[:3, :3]
    rotvec = spatial.rotation_vector(R0.T @ R1)
    angle = np.linalg.norm(rotvec)
    out = np.tile(np.eye(4), (len(s), 1, 1))
    out[:, :3, 3] = T0[:3, 3] + s[:, None] * (T1[:3, 3] - T0[:3, 3])
    if angle < 1e-12:
        out[:, :3, :3] = R0
        return out
    axis = rotvec / angle
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    th = s * angle
    Rs = (
        np.eye(3) + np.sin(th)[:, None, None] * K + (1 - np.cos(th))[:, None, None] * (K @ K)
    )  # Rodrigues
    out[:, :3, :3] = R0 @ Rs
    return out
