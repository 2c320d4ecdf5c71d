"""rworld dynamics inverse|forward|static"""

from __future__ import annotations

import click

from .common import FiniteFloat, handle_errors, json_option
from .physics_common import context, device_options, emit, joint_rows, output_options, parse_vector


def payload_options(fn):
    fn = click.option(
        "--payload-com",
        default=None,
        metavar="X,Y,Z",
        help="Point mass position in the TCP frame [m].",
    )(fn)
    fn = click.option(
        "--payload-mass",
        default=None,
        type=FiniteFloat(min=0),
        metavar="KG",
        help="A point mass at the TCP.",
    )(fn)
    fn = click.option(
        "--payload",
        "payload_object",
        default=None,
        metavar="OBJECT",
        help="An object's mass properties, held at the TCP (where the cell holds it there).",
    )(fn)
    return fn


def model_options(fn):
    """Payload and the armature / friction switches (inverse and forward dynamics)."""
    fn = click.option(
        "--no-friction", is_flag=True, help="Leave out viscous and Coulomb friction."
    )(fn)
    fn = click.option("--no-armature", is_flag=True, help="Leave out motor armature inertia.")(fn)
    return payload_options(fn)


def _payload(ctx, payload_object, payload_mass, payload_com):
    from ..api import resolve_payload

    com = parse_vector(payload_com, "--payload-com", 3) if payload_com else None
    return resolve_payload(ctx, payload_object, payload_mass, com)


def _model(ctx, payload_object, payload_mass, payload_com, no_armature, no_friction):
    """The device's dynamics with the payload options (a payload object is not counted again as
    carried), and the lines that say which loads it includes."""
    from ..api import device_dynamics, load_notes

    payload = _payload(ctx, payload_object, payload_mass, payload_com)
    exclude = [payload_object] if payload_object else ()
    notes = load_notes(ctx, payload, payload_object, exclude)
    return device_dynamics(ctx, payload, not no_armature, not no_friction, exclude), notes


@click.group()
def dynamics() -> None:
    """Inverse and forward dynamics and static force transmission of a device.

    States are CSV files with a header row (q1..qn, qd1..qdn, qdd1..qddn,
    tau1..taun; SI); a command reads the columns it needs.  Gravity comes
    from the cell, expressed in the device's base frame.  Motor armature
    (Jm G^2) and friction are included where the cell declares them.
    """


@dynamics.command()
@device_options
@click.option(
    "--states", required=True, type=click.Path(dir_okay=False), help="CSV with q, qd, qdd columns."
)
@model_options
@output_options
@json_option
@handle_errors
def inverse(
    cell,
    device,
    other_joints,
    tcp,
    states,
    payload_object,
    payload_mass,
    payload_com,
    no_armature,
    no_friction,
    output,
    json_output,
):
    """Joint torques for each state, by recursive Newton-Euler (batched).

    CSV out: tau1..taun [N m or N].  JSON: {"device": NAME, "tau": [[...], ...]}.

    \b
    Examples:
      rworld dynamics inverse workcells/puma560 --states states.csv --json
      rworld dynamics inverse workcells/puma560 --states states.csv --payload workpiece -o tau.csv
      rworld dynamics inverse workcells/puma560 --states states.csv --payload-mass 2.5 --no-friction
    """
    ctx = context(cell, device, tcp, other_joints)
    data, warnings = joint_rows(ctx, states, None, ["q", "qd", "qdd"])
    dyn, notes = _model(ctx, payload_object, payload_mass, payload_com, no_armature, no_friction)
    tau = dyn.inverse(data["q"], data["qd"], data["qdd"], ctx.gravity_base)
    emit(
        [f"tau{i}" for i in range(1, ctx.device.dof + 1)],
        tau,
        {"device": ctx.device.name, "tau": tau.tolist()},
        json_output,
        output,
        warnings,
        notes,
    )


@dynamics.command()
@device_options
@click.option(
    "--states", required=True, type=click.Path(dir_okay=False), help="CSV with q, qd, tau columns."
)
@model_options
@output_options
@json_option
@handle_errors
def forward(
    cell,
    device,
    other_joints,
    tcp,
    states,
    payload_object,
    payload_mass,
    payload_com,
    no_armature,
    no_friction,
    output,
    json_output,
):
    """Joint accelerations for given torques: qdd = M(q)^-1 (tau - C qd - g - friction).

    CSV out: qdd1..qddn.  JSON: {"device": NAME, "qdd": [[...], ...]}.

    \b
    Example:
      rworld dynamics forward workcells/puma560 --states torques.csv --json
    """
    ctx = context(cell, device, tcp, other_joints)
    data, warnings = joint_rows(ctx, states, None, ["q", "qd", "tau"])
    from ..api import forward_dynamics

    dyn, notes = _model(ctx, payload_object, payload_mass, payload_com, no_armature, no_friction)
    qdd = forward_dynamics(ctx, dyn, data["q"], data["qd"], data["tau"])
    emit(
        [f"qdd{i}" for i in range(1, ctx.device.dof + 1)],
        qdd,
        {"device": ctx.device.name, "qdd": qdd.tolist()},
        json_output,
        output,
        warnings,
        notes,
    )


@dynamics.command()
@device_options
@click.option("--q", default=None, metavar="Q1,...,QN", help="One configuration.")
@click.option("--states", default=None, type=click.Path(dir_okay=False), help="CSV with q columns.")
@click.option(
    "--wrench",
    default="0,0,0,0,0,0",
    show_default=True,
    metavar="FX,FY,FZ,MX,MY,MZ",
    help="Wrench the tool exerts on its surroundings, at the TCP origin, world axes [N, N m].",
)
@click.option(
    "--no-gravity", is_flag=True, help="Leave out the torques that hold the device against gravity."
)
@payload_options
@output_options
@json_option
@handle_errors
def static(
    cell,
    device,
    other_joints,
    tcp,
    q,
    states,
    wrench,
    no_gravity,
    payload_object,
    payload_mass,
    payload_com,
    output,
    json_output,
):
    """Joint torques to hold still while the tool pushes with a wrench: tau = g(q) + J^T w.

    Also the largest multiple of the wrench the effort limits allow
    (max_scale) and the joint that binds first.  CSV out: tau1..taun,
    max_scale, limiting_joint.  JSON: {"device", "wrench", "tau",
    "tau_wrench", "tau_gravity", "max_scale", "limiting_joint"}.

    \b
    Example:
      rworld dynamics static workcells/puma560 --q 0,0.5,-1,0,0.3,0 --wrench 0,0,-50,0,0,0
    """
    import numpy as np

    from ..api import load_notes, static_torques

    ctx = context(cell, device, tcp, other_joints)
    data, warnings = joint_rows(ctx, states, q, ["q"])
    w = parse_vector(wrench, "--wrench", 6)
    load = _payload(ctx, payload_object, payload_mass, payload_com)
    exclude = [payload_object] if payload_object else ()
    res = static_torques(ctx, data["q"], w, load, not no_gravity, exclude=exclude)
    notes = load_notes(ctx, load, payload_object, exclude) if not no_gravity else []
    names = [j.name for j in ctx.device.joints]
    limiting = [names[i] if i >= 0 else None for i in res.limiting_joint]
    scale = [float(s) if np.isfinite(s) else None for s in res.max_scale]
    payload = {
        "device": ctx.device.name,
        "tcp": ctx.tcp,
        "wrench": w,
        "tau": res.tau.tolist(),
        "tau_wrench": res.tau_wrench.tolist(),
        "tau_gravity": res.tau_gravity.tolist(),
        "max_scale": scale,
        "limiting_joint": limiting,
    }
    rows = np.hstack([res.tau, res.max_scale[:, None], (res.limiting_joint + 1)[:, None]])
    emit(
        [f"tau{i}" for i in range(1, ctx.device.dof + 1)] + ["max_scale", "limiting_joint"],
        rows,
        payload,
        json_output,
        output,
        warnings,
        notes,
    )
