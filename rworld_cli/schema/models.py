"""Pydantic models of rworld's YAML file formats: the cell and its pose files.

These models describe the *files* (numbers in the file's declared units); the
loader converts them to SI and builds the runtime model
(:mod:`rworld_cli.model.cell`).  Every field carries a description: they
become the JSON Schemas in ``schemas/`` that editors use for completion.

Units (``docs/formats.md``): a file's ``units.length`` applies to every
length (positions, sizes, DH ``a`` and ``d``, prismatic joint travel, speed
and acceleration, feature coordinates, sensor overlap volumes as length^3);
``units.angle`` to every angle (rotations, DH ``alpha`` and ``theta``,
revolute joint travel, speed and acceleration).  Mass properties, efforts
and gravity are always SI (kg, kg m^2, N m or N, m/s^2).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from annotated_types import Len
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StringConstraints,
    field_validator,
    model_validator,
)

NAME_PATTERN = r"^[A-Za-z_][A-Za-z0-9_\-]*$"
REF_PATTERN = r"^[A-Za-z_][A-Za-z0-9_\-]*(\.[A-Za-z_][A-Za-z0-9_\-]*)*$"

Name = Annotated[
    str,
    StringConstraints(pattern=NAME_PATTERN),
    Field(description="A name: letters, digits, '_' or '-', not starting with a digit, no '.'."),
]
FrameRef = Annotated[
    str,
    StringConstraints(pattern=REF_PATTERN),
    Field(
        description="A frame: 'world', a primitive's name (its natural frame) or 'owner.frame' "
        "for an auxiliary, link or TCP frame."
    ),
]
Vec3 = Annotated[list[float], Len(3, 3)]
PositiveVec3 = Annotated[list[Annotated[float, Field(gt=0)]], Len(3, 3)]
Positive = Annotated[float, Field(gt=0)]
NonNegative = Annotated[float, Field(ge=0)]


class Strict(BaseModel):
    """Base: no unknown keys, no silent string-to-number coercion, finite numbers only."""

    model_config = ConfigDict(strict=True, extra="forbid", allow_inf_nan=False, defer_build=True)


# --------------------------------------------------------------------------- shared


class Units(Strict):
    """Units of the numbers in this file; converted to SI when the file is loaded.  Both are
    required: rworld never guesses a unit (docs/formats.md, conventions)."""

    length: Literal["m", "mm"] = Field(description="Unit of every length in the file.")
    angle: Literal["rad", "deg"] = Field(description="Unit of every angle in the file.")


class LengthUnits(Strict):
    """Units of a file that holds lengths only (measurements)."""

    length: Literal["m", "mm"] = Field(description="Unit of every length in the file.")
    angle: Literal["rad", "deg"] | None = Field(None, description="Unused: no angles here.")


class PartUnits(Strict):
    """Units of a file that holds lengths or angles only in some cases (programs: offsets;
    paths: revolute and prismatic joints); the ones it uses must be given."""

    length: Literal["m", "mm"] | None = Field(None, description="Unit of every length in the file.")
    angle: Literal["rad", "deg"] | None = Field(
        None, description="Unit of every angle in the file."
    )


UNITS_HINT = "declare them, e.g. 'units: {length: mm, angle: deg}': rworld never guesses units"


class Pose(Strict):
    """A pose relative to the frame's parent: ``xyz`` with ``rpy``, ``quat_wxyz`` or
    ``quat_xyzw``, or a 4x4 ``matrix``.  A quaternion's key says its order (``quat`` alone is
    refused: both orders are common, and a wrong guess turns the frame silently).
    """

    xyz: Vec3 | None = Field(None, description="Translation [length unit]; default 0.")
    rpy: Vec3 | None = Field(
        None,
        description="Roll, pitch, yaw [angle unit] about the fixed x, y, z axes: R = Rz(yaw) "
        "Ry(pitch) Rx(roll).",
    )
    quat_wxyz: Annotated[list[float], Len(4, 4)] | None = Field(
        None, description="Unit quaternion, scalar first: (w, x, y, z) (Eigen, ABB, glTF's w)."
    )
    quat_xyzw: Annotated[list[float], Len(4, 4)] | None = Field(
        None, description="Unit quaternion, scalar last: (x, y, z, w) (ROS, scipy, glTF)."
    )
    quat: Annotated[list[float], Len(4, 4)] | None = Field(
        None,
        description="Refused: say the order in the key, quat_wxyz or quat_xyzw.",
    )
    matrix: Annotated[list[Annotated[list[float], Len(4, 4)]], Len(4, 4)] | None = Field(
        None, description="Homogeneous 4x4 matrix, rows; translation in the length unit."
    )

    @model_validator(mode="after")
    def _one_form(self):
        if self.quat is not None:
            raise ValueError(
                "'quat' does not say its order: write quat_wxyz: [w, x, y, z] (scalar first) or "
                "quat_xyzw: [x, y, z, w] (scalar last, as ROS and scipy)"
            )
        rotations = [k for k in ("rpy", "quat_wxyz", "quat_xyzw") if getattr(self, k) is not None]
        if len(rotations) > 1:
            raise ValueError(f"give the rotation once: {' or '.join(rotations)}, not both")
        if self.matrix is not None and (self.xyz is not None or rotations):
            raise ValueError(
                "'matrix' holds the whole pose; do not combine it with 'xyz' or a rotation"
            )
        return self

    @property
    def quaternion_wxyz(self) -> list[float] | None:
        """The quaternion, scalar first, whichever key gave it."""
        if self.quat_xyzw is not None:
            x, y, z, w = self.quat_xyzw
            return [w, x, y, z]
        return self.quat_wxyz


class Inertia(Strict):
    """Inertia tensor about the centre of mass, axes of the owner's frame [kg m^2]."""

    ixx: float = Field(description="kg m^2")
    iyy: float = Field(description="kg m^2")
    izz: float = Field(description="kg m^2")
    ixy: float = Field(0.0, description="kg m^2")
    ixz: float = Field(0.0, description="kg m^2")
    iyz: float = Field(0.0, description="kg m^2")


class Cylinder(Strict):
    radius: Positive = Field(description="[length unit]")
    length: Positive = Field(description="Along z, centred on the origin [length unit].")


class Sphere(Strict):
    radius: Positive = Field(description="[length unit]")


class Mesh(Strict):
    file: str = Field(description="STL, OBJ or PLY file, relative to the cell file.")
    units: Literal["m", "mm"] | None = Field(
        None, description="Length unit of the mesh file; default: the cell's."
    )
    surface: bool = Field(
        False,
        description="The mesh is known to be an open surface (not closed: a vendor's mesh, "
        "'rworld import urdf' marks the ones it could not close): checked as a surface, said "
        "in one note for all such meshes instead of a warning each (--quiet: not at all).",
    )


class Geometry(Strict):
    """Shape: exactly one of box, cylinder, sphere, mesh; placed by ``origin`` in the owner's
    frame.
    """

    box: PositiveVec3 | None = Field(
        None, description="Edge lengths x, y, z, centred on the origin [length unit]."
    )
    cylinder: Cylinder | None = None
    sphere: Sphere | None = None
    mesh: Mesh | None = None
    origin: Pose | None = Field(
        None, description="Pose of the shape in the owner's frame; default identity."
    )

    @model_validator(mode="after")
    def _exactly_one(self):
        given = [k for k in ("box", "cylinder", "sphere", "mesh") if getattr(self, k) is not None]
        if len(given) != 1:
            what = "none" if not given else " and ".join(given)
            raise ValueError(f"give exactly one shape (box, cylinder, sphere or mesh), got {what}")
        return self


# --------------------------------------------------------------------------- features


class LineSpec(Strict):
    point: Vec3 = Field(description="A point on the line [length unit].")
    direction: Vec3 = Field(
        description="Direction; for orientation-carrying probing, first -> last point."
    )


class PlaneSpec(Strict):
    point: Vec3 = Field(description="A point on the plane [length unit].")
    normal: Vec3 = Field(description="Normal pointing out of the material ('above' the surface).")


class CircleSpec(Strict):
    center: Vec3 = Field(description="[length unit]")
    normal: Vec3 = Field(description="Normal of the circle's plane, out of the material.")
    radius: Positive = Field(description="[length unit]")


class Feature(Strict):
    """A geometric feature of its owner, nominal equation in the owner's natural frame."""

    name: Name
    point: Vec3 | None = Field(None, description="A point feature [length unit].")
    line: LineSpec | None = None
    plane: PlaneSpec | None = None
    circle: CircleSpec | None = None

    @model_validator(mode="after")
    def _exactly_one(self):
        given = [k for k in ("point", "line", "plane", "circle") if getattr(self, k) is not None]
        if len(given) != 1:
            what = "none" if not given else " and ".join(given)
            raise ValueError(f"give exactly one of point, line, plane, circle; got {what}")
        return self

    @property
    def kind(self) -> str:
        return next(k for k in ("point", "line", "plane", "circle") if getattr(self, k) is not None)


# --------------------------------------------------------------------------- frames, objects,
# sensors


class AuxFrame(Strict):
    """An auxiliary frame owned by an object, sensor, device or link; its pose lives in a pose
    file.
    """

    name: Name
    parent: Name | None = Field(
        None,
        description="Another frame of the same owner this one is attached to; default the owner's "
        "frame.",
    )


class FreeFrame(Strict):
    """A frame in free space (e.g. a target location); its pose lives in a pose file."""

    name: Name
    parent: FrameRef | None = Field(None, description="'world' (default) or another free frame.")


class BoardPattern(Strict):
    """A calibration board's pattern, in the object's natural frame (``docs/vision.md``): +x
    along the first row of corners, +y along the columns, +z into the board; the origin at the
    first inner corner (chessboard), the board's outer corner (ChArUco) or the first tag's
    outer corner (AprilTag grid)."""

    pattern: Literal["chessboard", "charuco", "aprilgrid"]
    columns: Annotated[int, Field(ge=1, le=200)] = Field(
        description="Chessboard: inner corners along the board's x (3 or more); ChArUco: "
        "squares (3 or more); AprilTag grid: tags."
    )
    rows: Annotated[int, Field(ge=1, le=200)] = Field(
        description="Chessboard: inner corners along y; ChArUco: squares; AprilTag grid: tags."
    )
    square: Positive = Field(
        description="A square's edge; an AprilTag grid's: a tag's (its black border's outer "
        "edge) [length unit]."
    )
    marker: Positive | None = Field(None, description="ChArUco: a marker's edge [length unit].")
    spacing: Positive | None = Field(
        None, description="AprilTag grid: the gap between two tags [length unit]."
    )
    dictionary: str | None = Field(
        None,
        description="ChArUco: OpenCV's ArUco dictionary, e.g. DICT_5X5_100; AprilTag grid: "
        "the tag family (default DICT_APRILTAG_36h11, Kalibr's).",
    )


class RigidObject(Strict):
    """A rigid object: natural frame, mass properties, shape, auxiliary frames, features."""

    name: Name
    mass: NonNegative = Field(0.0, description="[kg]")
    com: Vec3 = Field(
        default_factory=lambda: [0.0, 0.0, 0.0],
        description="Centre of mass in the natural frame [length unit].",
    )
    inertia: Inertia | None = Field(
        None, description="About the centre of mass; default zero (a point mass)."
    )
    geometry: Geometry | None = None
    frames: list[AuxFrame] = Field(default_factory=list)
    features: list[Feature] = Field(default_factory=list)
    board: BoardPattern | None = Field(
        None, description="A calibration board: the pattern printed on the object's x-y plane."
    )


class Segments(Strict):
    rows: Annotated[int, Field(ge=1)] = Field(description="Cells along the pad's y axis.")
    cols: Annotated[int, Field(ge=1)] = Field(description="Cells along the pad's x axis.")


class Sensor(Strict):
    """A sensor: a box whose origin is the centre of its base face, sensing along +z; or, for a
    touch probe, a ball centred on the sensor frame's origin; or a camera, its frame OpenCV's
    (+z along the optical axis, +x along the image's rows, +y down), its housing box behind the
    lens and its intrinsics in a pose file's 'cameras:'."""

    name: Name
    type: Literal["touch", "tactile", "proximity", "presence", "force", "camera"]
    size: PositiveVec3 | None = Field(
        None,
        description="Box edge lengths x, y, z [length unit]; z is the sensing depth or range; "
        "a camera's housing, behind the lens (-z). Every sensor but a ball-tip touch probe.",
    )
    ball: Positive | None = Field(
        None,
        description="Touch sensors: a ball tip of this radius [length unit] centred on the "
        "sensor frame's origin (a touch-trigger probe's stylus ball), instead of a box. It "
        "triggers at contact.",
    )
    segments: Segments | None = Field(None, description="Tactile sensors: the pad's grid of cells.")
    slices: Annotated[int, Field(ge=1)] | None = Field(
        None, description="Proximity sensors: slices of the range along +z."
    )
    force_curve: list[Annotated[list[float], Len(2, 2)]] | None = Field(
        None,
        description="Force sensors: [overlap volume (length unit^3), force (N)] pairs, volume "
        "increasing.",
    )
    frames: list[AuxFrame] = Field(default_factory=list)


# --------------------------------------------------------------------------- devices


class JointLimits(Strict):
    position: Annotated[list[float], Len(2, 2)] | None = Field(
        None, description="[lower, upper] joint value [angle or length unit]."
    )
    velocity: Positive | None = Field(None, description="[angle or length unit]/s")
    acceleration: Positive | None = Field(None, description="[angle or length unit]/s^2")
    effort: Positive | None = Field(
        None, description="Torque [N m] or force [N] the actuator can give."
    )


class Motor(Strict):
    inertia: NonNegative = Field(
        description="Motor rotor (armature) inertia Jm [kg m^2], motor side."
    )
    gear_ratio: float = Field(
        description="G: motor speed / joint speed; sign allowed; reflected inertia Jm G^2."
    )

    @field_validator("gear_ratio")
    @classmethod
    def _nonzero(cls, v: float) -> float:
        if v == 0:
            raise ValueError("gear_ratio must not be 0")
        return v


class Friction(Strict):
    viscous: NonNegative = Field(0.0, description="B: torque per speed [N m s/rad or N s/m].")
    coulomb: NonNegative = Field(
        0.0, description="Coulomb friction magnitude when moving in + direction [N m or N]."
    )
    coulomb_negative: NonNegative | None = Field(
        None, description="Magnitude when moving in - direction; default: coulomb."
    )
    at: Literal["joint", "motor"] = Field(
        "joint",
        description="Side the values are measured on; motor-side values are scaled by the gear "
        "ratio (B G^2, Tc |G|).",
    )


class Joint(Strict):
    """One joint: a row of the DH table (devices with ``dh``; see docs/conventions.md for
    standard vs modified), or a joint frame (devices without ``dh``: ``origin`` and ``axis``, as
    URDF gives them).
    """

    name: Name | None = Field(None, description="Default j1, j2, ...")
    type: Literal["revolute", "continuous", "prismatic", "fixed"] = Field(
        description="continuous: a revolute joint without position limits; fixed (joint-frame "
        "devices only): its link is merged into the previous one and kept as a frame."
    )
    a: float | None = Field(None, description="DH link length [length unit]; default 0.")
    alpha: float | None = Field(None, description="DH link twist [angle unit]; default 0.")
    d: float | None = Field(
        None,
        description="DH link offset [length unit]; for prismatic joints added to the joint "
        "value; default 0.",
    )
    theta: float | None = Field(
        None,
        description=(
            "DH joint angle offset [angle unit]; for revolute joints added to the joint value; "
            "default 0."
        ),
    )
    origin: Pose | None = Field(
        None,
        description="Joint-frame devices: pose of the joint frame in the previous link's frame "
        "(the base for the first joint) at joint value 0; default identity.",
    )
    axis: Vec3 | None = Field(
        None,
        description="Joint-frame devices: the joint axis in the joint frame (normalised when "
        "loaded); default [0, 0, 1].",
    )
    limits: JointLimits | None = None
    motor: Motor | None = None
    friction: Friction | None = None


class Link(Strict):
    """Link i, moved by joint i; its frame is DH frame i (or joint i's frame, moved by it)."""

    name: Name | None = Field(None, description="Default link1, link2, ...")
    mass: NonNegative = Field(0.0, description="[kg]")
    com: Vec3 = Field(
        default_factory=lambda: [0.0, 0.0, 0.0],
        description="Centre of mass in the link frame [length unit].",
    )
    inertia: Inertia | None = None
    geometry: Geometry | None = None
    frames: list[AuxFrame] = Field(
        default_factory=list, description="Auxiliary frames on this link."
    )


class Tcp(Strict):
    name: Name
    parent: Name | None = Field(
        None, description="A link or frame of this device; default the last link."
    )


class Coupling(Strict):
    """A parallel linkage: the controller's axis also counts another joint's value."""

    joint: Name = Field(description="The other joint (its name in this device).")
    factor: float = Field(
        description="Added times that joint's value: ABB's coupled arms (IRB 2400, 6700) +1, "
        "FANUC -1 (ROS-Industrial's J23 factors; docs/export.md)."
    )


class AxisMap(Strict):
    """One controller axis: ``axis = sign * joint + offset (+ factor * other joint)``, in the
    joint's unit."""

    sign: Literal[1, -1] = 1
    offset: float = Field(0.0, description="[angle or length unit]")
    coupling: Coupling | None = None


class Controller(Strict):
    """How the robot's controller sees the device: the frames its tool data and Cartesian
    targets are given in, and its axis values (``docs/export.md``)."""

    vendor: (
        Literal[
            "abb",
            "fanuc",
            "kuka",
            "kuka_sunrise",
            "ur",
            "yaskawa",
            "staubli",
            "doosan",
            "franka",
            "kinova",
            "denso",
            "epson",
            "generic",
        ]
        | None
    ) = Field(
        None,
        description="Whose controller: 'export program' writes its language when no --format "
        "is given (abb: RAPID, fanuc: TP, kuka: KRL, ur: URScript, yaskawa: INFORM, staubli: "
        "VAL3, doosan: DRL, kuka_sunrise (LBR iiwa, Med): Sunrise Java; franka, kinova, denso, "
        "epson: no format yet, refused with the reason).",
    )
    flange: Name | None = Field(
        None,
        description="A frame of the device on its last link: tool data is given in it (the "
        "controller's flange: UR and ROS-Industrial 'tool0', KUKA $FLANGE). Default: the last "
        "link's frame.",
    )
    base: Name | None = Field(
        None,
        description="A frame fixed to the device's base: Cartesian targets (and user frames) "
        "are given in it (UR 'base', KUKA $ROBROOT, ABB base frame). Default: the device's "
        "natural frame.",
    )
    axes: list[AxisMap] | None = Field(
        None,
        description="Per joint, the controller's axis value from the cell's joint value; default "
        "the same.",
    )
    pulses_per_degree: list[Annotated[float, Field(gt=0)]] | None = Field(
        None,
        description="Yaskawa: each axis' encoder pulses per degree (robot parameters, read off "
        "the controller): INFORM jobs then give joint targets in pulses; without them, as "
        "Cartesian positions with their manipulator type (RCONF).",
    )
    zero_pulse: list[int] | None = Field(
        None,
        description="Yaskawa: each axis' pulse count at its zero (default 0); with "
        "pulses_per_degree.",
    )


class Device(Strict):
    """A device: a serial chain given by its DH table or by joint frames, with links, limits
    and TCPs.
    """

    name: Name
    dof: Annotated[int, Field(ge=1)] = Field(
        description="Mobility: number of moving (not fixed) joints."
    )
    dh: Literal["standard", "modified"] | None = Field(
        None,
        description="DH convention of the joint table; leave it out when the joints are given "
        "by their frames (origin and axis).",
    )
    joints: list[Joint] = Field(
        description="The DH table, one row per joint, or the joint frames from the base out."
    )
    links: list[Link] | None = Field(
        None, description="One per joint (fixed joints included); default massless links link1..n."
    )
    tcps: Annotated[list[Tcp], Len(1)] = Field(
        description="Tool centre points; the first is the default active TCP."
    )
    home: list[float] | None = Field(
        None, description="Initial joint values [angle or length unit]; default 0."
    )
    positions: dict[str, list[float]] = Field(
        default_factory=dict,
        description="Named joint configurations programs can move to (e.g. open, closed, "
        "station_b) [angle or length unit].",
    )
    geometry: Geometry | None = Field(None, description="Shape of the base.")
    frames: list[AuxFrame] = Field(
        default_factory=list, description="Auxiliary frames on the base."
    )
    features: list[Feature] = Field(
        default_factory=list, description="Features of the base, in the natural frame."
    )
    controller: Controller | None = Field(
        None, description="The robot controller's flange, base frame and axis values."
    )
    base_link: Name | None = Field(
        None,
        description="The base's link name in URDF ('rworld import urdf' keeps it, 'rworld "
        "export urdf' writes it, so a MoveIt SRDF naming it still fits); default the device's "
        "name.",
    )

    @model_validator(mode="after")
    def _dh_or_frames(self):
        if self.dh is None:
            for row in self.joints:
                given = [k for k in ("a", "alpha", "d", "theta") if getattr(row, k) is not None]
                if given:
                    raise ValueError(
                        f"the joints give DH parameters ({', '.join(given)}) but 'dh' is missing: "
                        "add 'dh: standard' or 'dh: modified', or give each joint by its frame "
                        "('origin', 'axis')"
                    )
        return self


# --------------------------------------------------------------------------- relations


class Affixment(Strict):
    """Child is affixed to parent: rigid (child follows parent) or non-rigid (child rests on
    parent).
    """

    parent: FrameRef
    child: Name = Field(description="An object, sensor or device.")
    type: Literal["rigid", "non_rigid"]
    kind: Literal["grasp", "assembly", "aggregation", "tool", "fixture", "rests_on"] | None = Field(
        None, description="What the affixment models; 'rests_on' is non-rigid, the others rigid."
    )


CONDITION_CODES: dict[str, str] = {
    "natural_unoriented": "C1",
    "natural_oriented": "C2",
    "origin_on": "C3",
    "x_normal_to": "C4",
    "y_normal_to": "C5",
    "z_normal_to": "C6",
    "xy_perpendicular_to": "C7",
    "xz_perpendicular_to": "C8",
    "yz_perpendicular_to": "C9",
    "xy_parallel_to": "C10",
    "xz_parallel_to": "C11",
    "yz_parallel_to": "C12",
    "circle_frame": "C13",
}
CODE_TO_CONDITION = {code: name for name, code in CONDITION_CODES.items()}
ConditionName = Literal[
    "natural_unoriented",
    "natural_oriented",
    "origin_on",
    "x_normal_to",
    "y_normal_to",
    "z_normal_to",
    "xy_perpendicular_to",
    "xz_perpendicular_to",
    "yz_perpendicular_to",
    "xy_parallel_to",
    "xz_parallel_to",
    "yz_parallel_to",
    "circle_frame",
]


class Condition(Strict):
    """A frame conditioned by features (the calibration report's C1-C13)."""

    frame: FrameRef
    type: ConditionName = Field(
        description="Readable name; the report's codes C1..C13 are accepted too."
    )
    feature: str | None = Field(
        None, description="The one feature of an auxiliary frame's condition (C3-C13)."
    )
    features: list[str] | None = Field(
        None, description="The features that locate a natural frame (C1, C2)."
    )

    @field_validator("type", mode="before")
    @classmethod
    def _code_alias(cls, v):
        if isinstance(v, str) and v.upper() in CODE_TO_CONDITION:
            return CODE_TO_CONDITION[v.upper()]
        return v

    @model_validator(mode="after")
    def _one_feature_key(self):
        if (self.feature is None) == (self.features is None):
            raise ValueError(
                "give either 'feature' (one name) or 'features' (a list), exactly one of them"
            )
        return self

    @property
    def code(self) -> str:
        return CONDITION_CODES[self.type]

    @property
    def feature_names(self) -> list[str]:
        return [self.feature] if self.feature is not None else list(self.features or [])


# --------------------------------------------------------------------------- files


class AllowedContact(Strict):
    """Bodies that may touch: every pair between two different names of the group."""

    between: Annotated[list[FrameRef], Len(2)] = Field(
        description="Objects, devices (all their bodies) or links as 'device.link'."
    )
    reason: Annotated[str, Len(1)] = Field(description="Why touching is fine here (for reviewers).")


class CellFile(Strict):
    """A workcell: structure, geometry, devices, features, affixments and frame conditions."""

    name: Name
    description: str | None = None
    units: Units
    pose_files: Annotated[list[str], Len(1)] = Field(
        default_factory=lambda: ["poses.yaml"],
        description="Numeric pose files relative to this file; later files override earlier ones "
        "(calibration overlays).",
    )
    gravity: Vec3 = Field(
        default_factory=lambda: [0.0, 0.0, -9.81],
        description="Acceleration of gravity in world [m/s^2].",
    )
    frames: list[FreeFrame] = Field(default_factory=list, description="Frames in free space.")
    objects: list[RigidObject] = Field(default_factory=list)
    sensors: list[Sensor] = Field(default_factory=list)
    devices: list[Device] = Field(default_factory=list)
    affixments: list[Affixment] = Field(
        default_factory=list, description="The initial tree; unaffixed primitives sit in world."
    )
    conditions: list[Condition] = Field(
        default_factory=list, description="Frame conditions for calibration."
    )
    allowed_contacts: list[AllowedContact] = Field(
        default_factory=list,
        description="Body pairs the collision check lets touch, beyond those the world state "
        "allows (adjacent links, grasps, resting, tools, aggregation).",
    )


class PinholeIntrinsics(Strict):
    fx: Positive = Field(description="Focal length along x [px].")
    fy: Positive = Field(description="Focal length along y [px].")
    cx: float = Field(description="Principal point x [px] (the top-left pixel's centre is 0).")
    cy: float = Field(description="Principal point y [px].")


class CameraIntrinsics(Strict):
    """A camera's numbers: OpenCV's model (``docs/vision.md``)."""

    resolution: Annotated[list[Annotated[int, Field(gt=0, le=65536)]], Len(2, 2)] = Field(
        description="Image width and height [px]."
    )
    intrinsics: PinholeIntrinsics
    distortion: Annotated[list[float], Len(5, 5)] = Field(
        default_factory=lambda: [0.0] * 5, description="OpenCV's k1 k2 p1 p2 k3."
    )


class PoseFile(Strict):
    """Numeric data: frame poses relative to their parents.  Calibration rewrites these files."""

    units: Units
    poses: dict[str, Pose] = Field(
        default_factory=dict, description="Frame name -> pose relative to its parent."
    )
    joints: dict[str, Pose] = Field(
        default_factory=dict,
        description="'device.joint' -> the joint's frame in the previous link's frame (its "
        "origin, the joint value's zero about its axis included), replacing the cell's: a "
        "joint-frame device's calibrated kinematics ('rworld calibrate-robot').",
    )
    corrections: dict[str, Pose] = Field(
        default_factory=dict,
        description="'device.joint' -> a small pose before the joint's DH row (A' = E A), "
        "replacing the cell's none: a DH device's calibrated kinematics ('rworld "
        "calibrate-robot'), a tilt between parallel axes included.",
    )
    compliance: dict[str, float] = Field(
        default_factory=dict,
        description="'device.joint' -> the joint's compliance under load, in the file's angle "
        "unit per kN m (revolute) or length unit per kN (prismatic): the arm's joint "
        "value is the commanded one plus compliance x the torque that holds it against gravity "
        "('rworld calibrate-robot --model compliance').",
    )
    cameras: dict[str, CameraIntrinsics] = Field(
        default_factory=dict,
        description="Camera sensor -> its resolution, intrinsics and distortion (pixels; "
        "'rworld calibrate-camera' writes them).",
    )
    provenance: dict[str, Any] | None = Field(
        None,
        description="Written by 'rworld calibrate': date, measurement files and their hashes, "
        "per-frame residuals and corrections.",
    )
