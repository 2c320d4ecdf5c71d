"""Pydantic models of robot programs and run files.

A program belongs to one device and names only primitives of the cell:
frames, objects, devices, the device's named positions.  The numbers that
locate those frames live in the cell's pose files, so calibration moves
where a program goes without touching the program (the report, section 6).
The only numbers a program holds are timing (speed fractions, waits) and
optional offsets relative to a named frame.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from ..units import parse_duration, parse_length
from .models import FrameRef, Name, PartUnits, Pose, Strict

Fraction = Annotated[float, Field(gt=0, le=1)]


class ConfigSpec(Strict):
    """The joint solution a Cartesian target is reached with (docs/programs.md)."""

    shoulder: Literal["front", "back"] | None = Field(
        None, description="The wrist centre in front of axis 1, or behind it (overhead)."
    )
    elbow: Literal["up", "down"] | None = Field(
        None, description="The elbow above the line from the shoulder to the wrist, or below."
    )
    wrist: Literal["noflip", "flip"] | None = Field(
        None,
        description="Axis 5 bent the way that points the tool down from a forearm "
        "reaching forward, or the other way.",
    )
    near: list[float] | None = Field(
        None,
        description="Joint values (the file's units) to take the solution nearest to, instead "
        "of the joints' values before the move.",
    )
    arm_angle: float | str | None = Field(
        None,
        description="A 7-axis arm (shoulder, elbow, wrist: the LBR iiwa, Med): the turn of the "
        "plane through shoulder, elbow and wrist about the shoulder-wrist line, from the "
        "vertical plane through it ('30deg', or the file's angle unit; docs/programs.md).",
    )


Length = float | str  # a bare number in the file's length unit, or '20mm'
Angle = float | str  # a bare number in the file's angle unit, or '90deg'


class FeatureTarget(Strict):
    """A target on a feature (docs/programs.md): its geometry, resolved when the program runs."""

    feature: FrameRef = Field(description="The feature, 'object.feature'.")
    standoff: Length = Field(
        0.0,
        description="How far out of the material: along a plane's or circle's normal, back "
        "from a line.",
    )
    at: list[Length] | Length | FrameRef | None = Field(
        None,
        description="Where on the feature: [u, v] in a plane from its point, a distance along "
        "a line, or another feature of the same object (a point or a circle's centre) "
        "projected onto the plane. Default: the feature's point (a circle's centre).",
    )
    spin: Angle | None = Field(
        None,
        description="The turn of the tool about the feature's free axis (z; a line's own "
        "direction). Default: chosen for reach and the configuration.",
    )


class MoveSpec(Strict):
    """Move the device: its TCP to a frame (joint or linear), or its joints to a named position."""

    to: FeatureTarget | FrameRef | None = Field(
        None,
        description="A frame of the cell, a named position of the device, 'home', or a target "
        "on a feature ({feature: plate.top, standoff: 20}).",
    )
    joints: list[float] | None = Field(
        None,
        description="Instead of 'to': joint values to move to (the file's units: angle for "
        "revolute, length for prismatic joints), joint-interpolated.",
    )
    motion: Literal["joint", "linear"] = Field(
        "joint", description="Joint-interpolated, or a straight TCP line."
    )
    tcp: FrameRef | None = Field(
        None, description="The tool frame to bring to the target; default the active TCP."
    )
    offset: Pose | None = Field(
        None, description="Target = the frame moved by this pose, in the frame's own axes."
    )
    position_only: bool = Field(
        False,
        description="Match the TCP position only (automatic for devices with fewer than 6 joints).",
    )
    speed: Fraction = Field(
        1.0, description="Fraction of the velocity limits (joint) or of the linear speed (linear)."
    )
    acceleration: Fraction = Field(1.0, description="Fraction of the acceleration limits.")
    until: Name | None = Field(
        None, description="Guarded move: stop where this sensor first senses something."
    )
    config: ConfigSpec | None = Field(
        None,
        description="A joint move: the arm configuration (shoulder, elbow, wrist) or the joint "
        "values to reach the target nearest to. A linear move: the configuration it must end in "
        "(a straight line cannot change it).",
    )
    touch: list[FrameRef] | dict[FrameRef, float | str] = Field(
        default_factory=list,
        description="Bodies the device and what it carries may touch during this move (a probe, "
        "a guarded approach, setting a part down): objects, devices or links as 'device.link'. "
        "A list allows contact up to the run's collision tolerance; a mapping gives each body "
        "the depth it may be touched to ({table: 2mm}, a bare number in the program's length "
        "unit). Deeper is a collision.",
    )

    path: str = Field(
        "straight",
        description="A joint move: 'straight' goes along the straight line in joint space; "
        "'free' plans a collision-free joint path when the step runs (in the world as it is "
        "then: other devices, grasps, calibrated poses) and goes through its via points; a "
        "path file (paths/a.yaml, relative to the program; 'boundary: segments', as 'rworld "
        "plan path' writes it) is driven through its waypoints, from the joints the step "
        "starts at (docs/planning.md).",
    )
    seed: Annotated[int, Field(ge=0)] | None = Field(
        None,
        description="'path: free': the planner's random seed (the same world, start and seed "
        "give the same path). Default: the run's seed plus the step's position in its program.",
    )
    timeout: float | str | None = Field(
        None,
        description="'path: free': how long the planner may search, e.g. '30s' (a bare number "
        "is seconds). Default: the run's 'timeout'.",
    )

    @field_validator("timeout")
    @classmethod
    def _a_duration(cls, value):
        return None if value is None else parse_duration(value, "timeout")

    @model_validator(mode="after")
    def _one_goal(self):
        if self.path not in ("straight", "free"):  # a path file: its last waypoint is the goal
            if self.to is not None or self.joints is not None:
                raise ValueError("a move along a path file has its goal there: no 'to' or 'joints'")
            if (
                self.motion == "linear"
                or self.offset is not None
                or self.config is not None
                or self.until is not None
            ):
                raise ValueError(
                    "a move along a path file is joint moves through its waypoints: no linear "
                    "motion, offset, config or guard ('until')"
                )
            return self
        if (self.to is None) == (self.joints is None):
            raise ValueError(
                "give the move one goal: 'to' (a frame or position), 'joints' or a path file "
                "('path: paths/a.yaml')"
            )
        if self.joints is not None and (
            self.motion == "linear" or self.offset is not None or self.config is not None
        ):
            raise ValueError("'joints' is a joint move: no linear motion, offset or config")
        if self.path == "free" and (self.motion == "linear" or self.until is not None):
            raise ValueError(
                "'path: free' plans a joint move: no linear motion, no guarded move ('until')"
            )
        steering = [k for k in ("seed", "timeout") if getattr(self, k) is not None]
        planned = self.path == "free" or (
            "path" not in self.model_fields_set and self.motion != "linear" and self.until is None
        )
        if steering and not planned:
            raise ValueError(
                f"'{' and '.join(steering)}' steer the planner of a 'path: free' move; this "
                "move is not planned (give 'path: free', or drop them)"
            )
        return self


class ObjectRef(Strict):
    object: Name
    tcp: FrameRef | None = Field(
        None, description="Grasp: the TCP that takes the object; default the active TCP."
    )


class PlaceSpec(Strict):
    object: FrameRef = Field(
        description="The held object; or its face ('part.bottom') to set down on a feature."
    )
    on: FrameRef = Field(
        description="The frame the object now rests on (non-rigid); or a plane feature "
        "('table.top') to set the object's face down on, moving there first."
    )
    at: list[Length] | FrameRef | None = Field(
        None, description="Face on a feature: [u, v] in the plane, or a feature projected on it."
    )
    spin: Angle | None = Field(None, description="Face on a feature: the turn about the normal.")
    approach: Length = Field(
        "50mm", description="Face on a feature: the approach, straight down the normal."
    )
    speed: Fraction = Field(0.1, description="Face on a feature: the last straight move's speed.")
    path: Literal["straight", "free"] = Field(
        "straight",
        description="The joint move to the approach: 'straight' in joint space, or 'free': a "
        "collision-free joint path planned when the step runs (docs/planning.md).",
    )


class InsertSpec(Strict):
    """Insert a held object's axis feature into a hole: aligned, approached along the axis and
    pushed in to the depth (docs/programs.md)."""

    object: FrameRef = Field(
        description="The held object's tip: a circle (its normal out of the tip) or a line "
        "(its point at the tip, its direction out of it), 'peg.tip'."
    )
    into: FrameRef = Field(description="The hole: a circle feature, 'plate.hole1'.")
    depth: Length = Field(description="How far past the rim the tip goes.")
    approach: Length = Field("50mm", description="The approach along the axis, above the rim.")
    speed: Fraction = Field(0.1, description="The insertion's fraction of the linear speed.")
    until: Name | None = Field(
        None, description="Guarded insertion: stop where this sensor first senses something."
    )
    spin: Angle | None = Field(
        None, description="The turn about the axis; default chosen for reach."
    )
    path: Literal["straight", "free"] = Field(
        "straight",
        description="The joint move to the approach: 'straight' in joint space, or 'free': a "
        "collision-free joint path planned when the step runs (docs/planning.md).",
    )


class FollowSpec(Strict):
    """A straight path along a line feature at a held speed (dispensing, deburring)."""

    edge: FrameRef = Field(description="The line feature, 'bracket.top_edge'.")
    speed: Length = Field(
        description="The tool's speed along the line, held: '20mm/s' (a bare number is the "
        "file's length unit per second)."
    )
    offset: Pose | None = Field(
        None,
        description="The tool frame relative to the edge's frame (x along the line, z towards "
        "the material), in the file's units.",
    )
    from_: Length | None = Field(
        None,
        alias="from",
        description="Start, along the line from its point; default the material's end.",
    )
    to: Length | None = Field(
        None, description="End, along the line from its point; default the material's other end."
    )
    approach: Length = Field("30mm", description="Into and out of the path, away from the edge.")
    spin: Angle | None = Field(None, description="The turn about the line; default chosen.")
    tcp: FrameRef | None = Field(None, description="The tool frame; default the active TCP.")
    path: Literal["straight", "free"] = Field(
        "straight",
        description="The joint move to the approach: 'straight' in joint space, or 'free': a "
        "collision-free joint path planned when the step runs (docs/planning.md).",
    )


class ToolSpec(Strict):
    tool: Name = Field(description="A device (hand) or object used as a tool.")
    at: FrameRef | None = Field(
        None, description="attach_tool: the frame it is affixed to; default the active TCP."
    )
    on: FrameRef | None = Field(
        None, description="detach_tool: the frame it is left resting on; default world."
    )


class ProbeSpec(Strict):
    feature: FrameRef = Field(
        description="The feature ('object.feature'). Right after a guarded move: its contact "
        "is a probe point of the feature. Anywhere else: the probing moves for the feature, as "
        "plan-measurements plans them."
    )
    points: Annotated[int, Field(ge=1, le=100)] | None = Field(
        None,
        description="The probing moves: how many points (default: the fewest the feature's "
        "kind needs).",
    )
    tcp: FrameRef | None = Field(None, description="The probing moves: the probe's TCP.")
    sensor: Name | None = Field(None, description="The probing moves: the touch sensor.")
    path: Literal["straight", "free"] = Field(
        "straight",
        description="The probing moves: the joint move to the first point's lift, 'straight' "
        "in joint space or 'free': a collision-free joint path planned when the step runs "
        "(docs/planning.md).",
    )


class CaptureSpec(Strict):
    camera: Name = Field(description="The camera sensor that takes the image.")
    settle: Annotated[float, Field(ge=0, le=60)] = Field(
        0.5,
        description="Seconds the robot stands still before the trigger, for the arm's "
        "vibration to die down.",
    )
    exposure: Annotated[float, Field(gt=0, le=60)] = Field(
        0.1,
        description="Seconds the trigger output is held on (the camera's exposure); the robot "
        "stays still.",
    )


class WaitSpec(Strict):
    time: Annotated[float, Field(ge=0)] | None = Field(None, description="Seconds to wait.")
    for_: Name | None = Field(
        None, alias="for", description="Wait until this device's program has ended."
    )

    @model_validator(mode="after")
    def _one(self):
        if (self.time is None) == (self.for_ is None):
            raise ValueError("give either 'time' (seconds) or 'for' (a device), exactly one")
        return self


class Step(Strict):
    """One program step: exactly one of the keys."""

    move: MoveSpec | None = None
    grasp: ObjectRef | None = Field(
        None, description="Rigidly affix the object to the TCP ('grasp: part' for short)."
    )
    release: ObjectRef | None = Field(
        None, description="Remove the object's affixment; it stays where it is."
    )
    place: PlaceSpec | None = Field(
        None,
        description="The object now rests on a frame (non-rigid affixment); or its face set "
        "down on a plane feature.",
    )
    insert: InsertSpec | None = Field(
        None, description="Insert a held object's tip into a hole feature."
    )
    follow: FollowSpec | None = Field(None, description="Follow a line feature at a held speed.")
    attach_tool: ToolSpec | None = Field(
        None, description="Tool change: affix a tool; its TCP becomes the active one."
    )
    detach_tool: ToolSpec | None = Field(
        None, description="Tool change: leave the tool (on a frame or in world)."
    )
    wait: WaitSpec | None = None
    sync: Name | None = Field(
        None, description="Meet the other programs at their sync of the same name."
    )
    sense: Name | None = Field(
        None, description="Read a sensor; the reading is recorded as an event."
    )
    capture: CaptureSpec | None = Field(
        None,
        description="Take an image: stand still, trigger the camera, log the robot's pose "
        "('capture: camera' for short; docs/vision.md).",
    )
    probe: ProbeSpec | None = Field(
        None,
        description="Record where the guarded move before stopped (its sensor's origin, a ball "
        "tip's centre) as a probe point of a feature ('probe: object.feature' for short).",
    )

    @field_validator("grasp", "release", mode="before")
    @classmethod
    def _object_shorthand(cls, v):
        return {"object": v} if isinstance(v, str) else v

    @field_validator("probe", mode="before")
    @classmethod
    def _probe_shorthand(cls, v):
        return {"feature": v} if isinstance(v, str) else v

    @field_validator("capture", mode="before")
    @classmethod
    def _capture_shorthand(cls, v):
        return {"camera": v} if isinstance(v, str) else v

    @field_validator("attach_tool", "detach_tool", mode="before")
    @classmethod
    def _tool_shorthand(cls, v):
        return {"tool": v} if isinstance(v, str) else v

    @model_validator(mode="after")
    def _exactly_one(self):
        given = [k for k in STEP_KINDS if getattr(self, k) is not None]
        if len(given) != 1:
            what = "none" if not given else " and ".join(given)
            raise ValueError(f"a step does exactly one thing ({', '.join(STEP_KINDS)}); got {what}")
        return self

    @property
    def kind(self) -> str:
        return next(k for k in STEP_KINDS if getattr(self, k) is not None)


STEP_KINDS = (
    "move",
    "grasp",
    "release",
    "place",
    "insert",
    "follow",
    "attach_tool",
    "detach_tool",
    "wait",
    "sync",
    "sense",
    "capture",
    "probe",
)


class ProgramFile(Strict):
    """A symbolic program for one device."""

    device: Name
    description: str | None = None
    units: PartUnits | None = Field(
        None,
        description="Units of offsets and touch depths in this file; required when it has them.",
    )
    steps: Annotated[list[Step], Field(min_length=1)]


class RunFile(Strict):
    """Programs that run together, on one clock."""

    description: str | None = None
    programs: Annotated[list[str], Field(min_length=1)] = Field(
        description="Program files, relative to this file."
    )
    dt: Annotated[float, Field(gt=0, le=1)] = Field(
        0.01, description="Time step of the uniform clock [s]."
    )
    clearance: float | str | None = Field(
        None,
        description="Required distance between bodies that may not touch, e.g. '10mm' (a bare "
        "number is metres); closer is a violation. Default: contact only.",
    )
    collision_tolerance: float | str | None = Field(
        None,
        description="Contacts shallower than this may be missed between two simulated instants "
        "(default 1mm); see docs/collision.md.",
    )
    paths: Literal["straight", "free"] = Field(
        "straight",
        description="The 'path:' of every joint move that gives none (and of insert, place, "
        "follow and probe's approach; not linear or guarded moves): 'free' plans each around "
        "what is in the way when it runs (docs/planning.md).",
    )
    seed: Annotated[int, Field(ge=0)] = Field(
        0,
        description="The planner's seed for the run's free paths: each planned move uses this "
        "plus its step's position in its program (a step's own 'seed' instead).",
    )
    timeout: float | str = Field(
        10.0,
        description="How long the planner may search for each free path, e.g. '30s' (a bare "
        "number is seconds); a step's own 'timeout' instead.",
    )

    @field_validator("timeout")
    @classmethod
    def _a_duration(cls, value):
        return parse_duration(value, "timeout")

    @field_validator("clearance", "collision_tolerance")
    @classmethod
    def _a_length(cls, value, info):
        if value is None:
            return value
        length = parse_length(value, info.field_name)  # ValueError -> a located message
        if info.field_name == "collision_tolerance" and length == 0:
            raise ValueError(
                "collision_tolerance must be above 0: no check between instants can be exact"
            )
        return value


class PathFile(Strict):
    """A joint-space path: a cubic spline through waypoints (for 'rworld plan')."""

    device: Name | None = Field(
        None, description="The device the path is for; read for another device it is refused."
    )
    units: PartUnits = Field(
        description="Units of the joint values (angle for revolute, length for prismatic joints)."
    )
    waypoints: Annotated[list[list[float]], Field(min_length=2)] = Field(
        description="Joint values, one row per waypoint."
    )
    knots: list[float] | None = Field(
        None,
        description="Path parameter of each waypoint, rising from 0 to 1; default equally spaced.",
    )
    boundary: Literal["clamped", "natural", "not-a-knot", "segments", "blended"] = Field(
        "clamped",
        description="clamped: dq/ds = 0 at both ends. segments: straight joint-space "
        "segments between the waypoints, at rest at each. blended: those segments with each "
        "corner cut by a parabolic blend ('blends'), the knots by joint-space length (a "
        "collision-free path from 'rworld plan path': the lines and blends it checked).",
    )
    blends: list[float] | None = Field(
        None,
        description="boundary 'blended': per waypoint, the corner's blend half-width as a "
        "fraction of the shorter segment beside it, in [0, 0.5]; 0 at the ends and at "
        "corners passed at rest. Default: all 0.",
    )
