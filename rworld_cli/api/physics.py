"""Device physics tasks: a device in its cell, kinematics, dynamics, statics, payloads, carried
loads.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..kinematics.jacobian import ToolMount
    from ..model.cell import DeviceModel
    from ..world.tree import World

from ..errors import Issue, UserError
from .cells import load_world

# --------------------------------------------------------------------------- device physics


@dataclass
class DeviceContext:
    """A device in its cell: the model, where its base is, which tool frame, and gravity in its
    base.
    """

    world: World
    device: DeviceModel
    tcp: str
    mount: ToolMount
    T_world_base: np.ndarray
    gravity_base: np.ndarray
    warnings: list[Issue]

    def to_world(self, T_base: np.ndarray) -> np.ndarray:
        return self.T_world_base @ T_base

    def jacobian_to_world(self, J: np.ndarray) -> np.ndarray:
        R = self.T_world_base[:3, :3]
        out = np.empty_like(J)
        out[..., :3, :] = np.einsum("ij,...jk->...ik", R, J[..., :3, :])
        out[..., 3:, :] = np.einsum("ij,...jk->...ik", R, J[..., 3:, :])
        return out


def _tool_mount(world, device, tcp: str):
    """(ToolMount) of frame ``tcp`` on ``device``: the link it rides on and its fixed pose there."""
    from ..kinematics.jacobian import ToolMount

    return ToolMount(*world.mount_of(device.name, tcp))


def device_context(
    cell_path: str,
    device: str,
    tcp: str | None = None,
    joints: dict[str, list[float]] | None = None,
) -> DeviceContext:
    """Load a cell and prepare one device for kinematics and dynamics.

    Parameters
    ----------
    joints : dict, optional
        Joint values (SI) of devices, e.g. a conveyor that carries this one;
        they fix the device's base pose and the tools it carries.
    tcp : str, optional
        A frame carried by the device (default its active TCP); local names
        (``tool``) are qualified with the device name.
    """
    from ..errors import did_you_mean

    world, warnings = load_world(cell_path, joints)
    cell = world.cell
    if device not in cell.devices:
        raise UserError(
            f"unknown device '{device}'{did_you_mean(device, cell.devices)}; the cell has: "
            f"{', '.join(cell.devices) or 'none'}"
        )
    model = cell.devices[device]
    if tcp is None:
        tcp = world.active_tcp(device)
    elif tcp not in cell.frames and f"{device}.{tcp}" in cell.frames:
        tcp = f"{device}.{tcp}"
    if tcp not in cell.frames:
        raise UserError(f"unknown frame '{tcp}'{did_you_mean(tcp, cell.frames)}")
    mount = _tool_mount(world, model, tcp)
    T_world_base = world.T_world(device)
    gravity_base = T_world_base[:3, :3].T @ cell.gravity
    return DeviceContext(world, model, tcp, mount, T_world_base, gravity_base, warnings)


def _check_joint_count(ctx: DeviceContext, q: np.ndarray, what: str = "joint values"):
    n = ctx.device.dof
    if q.shape[-1] != n:
        raise UserError(f"device '{ctx.device.name}' has {n} joint(s); {what} have {q.shape[-1]}")


def forward_kinematics(ctx: DeviceContext, q) -> np.ndarray:
    """``T_world_tcp`` for joint values ``q`` (n,) or (N, n); shape (4, 4) or (N, 4, 4)."""
    from ..kinematics.jacobian import tool_pose

    q = np.asarray(q, dtype=float)
    _check_joint_count(ctx, q)
    return ctx.to_world(tool_pose(ctx.device, q, ctx.mount))


@dataclass
class JacobianResult:
    jacobian: np.ndarray  # (N, 6, n)
    manipulability: np.ndarray  # (N,)
    condition_number: np.ndarray  # (N,)
    frame: str


def jacobians(ctx: DeviceContext, q, frame: str = "world", point_in_tool=None) -> JacobianResult:
    """Geometric Jacobians at the TCP origin (or a point on the tool), with manipulability and
    conditioning.
    """
    from ..kinematics.jacobian import condition_number, jacobian, manipulability

    q = np.atleast_2d(np.asarray(q, dtype=float))
    _check_joint_count(ctx, q)
    J = jacobian(ctx.device, q, ctx.mount, point_in_tool)
    if frame == "world":
        J = ctx.jacobian_to_world(J)
    elif frame != "base":
        raise UserError(f"frame must be 'world' or 'base', got '{frame}'")
    return JacobianResult(J, manipulability(J), condition_number(J), frame)


def inverse_kinematics(
    ctx: DeviceContext,
    T_world_target: np.ndarray,
    target_name: str,
    seed=None,
    position_only: bool = False,
    restarts: int = 16,
    configuration: dict[str, str] | None = None,
):
    """Solve IK for the context's TCP; raise UserError (exit 2) with the figures when
    unreachable.  ``configuration``: a 6-axis arm's shoulder (front/back), elbow (up/down)
    and wrist (noflip/flip) asked for (``docs/export.md``); a target with no solution in it
    names the configuration that does reach it.
    """
    from ..kinematics.configuration import arm_configurations, is_arm
    from ..kinematics.inverse import solve_ik

    T_base_target = np.linalg.inv(ctx.T_world_base) @ T_world_target
    seed = ctx.world.joints(ctx.device.name) if seed is None else np.asarray(seed, dtype=float)
    _check_joint_count(ctx, np.asarray(seed), "the seed")
    accept = None
    if configuration:
        if not is_arm(ctx.device):
            raise UserError(f"--config is for 6-axis arms; '{ctx.device.name}' is none")
        dev = ctx.device

        def accept(Q):
            return arm_configurations(dev, Q).matches(configuration)

    result = solve_ik(
        ctx.device, T_base_target, ctx.mount, seed, position_only, restarts, accept=accept
    )
    if not result.success and configuration:
        anyhow = solve_ik(ctx.device, T_base_target, ctx.mount, seed, position_only, restarts)
        if anyhow.success:
            have = arm_configurations(ctx.device, anyhow.q).names()
            said = lambda c: ", ".join(f"{k}={v}" for k, v in c.items())  # noqa: E731
            raise UserError(
                f"no joint solution within the limits reaches {target_name} with "
                f"{said(configuration)}; one with {said(have)} does"
            )
    if not result.success:
        why = result.unreachable(
            target_name, ctx.tcp, [j.name for j in ctx.device.joints], position_only
        )
        raise UserError(f"target {why[:-1]}; {restarts + 1} starts)")
    return result


def configuration_of(ctx: DeviceContext, q) -> dict[str, str] | None:
    """A 6-axis arm's configuration at ``q`` (shoulder, elbow, wrist), or None for others."""
    from ..kinematics.configuration import arm_configurations, is_arm

    return arm_configurations(ctx.device, q).names() if is_arm(ctx.device) else None


def grasped(ctx: DeviceContext) -> list[tuple[str, float]]:
    """Objects the device grasps in the cell's state: [(name, mass [kg])]."""
    out = []
    for name, _, bodies in ctx.world.carried(ctx.device.name):
        aff = ctx.world.affixment(name)
        if aff is not None and aff.kind == "grasp" and name in ctx.world.cell.objects:
            out.append((name, float(sum(inertial.mass for inertial, _ in bodies))))
    return out


def resolve_payload(ctx: DeviceContext, object_name: str | None, mass: float | None, com=None):
    """A Payload from an object of the cell (at its current pose relative to the TCP, or at the
    TCP) or a point mass.

    Raises
    ------
    UserError
        Both given; or a point mass while the device grasps an object in the cell's state (the
        load would count twice: the object is already carried).
    """
    from ..dynamics import Payload
    from ..errors import did_you_mean

    if object_name and mass is not None:
        raise UserError("give --payload OBJECT or --payload-mass KG, not both")
    holding = grasped(ctx)
    if mass is not None and holding:
        name, kg = holding[0]
        raise UserError(
            f"a load given twice: --payload-mass {mass:g} kg at {ctx.tcp}, and '{name}' "
            f"({kg:g} kg), which {ctx.device.name} grasps in the cell's state and is counted "
            f"already; give the object as the payload (--payload {name}, counted once) or leave "
            "--payload-mass out"
        )
    if object_name:
        objects = ctx.world.cell.objects
        if object_name not in objects:
            raise UserError(f"unknown object '{object_name}'{did_you_mean(object_name, objects)}")
        held = object_name in ctx.world.subtree(ctx.tcp)
        T = ctx.world.T(ctx.tcp, object_name) if held else np.eye(4)
        return Payload.rigid_body(objects[object_name].inertial, T)
    if mass is not None:
        if not (mass >= 0 and np.isfinite(mass)):
            raise UserError(f"--payload-mass must be a finite number >= 0, got {mass}")
        return Payload.point_mass(mass, com if com is not None else (0.0, 0.0, 0.0))
    return None


def carried_loads(ctx: DeviceContext, exclude=()) -> dict[int, list]:
    """What rides on the device's links in the cell's state - aggregated devices (a hand on the
    flange), grasped objects - as ``DeviceDynamics`` link loads; ``exclude`` names primitives to
    leave
    out (an object given as the payload)."""
    return ctx.world.carried_loads(ctx.device.name, set(exclude))


def load_notes(ctx: DeviceContext, payload, payload_object: str | None, exclude=()) -> list[str]:
    """What a dynamics result includes beyond the device's own links, one line each: the
    payload, and everything the cell's state puts on its links (a hand, a grasped part)."""
    out = []
    if payload is not None and payload.mass > 0:
        what = f"'{payload_object}'" if payload_object else "a point mass"
        out.append(f"includes the payload: {what}, {payload.mass:g} kg at {ctx.tcp}")
    for item in carried_summary(ctx, exclude):
        out.append(
            f"includes what {ctx.device.name} carries in the cell's state: {item['name']}, "
            f"{item['mass']:g} kg on link {item['link']}"
        )
    dyn_mass = sum(link.inertial.mass for link in ctx.device.links)
    if dyn_mass == 0 and not out:
        out.append(
            f"every link of '{ctx.device.name}' is massless (an imported URDF without "
            "<inertial>?): its torques are armature and friction alone"
        )
    return out


def forward_dynamics(ctx: DeviceContext, dyn, q, qd, tau) -> np.ndarray:
    """``dyn.forward`` with a singular mass matrix as bad input (the model has a joint that
    moves no inertia), not as a bug."""
    try:
        return dyn.forward(q, qd, tau, ctx.gravity_base)
    except ValueError as exc:
        if "singular" not in str(exc):
            raise
        raise UserError(
            f"{exc}; give the links mass and inertia in the cell (an imported URDF without "
            "<inertial> elements has none), or a payload"
        ) from None


def carried_summary(ctx: DeviceContext, exclude=()) -> list[dict]:
    """[{"name", "link", "mass"}] of what rides on the device's links (see
    :func:`carried_loads`).
    """
    return [
        {"name": name, "link": link, "mass": float(sum(inertial.mass for inertial, _ in bodies))}
        for name, link, bodies in ctx.world.carried(ctx.device.name, set(exclude))
    ]


def device_dynamics(
    ctx: DeviceContext, payload=None, armature: bool = True, friction: bool = True, exclude=()
):
    """:class:`~rworld_cli.dynamics.DeviceDynamics` of the context's device, payload at its TCP.

    What the cell's state puts on its links (hands, grasped objects) is included, as the simulator
    includes it, except the primitives named in ``exclude`` (an object given as the payload).
    """
    from ..dynamics import DeviceDynamics

    if payload is not None and payload.mass > 0 and ctx.mount.link == 0:
        raise UserError(
            f"'{ctx.tcp}' sits on the base of '{ctx.device.name}': a payload there loads no "
            "joint; choose a TCP on a link"
        )
    return DeviceDynamics(
        ctx.device, payload, ctx.mount, armature, friction, link_loads=carried_loads(ctx, exclude)
    )


@dataclass
class StaticResult:
    tau: np.ndarray  # (N, n) total: gravity hold + J^T w
    tau_wrench: np.ndarray
    tau_gravity: np.ndarray
    max_scale: np.ndarray  # (N,)
    limiting_joint: np.ndarray  # (N,)


def static_torques(
    ctx: DeviceContext, q, wrench_world, payload=None, gravity: bool = True, exclude=()
) -> StaticResult:
    """Joint torques holding the device (and payload) still while the tool exerts ``wrench_world``.

    Also the largest multiple of the wrench the effort limits allow, and the joint that binds.
    """
    from ..dynamics.statics import wrench_capacity, wrench_torques

    q = np.atleast_2d(np.asarray(q, dtype=float))
    _check_joint_count(ctx, q)
    w = np.asarray(wrench_world, dtype=float)
    J = jacobians(ctx, q, "world").jacobian
    tau_w = wrench_torques(J, w)
    dyn = device_dynamics(ctx, payload, armature=False, friction=False, exclude=exclude)
    tau_g = dyn.gravity_torques(q, ctx.gravity_base) if gravity else np.zeros_like(q)
    cap = wrench_capacity(J, w, ctx.device.limit_array("effort"), tau_g)
    return StaticResult(tau_g + tau_w, tau_w, tau_g, cap.scale, cap.limiting_joint)


def the_device(cell_path: str, device: str | None) -> str:
    """``device``, or the cell's only device when none is named."""
    from ..schema.loader import load_cell

    if device is not None:
        return device
    devices = list(load_cell(cell_path).cell.devices)
    if len(devices) != 1:
        raise UserError(
            f"the cell has {len(devices)} devices ({', '.join(devices)}); choose one with --device"
        )
    return devices[0]


def joint_states(ctx: DeviceContext, states_file: str | None, q_values=None, groups=("q",)):
    """Joint arrays from a CSV state file (columns ``q1..qn``, ``qd1..``, ...) or one set of q
    values.

    Returns
    -------
    (dict group -> ndarray (N, n), list of Issue)
        The warnings name joint values outside their limits (kept: analysis may want them).
    """
    from ..schema.tables import limit_warnings, read_states

    n = ctx.device.dof
    if states_file is not None:
        data = read_states(states_file, n, list(groups))
        source = states_file
    else:
        q = np.asarray(q_values, dtype=float).reshape(1, -1)
        _check_joint_count(ctx, q)
        data, source = {"q": q}, "--q"
    return data, limit_warnings(
        source, data["q"], ctx.device.limit_array("lower"), ctx.device.limit_array("upper")
    )


def table_text(columns: list[str], rows) -> str:
    """CSV text with a header (numbers round-trip exact)."""
    from ..schema.tables import format_csv

    return format_csv(columns, rows)


def write_table(path: str, columns: list[str], rows) -> None:
    """Write a CSV table atomically."""
    from ..schema.tables import write_csv

    write_csv(path, columns, rows)


def pose_rows(T) -> np.ndarray:
    """Poses (N, 4, 4) as rows x, y, z, qw, qx, qy, qz (m; unit quaternion)."""
    from ..spatial import matrix_to_quat

    T = np.asarray(T, dtype=float).reshape(-1, 4, 4)
    return np.hstack([T[:, :3, 3], matrix_to_quat(T[:, :3, :3])])


def target_pose(
    ctx: DeviceContext, target: str | None = None, xyz=None, rpy=None, position_only: bool = False
):
    """(T_world_target, name): a frame of the cell, or a point (and fixed-axis roll, pitch, yaw
    [rad]) in world.
    """
    from ..errors import did_you_mean
    from ..spatial import make_transform, rpy_to_matrix

    if (target is None) == (xyz is None):
        raise UserError("give --target FRAME or --xyz X,Y,Z (one of them)")
    if target is not None:
        if target not in ctx.world.cell.frames:
            raise UserError(
                f"unknown frame '{target}'{did_you_mean(target, ctx.world.cell.frames)}"
            )
        return ctx.world.T_world(target), target
    if rpy is None and not position_only:
        raise UserError("--xyz needs --rpy, or --position-only")
    R = rpy_to_matrix(rpy) if rpy is not None else None
    return make_transform(R, xyz), "xyz " + ",".join(f"{v:g}" for v in xyz)
