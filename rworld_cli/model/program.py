"""Programs and runs as data: resolved steps per device, the programs that run together on a
cell.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import Issue
from .cell import CellModel


@dataclass
class FeatureGoal:
    """A feature step's geometry, checked and in SI (``docs/programs.md``); resolved against
    the features' current poses when the program runs.

    Attributes
    ----------
    feature : str
        The target feature (qualified): a move's, the hole, the surface set down on, the edge
        followed, the feature probed.
    at : float or ndarray (2,) or str or None
        A line: the distance along it [m]; a plane: [u, v] from its point [m], or another
        feature of the same object whose point is projected onto the plane.
    standoff : float
        [m] out of the material.
    spin : float or None
        [rad] about the free axis; None: chosen for reach.
    held : str or None
        insert / place: the held object's feature brought onto the target.
    depth : float
        insert: [m] past the rim.
    approach : float
        insert / place / follow: the straight approach [m].
    extent : (float or None, float or None)
        follow: start and end along the line [m] (None: the material's ends).
    speed : float or None
        follow: the tool's speed along the line [m/s].
    points : int or None
        probe: how many points the probing moves take.
    """

    feature: str
    at: float | np.ndarray | str | None = None
    standoff: float = 0.0
    spin: float | None = None
    held: str | None = None
    depth: float = 0.0
    approach: float = 0.0
    extent: tuple[float | None, float | None] = (None, None)
    speed: float | None = None
    points: int | None = None
    where: str = ""  # file:line:col of the feature in the program, for messages


@dataclass
class Step:
    """One resolved program step.

    Attributes
    ----------
    index : int
        0-based position in its program.
    kind : str
        move | grasp | release | place | attach_tool | detach_tool | wait | sync | sense | capture
        | probe
    spec : object
        The step's parameters, by attribute as in ``docs/simulation.md`` (``to``, ``tcp``,
        ``speed``,
        ``object``, ...); fractions, times [s] and names - lengths and angles are in ``T_offset``.
    where : str
        ``file:line`` of the step, for messages.
    T_offset : ndarray, shape (4, 4)
        Move offsets in SI (identity when none).
    touch : dict
        A move's ``touch:`` bodies -> the depth they may be touched to [m] (None: the run's
        collision tolerance).
    configuration, near
        A move's ``config:``: the arm configuration asked for ({"elbow": "up", ...}), and the
        joint values to take the IK solution nearest to.
    """

    index: int
    kind: str
    spec: Any
    where: str
    T_offset: np.ndarray = field(default_factory=lambda: np.eye(4))
    touch: dict[str, float | None] = field(default_factory=dict)
    configuration: dict[str, str] = field(default_factory=dict)  # shoulder, elbow, wrist
    near: np.ndarray | None = None  # (n,) joint values to take the solution nearest to (SI)
    arm_angle: float | None = None  # [rad] a 7-axis arm's arm angle (config: {arm_angle})
    joints: np.ndarray | None = None  # (n,) a move's joint goal (``joints:``), SI
    waypoints: np.ndarray | None = None  # (W, n) a move along a path file's segments, SI
    blends: np.ndarray | None = None  # (W,) its corners' blends (a 'blended' path file)
    goal: FeatureGoal | None = None  # a step on features (docs/programs.md)

    def describe(self) -> str:
        s = self.spec
        if self.kind == "move" and self.goal is not None:
            return (
                f"move to {self.goal.feature}"
                + (f" ({self.goal.standoff * 1000:g} mm out)" if self.goal.standoff else "")
                + (" (linear)" if s.motion == "linear" else "")
                + (f" until {s.until}" if s.until else "")
            )
        if self.kind == "move" and self.waypoints is not None:
            return f"move along {s.path}"
        if self.kind == "move":
            return (
                f"move to {s.to if s.to is not None else 'joint values'}"
                + (" (linear)" if s.motion == "linear" else "")
                + (" (free path)" if getattr(s, "path", "straight") == "free" else "")
                + (f" until {s.until}" if s.until else "")
            )
        if self.kind in ("grasp", "release"):
            return f"{self.kind} {s.object}"
        if self.kind == "place":
            return f"place {s.object} on {s.on}"
        if self.kind == "insert":
            return f"insert {s.object} into {s.into}"
        if self.kind == "follow":
            return f"follow {s.edge}"
        if self.kind in ("attach_tool", "detach_tool"):
            return f"{self.kind} {s.tool}"
        if self.kind == "wait":
            return f"wait {s.time} s" if s.time is not None else f"wait for {s.for_}"
        if self.kind == "sense":
            return f"sense {s}"
        if self.kind == "capture":
            return f"capture {s.camera}"
        if self.kind == "probe":
            return f"probe {s.feature}" + (
                f" ({self.goal.points} points)" if self.goal is not None else ""
            )
        return f"sync {s}"


@dataclass
class Program:
    device: str
    file: str
    steps: list[Step]


@dataclass
class Run:
    """A cell and the programs that run together on it."""

    cell: CellModel
    programs: list[Program]
    dt: float
    file: str
    warnings: list[Issue] = field(default_factory=list)
    clearance: float = 0.0  # required distance between bodies that may not touch [m]
    collision_tolerance: float = 1e-3  # contacts shallower may be missed between instants [m]
    paths: str = "straight"  # the path: of joint moves that give none ('straight' | 'free')
    seed: int = 0  # the planner's seed of each free path: this plus the step's index
    timeout: float = 10.0  # [s] each free path's search gives up after this


@dataclass
class MoveTarget:
    """Where a move went, as the simulation resolved it (SI, the device's base frame).

    Attributes
    ----------
    motion : {"joint", "linear"}
    target : str
        The frame, or the named joint position (``home``, ``ready``) moved to.
    tcp : str
        The qualified TCP frame the move steered.
    link : int
        The link (1..n) that carries the TCP.
    T_link_tcp : ndarray, shape (4, 4)
        The TCP in that link's frame: the tool data.
    q_start, q_goal : ndarray, shape (n,)
        Joint values at the start and the end (the IK solution the simulation chose; where a
        guarded move stopped).
    T_base_tcp : ndarray, shape (4, 4)
        The TCP at ``q_goal`` in the device's base frame.
    t0, t1 : float
        When the move ran [s].
    speed, acceleration : float
        The step's fractions of the limits.
    guard : str or None
        A guarded move's sensor (``until:``): the move searches towards its planned end and
        stops when the sensor senses; ``q_goal`` and ``T_base_tcp`` are where the simulation
        stopped, ``q_planned`` and ``T_base_planned`` where it would have ended.
    blend : BlendZone or None
        A via point of a planned path passed without stopping: ``q_goal`` is the via point
        (what a controller is sent), the motion cuts its corner by this blend.
    """

    motion: str
    target: str
    tcp: str
    link: int
    T_link_tcp: np.ndarray
    q_start: np.ndarray
    q_goal: np.ndarray
    T_base_tcp: np.ndarray
    t0: float
    t1: float
    speed: float
    acceleration: float
    guard: str | None = None
    q_planned: np.ndarray | None = None
    T_base_planned: np.ndarray | None = None
    blend: BlendZone | None = None


@dataclass(frozen=True)
class BlendZone:
    """How a via point of a path timed as one is blended (SI): the motion leaves the line
    into the via point and joins the next one without stopping, by the parabolic blend
    rworld checked (``planning.path.blended_pieces``).

    Attributes
    ----------
    fraction : float
        The blend's half-width as a fraction of the shorter segment beside it (0, 0.5].
    before, after : float
        Where the blend leaves the incoming line and joins the outgoing one, as fractions of
        each (joint-space length): (0, 0.5].
    joint : float
        Where the blend leaves or joins the lines, the larger joint change from the via
        point, on the nearer side [rad or m].
    tcp : float
        The same as a TCP distance [m], on the nearer side.
    """

    fraction: float
    before: float
    after: float
    joint: float
    tcp: float


@dataclass
class ResolvedStep:
    """One action of a step as the simulation carried it out, in the order it happened: what
    exporters write (``rworld export program``).  A step may act several times (a feature
    step's moves, a ``place:`` on a feature that moves and then lets go, a ``probe:`` on a
    feature that touches and records each point): each action is one entry.

    Attributes
    ----------
    step : Step
        The program step (kind, parameters, ``file:line``).
    t0 : float
        When the action happened [s].
    move : MoveTarget or None
        For moves.
    action : str or None
        What happened when it is not a move: ``grasp``, ``release``, ``place``,
        ``attach_tool``, ``detach_tool`` (the affixment tree changed), ``probe`` (a contact
        recorded), ``capture`` (an image taken: the camera is ``step.spec.camera``); None: the step
        itself (a wait, a sync, a sense).
    feature : str or None
        A ``probe`` action's feature.
    """

    step: Step
    t0: float
    move: MoveTarget | None = None
    action: str | None = None
    feature: str | None = None

    @property
    def kind(self) -> str:
        """``move``, the action, or the step's kind."""
        if self.move is not None:
            return "move"
        return self.action or self.step.kind
