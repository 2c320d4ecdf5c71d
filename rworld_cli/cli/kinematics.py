"""rworld kinematics fk|jacobian|ik"""

from __future__ import annotations

import click

from .common import handle_errors, json_option
from .physics_common import context, device_options, emit, joint_rows, output_options, parse_vector


@click.group()
def kinematics() -> None:
    """Forward kinematics, Jacobians and inverse kinematics of a device.

    Joint values are SI (rad, m); poses are in world.  Joint values come from
    --q q1,...,qn or from a CSV file with a header row q1..qn (--states).
    """


@kinematics.command()
@device_options
@click.option("--q", default=None, metavar="Q1,...,QN", help="One set of joint values.")
@click.option(
    "--states", default=None, type=click.Path(dir_okay=False), help="CSV with columns q1..qn."
)
@output_options
@json_option
@handle_errors
def fk(cell, device, other_joints, tcp, q, states, output, json_output):
    """Tool pose in world for each set of joint values.

    CSV out: x, y, z [m], qw, qx, qy, qz.  JSON: {"device", "tcp",
    "T_world_tool": [4x4 per row], "warnings"}.

    \b
    Examples:
      rworld kinematics fk workcells/puma560 --q 0,0.5,-1,0,0.3,0
      rworld kinematics fk workcells/paper_fig9 -d robot --tcp hand_a.tcp --states q.csv -o
      poses.csv
    """
    from ..api import forward_kinematics, pose_rows

    ctx = context(cell, device, tcp, other_joints)
    data, warnings = joint_rows(ctx, states, q, ["q"])
    T = forward_kinematics(ctx, data["q"])
    rows = pose_rows(T)
    payload = {
        "device": ctx.device.name,
        "tcp": ctx.tcp,
        "frame": "world",
        "T_world_tool": T.tolist(),
    }
    emit(["x", "y", "z", "qw", "qx", "qy", "qz"], rows, payload, json_output, output, warnings)


@kinematics.command()
@device_options
@click.option("--q", default=None, metavar="Q1,...,QN", help="One set of joint values.")
@click.option(
    "--states", default=None, type=click.Path(dir_okay=False), help="CSV with columns q1..qn."
)
@click.option(
    "--frame",
    type=click.Choice(["world", "base"]),
    default="world",
    show_default=True,
    help="Frame the velocity rows are expressed in.",
)
@click.option(
    "--point",
    default=None,
    metavar="X,Y,Z",
    help="Point on the tool (tool coordinates, m) whose velocity the top rows give.",
)
@output_options
@json_option
@handle_errors
def jacobian(cell, device, other_joints, tcp, q, states, frame, point, output, json_output):
    """Geometric Jacobian (rows vx vy vz wx wy wz) with manipulability and condition number.

    CSV out: J11..J6n row-major, manipulability, condition_number.  JSON:
    {"device", "tcp", "frame", "jacobian": [6xn per row], "manipulability", "condition_number"}.

    \b
    Example:
      rworld kinematics jacobian workcells/puma560 --q 0,0.5,-1,0,0.3,0 --json
    """
    import numpy as np

    from ..api import jacobians

    ctx = context(cell, device, tcp, other_joints)
    data, warnings = joint_rows(ctx, states, q, ["q"])
    res = jacobians(ctx, data["q"], frame, parse_vector(point, "--point", 3) if point else None)
    n = ctx.device.dof
    cols = [f"J{r}{c}" for r in range(1, 7) for c in range(1, n + 1)] + [
        "manipulability",
        "condition_number",
    ]
    rows = np.hstack(
        [
            res.jacobian.reshape(len(res.jacobian), -1),
            res.manipulability[:, None],
            res.condition_number[:, None],
        ]
    )
    payload = {
        "device": ctx.device.name,
        "tcp": ctx.tcp,
        "frame": frame,
        "jacobian": res.jacobian.tolist(),
        "manipulability": res.manipulability.tolist(),
        "condition_number": [float(c) if np.isfinite(c) else None for c in res.condition_number],
    }
    emit(cols, rows, payload, json_output, output, warnings)


@kinematics.command()
@device_options
@click.option(
    "--target",
    default=None,
    metavar="FRAME",
    help="A frame of the cell to reach (e.g. workpiece.grasp).",
)
@click.option(
    "--xyz",
    default=None,
    metavar="X,Y,Z",
    help="Target position in world [m] (instead of --target).",
)
@click.option(
    "--rpy",
    default=None,
    metavar="R,P,Y",
    help="Target roll, pitch, yaw in world [rad] (with --xyz).",
)
@click.option("--position-only", is_flag=True, help="Match the TCP origin only.")
@click.option(
    "--seed",
    default=None,
    metavar="Q1,...,QN",
    help="Start (default: the device's current values).",
)
@click.option(
    "--restarts",
    default=16,
    show_default=True,
    type=click.IntRange(0, 10000),
    help="Random starts besides the seed.",
)
@click.option(
    "--config",
    "configuration",
    default=None,
    metavar="shoulder=front,elbow=up,wrist=noflip",
    help="A 6-axis arm's configuration to solve in (any of the three; docs/export.md).",
)
@output_options
@json_option
@handle_errors
def ik(
    cell,
    device,
    other_joints,
    tcp,
    target,
    xyz,
    rpy,
    position_only,
    seed,
    restarts,
    configuration,
    output,
    json_output,
):
    """Joint values that put the TCP on a target frame.

    Damped least squares within the joint limits, all starts batched; of the
    solutions found, the one nearest the seed.  An unreachable target exits 2
    with how far off the closest pose is and which joints sit on a limit.

    \b
    Examples:
      rworld kinematics ik workcells/puma560 --target workpiece.grasp
      rworld kinematics ik workcells/puma560 --xyz 0.5,0.2,0.6 --position-only --json
      rworld kinematics ik workcells/puma560 --target workpiece.grasp --config elbow=down
    """

    from ..api import inverse_kinematics, target_pose

    ctx = context(cell, device, tcp, other_joints)
    if (target is None) == (xyz is None):
        raise click.UsageError("give --target FRAME or --xyz X,Y,Z (one of them)")
    if xyz is not None and rpy is None and not position_only:
        raise click.UsageError("--xyz needs --rpy, or --position-only")
    T_target, name = target_pose(
        ctx,
        target,
        parse_vector(xyz, "--xyz", 3) if xyz else None,
        parse_vector(rpy, "--rpy", 3) if rpy else None,
        position_only,
    )
    if xyz is not None:
        name = f"xyz {xyz}"
    seed_q = parse_vector(seed, "--seed", ctx.device.dof) if seed else None
    wanted = _configuration(configuration) if configuration else None
    result = inverse_kinematics(ctx, T_target, name, seed_q, position_only, restarts, wanted)
    from ..api import configuration_of

    took = configuration_of(ctx, result.q)
    payload = {
        "device": ctx.device.name,
        "tcp": ctx.tcp,
        "target": name,
        "configuration": took,
        "q": result.q.tolist(),
        "position_error": result.position_error,
        "rotation_error": result.rotation_error,
        "iterations": result.iterations,
        "success": result.success,
    }
    if not json_output:
        click.echo(
            f"reached {name} with {ctx.tcp}: position error {result.position_error:.3g} m, "
            f"rotation error {result.rotation_error:.3g} rad ({result.iterations} iterations)"
            + (f"; {', '.join(f'{k} {v}' for k, v in took.items())}" if took else ""),
            err=True,
        )
    emit(
        [f"q{i}" for i in range(1, ctx.device.dof + 1)],
        result.q[None, :],
        payload,
        json_output,
        output,
        [],
    )


CONFIGURATION_WORDS = {
    "shoulder": ("front", "back"),
    "elbow": ("up", "down"),
    "wrist": ("noflip", "flip"),
}


def _configuration(text: str) -> dict[str, str]:
    """``shoulder=front,elbow=up,wrist=noflip`` (any of them) as a dict; bad words exit 2."""
    out = {}
    for part in text.split(","):
        key, sep, value = part.strip().partition("=")
        if not sep or key not in CONFIGURATION_WORDS or value not in CONFIGURATION_WORDS[key]:
            choices = "; ".join(f"{k}={'|'.join(v)}" for k, v in CONFIGURATION_WORDS.items())
            raise click.BadParameter(f"'{part.strip()}': give {choices}", param_hint="--config")
        out[key] = value
    return out
