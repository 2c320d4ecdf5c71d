"""What a simulated run is: its events, limit violations, each device's sampled timeline, and
the result that holds them (:func:`rworld_cli.simulate.engine.simulate` returns it)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..model.program import Program, ResolvedStep


@dataclass
class Event:
    t: float
    device: str
    step: int | None
    kind: str
    detail: str
    tree: dict | None = None  # affixment change: child, parent (None when detached), type, kind
    reading: dict | None = None  # sense steps and guarded moves: the sensor reading

    def as_dict(self) -> dict:
        return {
            "t": self.t,
            "device": self.device,
            "step": None if self.step is None else self.step + 1,  # 1-based, as in text
            "kind": self.kind,
            "detail": self.detail,
            "tree": self.tree,
            "reading": self.reading,
        }


@dataclass
class Violation:
    """A limit exceeded on ``[t_start, t_end]``; ``peak`` is the worst value, ``limit`` the
    bound.
    """

    device: str
    joint: str
    kind: str  # position | velocity | acceleration | torque
    t_start: float
    t_end: float
    peak: float
    limit: float
    step: int | None
    step_text: str

    def as_dict(self) -> dict:
        return {
            k: getattr(self, k)
            for k in (
                "device",
                "joint",
                "kind",
                "t_start",
                "t_end",
                "peak",
                "limit",
                "step_text",
            )
        } | {"step": None if self.step is None else self.step + 1}  # 1-based, as in text

    def describe(self) -> str:
        where = f"step {self.step + 1} ({self.step_text})" if self.step is not None else "at rest"
        return (
            f"{self.device} {self.joint}: {self.kind} {self.peak:.4g} beyond its limit "
            f"{self.limit:.4g} "
            f"from t = {self.t_start:.3f} s to {self.t_end:.3f} s, {where}"
        )


@dataclass
class DeviceTimeline:
    """One device on the uniform clock (SI).

    Attributes
    ----------
    q, qd, qdd, tau : ndarray, shape (K, n)
    tcp : ndarray, shape (K, 4, 4)
        ``T_world_tcp`` of the active TCP.
    step : ndarray of int, shape (K,)
        Index of the program step running at each sample (-1: none).
    ratios : dict
        'velocity' | 'acceleration' | 'torque' -> ndarray (K, n) of |value| / limit (NaN for
        a joint without that limit).
    cycle_time : float
        When the device's program ended [s].
    torque_per_kg : ndarray, shape (K, n), optional
        What 1 kg more at the active TCP's origin adds to ``tau`` [N m / kg] (torque is affine
        in a point mass); computed when :func:`simulate` is asked for payload capacity.
    """

    device: str
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    tcp: np.ndarray
    step: np.ndarray
    ratios: dict
    cycle_time: float
    tcp_names: list = field(default_factory=list)
    torque_per_kg: np.ndarray | None = None
    payload: dict | None = None  # SimulationResult.payload_capacity


@dataclass
class SimulationResult:
    cell: str
    run: str
    dt: float
    times: np.ndarray
    devices: dict[str, DeviceTimeline]
    events: list[Event]
    violations: list[Violation]
    step_texts: dict[str, list[str]]
    unlimited: dict[str, dict[str, list[str]]] = field(
        default_factory=dict
    )  # device -> kind -> joints with no limit
    collisions: Any = None  # simulate.collisions.CollisionReport, or None when not checked
    resolved: dict[str, list[ResolvedStep]] = field(default_factory=dict)  # device -> steps
    step_where: dict[str, list[str]] = field(default_factory=dict)  # device -> 'file:line' per step
    massless: list[str] = field(default_factory=list)  # devices whose links have no mass at all
    # (t, World.snapshot()) at the start and after every affixment change: the tree each stretch
    # of samples ran in (a sample at t belongs to the latest snapshot at or before it)
    snapshots: list[tuple[float, dict]] = field(default_factory=list)

    @property
    def cycle_time(self) -> float:
        """When the last program ended [s]."""
        return max((tl.cycle_time for tl in self.devices.values()), default=0.0)

    @property
    def ok(self) -> bool:
        """No limit violation, no collision, no clearance violation, no impossible handling."""
        return not self.violations and not (self.collisions and self.collisions.failed)

    def peak_ratios(self, device: str) -> dict[str, list[float]]:
        """Per kind, each joint's largest ratio to its limit (NaN: the joint has no limit)."""
        out = {}
        for k, v in self.devices[device].ratios.items():
            if not len(v):
                out[k] = []
                continue
            peak = np.max(np.where(np.isnan(v), -np.inf, v), axis=0)
            out[k] = np.where(np.isfinite(peak), peak, np.nan).tolist()
        return out

    def payload_capacity(self, device: str) -> dict | None:
        """The largest point mass [kg] the device could carry more at its active TCP's origin
        through the whole run with every torque within its limit: ``plan payload`` on the run's
        motion, exact (torque is affine in the mass); what the run carries it carries in any case.

        Returns ``{"mass": kg, "joint": name, "t": s, "side": "upper" | "lower"}`` (the mass is
        negative when the run already overloads a joint a payload loads), or None: simulated
        without ``payload=True``, or no joint with a torque limit feels a payload.
        """
        return self.devices[device].payload


@dataclass
class Track:
    """A device's program as the scheduler runs it: its motion segments so far, where it is
    in the program, whether it runs, waits or is done."""

    program: Program
    segments: list = field(default_factory=list)
    q_init: np.ndarray | None = None
    step_starts: list = field(default_factory=list)  # (t, step index)
    t: float = 0.0
    pc: int = 0
    status: str = "running"  # running | waiting | done
    waiting_on: object = None
    sync_counts: dict = field(default_factory=dict)
    end: float | None = None
