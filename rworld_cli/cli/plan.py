"""rworld plan path | time-optimal | payload | load-optimal | impulse"""

from __future__ import annotations

import click

from .common import FiniteFloat, emit_json, handle_errors, json_option, output_option, seed_option
from .physics_common import context, device_options, output_options, parse_vector

GRID_HELP = "Grid points on the path (N points, N - 1 intervals), as toppra counts them."
SAMPLES_DEFAULT = 20001


def sampling_options(fn):
    """--samples / --period / --grid-instants: the rows of a trajectory CSV (and the instants
    checked).
    """
    fn = click.option(
        "--grid-instants",
        is_flag=True,
        help="Also write both sides of every grid instant, where the path acceleration jumps.",
    )(fn)
    fn = click.option(
        "--period",
        default=None,
        metavar="DT",
        help="A row every DT (e.g. 8ms, 0.004s) from t = 0 for fixed-rate controllers, instead of "
        "--samples; "
        "the last row, at or after the end, is at rest.",
    )(fn)
    return click.option(
        "--samples",
        default=None,
        type=click.IntRange(2, 10_000_000),
        metavar="N",
        help=f"Equally spaced instants, ends included  [default: {SAMPLES_DEFAULT}].",
    )(fn)


def _sampling(samples, period):
    from ..api import parse_period

    if samples is not None and period is not None:
        raise click.UsageError("give --samples N or --period DT, not both")
    return (SAMPLES_DEFAULT if samples is None and period is None else samples), (
        parse_period(period) if period else None
    )


def _unlimited_line(unlimited: dict) -> str:
    return "unlimited (no limit in the cell): " + "; ".join(
        f"{kind} of {', '.join(joints)}" for kind, joints in unlimited.items()
    )


@click.group()
def plan() -> None:
    """Planning for a device: collision-free joint paths, and timing along a path.

    'plan path' finds a collision-free path and writes a path file; the
    others time a path file (waypoints in the file's units, optional knots,
    boundary; docs/planning.md).  Limits are the device's velocity,
    acceleration and effort limits; torques include the motor armature
    (Jm G^2).
    """


@plan.command("time-optimal")
@device_options
@click.option(
    "--path", "path_file", required=True, type=click.Path(dir_okay=False), help="Path file (YAML)."
)
@click.option(
    "--gridpoints", default=1000, show_default=True, type=click.IntRange(10, 100000), help=GRID_HELP
)
@click.option("--no-torque", is_flag=True, help="Velocity and acceleration limits only.")
@click.option(
    "--payload",
    "payload_object",
    default=None,
    metavar="OBJECT",
    help="An object's mass properties at the TCP.",
)
@click.option(
    "--payload-mass",
    default=None,
    type=FiniteFloat(min=0),
    metavar="KG",
    help="A point mass at the TCP (see --payload-com).",
)
@click.option(
    "--payload-com", default=None, metavar="X,Y,Z", help="Point mass position in the TCP frame [m]."
)
@sampling_options
@click.option(
    "--plot",
    default=None,
    type=click.Path(dir_okay=False),
    help="PNG: path speed against its limit, torque ratios.",
)
@output_options
@json_option
@handle_errors
def time_optimal(
    cell,
    device,
    other_joints,
    tcp,
    path_file,
    gridpoints,
    no_torque,
    payload_object,
    payload_mass,
    payload_com,
    samples,
    period,
    grid_instants,
    plot,
    output,
    json_output,
):
    """The fastest rest-to-rest timing of a path within velocity, acceleration and torque limits.

    Reachability analysis (as in TOPP-RA) on a grid, with the limits
    imposed at both ends of every interval.  Between grid points the
    velocity and acceleration maxima are found exactly and torque is bounded
    on a fine grid (20 001 points, with the interpolation error bound); an
    interval over a limit is slowed locally and the grid solved again, so
    the trajectory respects every limit between grid points as well.

    A joint with no limit of a kind in the cell runs unlimited in that kind
    (the output names it); the other joints keep their limits.  A path whose
    spline leaves a joint's position range between waypoints exits 1.

    The CSV (-o) has t, s, sd, sdd, q, qd, qdd and tau columns (SI), at
    --samples instants or every --period.

    \b
    Examples:
      rworld plan time-optimal workcells/puma560 --path workcells/puma560/paths/reference.yaml
      rworld plan time-optimal workcells/puma560 --path p.yaml --payload-mass 2 --payload-com
      0,0,0.1 --plot p.png -o traj.csv
      rworld plan time-optimal workcells/puma560 --path p.yaml --period 8ms --grid-instants -o
      traj.csv
    """
    from ..api import time_optimal_plan

    samples, period = _sampling(samples, period)
    ctx = context(cell, device, tcp, other_joints)
    com = parse_vector(payload_com, "--payload-com", 3) if payload_com else None
    p = time_optimal_plan(
        ctx,
        path_file,
        gridpoints,
        not no_torque,
        payload_object,
        payload_mass,
        com,
        samples,
        period,
        grid_instants,
        output,
        plot,
    )
    timing, info, carried, unlimited, binding, peaks = (
        p.timing,
        p.info,
        p.carried,
        p.unlimited,
        p.binding,
        p.peak_ratio,
    )
    if json_output:
        emit_json(
            {
                "device": ctx.device.name,
                "path": path_file,
                "gridpoints": gridpoints,
                **p.as_dict(),
                "written": output,
                "plot": plot,
            }
        )
        return
    click.echo(
        f"{ctx.device.name}: {path_file}: cycle time {timing.duration:.6f} s ({gridpoints} grid "
        "points)"
    )
    for note in p.notes:
        click.echo(f"note: {note}")
    if not p.loads_counted and carried:
        _echo_carried(carried)
        click.echo("  (no torque limit in the timing, so no load counts)")
    if unlimited:
        click.echo(_unlimited_line(unlimited))
    click.echo("binding along the path: " + ", ".join(f"{k} {v:.0%}" for k, v in binding.items()))
    click.echo(
        f"peak ratio to the limits ({len(p.rows.t)} rows): "
        + ", ".join(f"{k} {v:.6f}" if v == v else f"{k} n/a" for k, v in peaks.items())
    )
    if info["repaired"]:
        click.echo(
            f"slowed locally at {info['repaired']} grid point(s) so that no limit is exceeded "
            "between grid points "
            f"({info['rounds']} solves)"
        )
    if timing.scale > 1:
        click.echo(
            f"slowed uniformly by {timing.scale - 1:.2e} (relative): the local repairs did not "
            "settle"
        )
    for path_out in (output, plot):
        if path_out:
            click.echo(f"wrote {path_out}")


@plan.command("payload")
@device_options
@click.option(
    "--path",
    "path_file",
    default=None,
    type=click.Path(dir_okay=False),
    help="Path file (YAML), timed by --timing.",
)
@click.option(
    "--trajectory",
    "trajectory_file",
    default=None,
    type=click.Path(dir_okay=False),
    metavar="CSV",
    help="Or a trajectory timed elsewhere: CSV with t, q1..qn, qd1..qdn, qdd1..qddn (SI), e.g. a "
    "plan's -o.",
)
@click.option(
    "--timing",
    type=click.Choice(["time-optimal", "quintic"]),
    default="time-optimal",
    show_default=True,
    help="--path: time-optimal (velocity + acceleration limits, no payload) or a quintic time law "
    "over --duration.",
)
@click.option(
    "--duration",
    type=FiniteFloat(min=0, min_open=True),
    default=None,
    help="Quintic: the duration [s].",
)
@click.option(
    "--payload-com",
    default="0,0,0",
    show_default=True,
    metavar="X,Y,Z",
    help="Where the point mass sits, TCP frame [m].",
)
@click.option(
    "--payload",
    "payload_object",
    default=None,
    metavar="OBJECT",
    help="Scale an object's mass properties instead of a point mass.",
)
@click.option(
    "--gridpoints", default=1000, show_default=True, type=click.IntRange(10, 100000), help=GRID_HELP
)
@click.option(
    "--samples",
    default=SAMPLES_DEFAULT,
    show_default=True,
    type=click.IntRange(2, 10_000_000),
    metavar="N",
    help="--path: instants checked; a time-optimal timing adds both sides of every grid instant, "
    "where the acceleration jumps.",
)
@json_option
@handle_errors
def payload(
    cell,
    device,
    other_joints,
    tcp,
    path_file,
    trajectory_file,
    timing,
    duration,
    payload_com,
    payload_object,
    gridpoints,
    samples,
    json_output,
):
    """The largest payload a timed path can carry within the torque limits - exact (torque is affine
    in mass).

    The path is timed here (--path with --timing) or was timed elsewhere
    (--trajectory CSV: every row is checked).  A joint with no effort limit
    in the cell is unlimited in torque; a path that leaves a joint's position
    range between waypoints exits 1.

    \b
    Examples:
      rworld plan payload workcells/puma560 --path workcells/puma560/paths/reference.yaml --tcp
      probe
      rworld plan payload workcells/puma560 --path workcells/puma560/paths/reference.yaml --tcp
      probe --timing quintic --duration 5
      rworld plan payload workcells/puma560 --trajectory traj.csv --tcp probe
    """
    from ..api import carried_summary, plan_payload
    from ..errors import UserError

    if (path_file is None) == (trajectory_file is None):
        raise click.UsageError(
            "give the motion as --path FILE (timed here) or --trajectory CSV (timed elsewhere)"
        )
    if timing == "quintic" and (duration is None or not duration > 0):
        raise UserError("--timing quintic needs --duration SECONDS > 0")
    ctx = context(cell, device, tcp, other_joints)
    r = plan_payload(
        ctx,
        path_file,
        trajectory_file,
        timing,
        duration,
        parse_vector(payload_com, "--payload-com", 3),
        payload_object,
        gridpoints,
        samples,
    )
    exclude = [payload_object] if payload_object else ()
    carried = carried_summary(ctx, exclude)
    joint = ctx.device.joints[r.capacity.joint].name
    unlimited = {k: v for k, v in ctx.device.unlimited().items() if k == "torque"}
    source = trajectory_file or path_file
    label = "external" if trajectory_file else timing
    if json_output:
        emit_json(
            {
                "device": ctx.device.name,
                "tcp": ctx.tcp,
                "timing": label,
                "source": source,
                "duration": r.duration,
                "payload_mass": r.capacity.mass,
                "binding_joint": joint,
                "binding_time": r.binding_time,
                "binding_side": r.capacity.side,
                "instants": r.instants,
                "unlimited": unlimited,
                "carried": carried,
            }
        )
        return
    click.echo(
        f"{ctx.device.name}: {label} timing of {source} ({r.duration:.6f} s): payload capacity "
        f"{r.capacity.mass:.4f} kg at {ctx.tcp}"
    )
    _echo_carried(carried)
    if unlimited:
        click.echo(_unlimited_line(unlimited))
    click.echo(
        f"binding: joint {joint} at t = {r.binding_time:.4f} s ({r.capacity.side} torque limit; "
        f"{r.instants} instants checked)"
    )
    if r.capacity.mass < 0:
        click.echo("negative: the trajectory overloads the joint even without a payload")


def _echo_carried(carried: list[dict]) -> None:
    """One line on what the cell's state puts on the device's links (included in every torque)."""
    if carried:
        click.echo(
            "  also carrying (the cell's state): "
            + ", ".join(f"{c['name']} {c['mass']:.3f} kg on link {c['link']}" for c in carried)
        )


@plan.command("load-optimal")
@device_options
@click.option(
    "--path", "path_file", required=True, type=click.Path(dir_okay=False), help="Path file (YAML)."
)
@click.option(
    "--duration", required=True, type=FiniteFloat(min=0, min_open=True), help="The cycle time [s]."
)
@click.option(
    "--payload-com",
    default="0,0,0",
    show_default=True,
    metavar="X,Y,Z",
    help="Where the point mass sits, TCP frame [m].",
)
@click.option(
    "--gridpoints", default=400, show_default=True, type=click.IntRange(10, 100000), help=GRID_HELP
)
@click.option(
    "--tolerance",
    default=1e-4,
    show_default=True,
    type=FiniteFloat(min=0, min_open=True),
    help="Mass resolution [kg].",
)
@click.option(
    "--shape",
    is_flag=True,
    help="Also optimise the path parameters of the waypoints (knots): the spline still passes "
    "through every waypoint.",
)
@click.option(
    "--evaluations",
    default=80,
    show_default=True,
    type=click.IntRange(5, 10000),
    help="--shape: path shapes tried.",
)
@click.option(
    "--shape-output",
    default=None,
    type=click.Path(dir_okay=False),
    metavar="FILE",
    help="--shape: write the path file with the optimised knots here.",
)
@sampling_options
@output_options
@json_option
@handle_errors
def load_optimal_cmd(
    cell,
    device,
    other_joints,
    tcp,
    path_file,
    duration,
    payload_com,
    gridpoints,
    tolerance,
    shape,
    evaluations,
    shape_output,
    samples,
    period,
    grid_instants,
    output,
    json_output,
):
    """The timing of a path that carries the heaviest payload within a cycle time (the report's
    OPTLOAD idea).

    Reports the payload and its gain over the unloaded time-optimal timing
    and over a quintic time law of the same duration.  With --shape the
    knots move too (Nelder-Mead on the cycle time at the payload, a few
    seconds), and the gain over the path as given is reported.

    \b
    Examples:
      rworld plan load-optimal workcells/puma560 --path workcells/puma560/paths/reference.yaml --tcp
      probe --duration 5
      rworld plan load-optimal workcells/puma560 --path workcells/puma560/paths/reference.yaml --tcp
      probe --duration 2.2 \\
          --shape --shape-output faster.yaml
    """
    import sys

    from ..api import carried_summary, load_optimal_plan

    samples, period = _sampling(samples, period)
    ctx = context(cell, device, tcp, other_joints)
    com = parse_vector(payload_com, "--payload-com", 3)

    def run(progress=None):
        return load_optimal_plan(
            ctx,
            path_file,
            duration,
            com,
            gridpoints,
            tolerance,
            shape,
            evaluations,
            shape_output,
            samples,
            period,
            grid_instants,
            output,
            progress,
        )

    if shape and not json_output and sys.stderr.isatty():
        from rich.progress import Progress

        with Progress(transient=True) as bar:
            task = bar.add_task("trying path shapes", total=evaluations)
            r, unlimited = run(lambda done, total: bar.update(task, completed=done, total=total))
    else:
        r, unlimited = run()
    payload = {
        "device": ctx.device.name,
        "tcp": ctx.tcp,
        "duration": duration,
        "payload_mass": r.mass,
        "unlimited": unlimited,
        "time_optimal_capacity": r.time_optimal_capacity,
        "quintic_capacity": r.quintic_capacity,
        "static_capacity": r.static_capacity,
        "knots": r.path.knots.tolist(),
        "given_shape_mass": r.given_shape_mass,
        "carried": carried_summary(ctx),
        "written": [f for f in (output, shape_output) if f],
    }
    if json_output:
        emit_json(payload)
        return
    click.echo(
        f"{ctx.device.name}: {path_file} in {duration} s carries {r.mass:.4f} kg at {ctx.tcp}"
    )
    _echo_carried(payload["carried"])
    if unlimited:
        click.echo(_unlimited_line(unlimited))
    click.echo(
        f"  a quintic time law over {duration} s: {r.quintic_capacity:.4f} kg "
        f"({r.mass - r.quintic_capacity:+.4f} kg)"
    )
    click.echo(
        f"  the unloaded time-optimal timing: {r.time_optimal_capacity:.4f} kg "
        f"({r.mass - r.time_optimal_capacity:+.4f} kg)"
    )
    click.echo(f"  at rest (any slower): at most {r.static_capacity:.4f} kg")
    if shape:
        knots = ", ".join(f"{k:.4f}" for k in r.path.knots)
        if r.given_shape_mass is not None and r.mass > r.given_shape_mass:
            click.echo(
                f"  knots [{knots}]: {r.mass - r.given_shape_mass:+.4f} kg over the path as given "
                f"({r.given_shape_mass:.4f} kg)"
            )
        else:
            click.echo(f"  no other knots carry more; kept [{knots}]")
    for written in (shape_output, output):
        if written:
            click.echo(f"wrote {written}")


@plan.command("impulse")
@device_options
@click.option("--target", required=True, metavar="FRAME", help="The frame the TCP arrives at.")
@click.option(
    "--direction", required=True, metavar="X,Y,Z", help="Direction of the impulse, world axes."
)
@click.option(
    "--payload-mass",
    default=0.0,
    show_default=True,
    type=FiniteFloat(min=0),
    help="Mass carried at the TCP [kg].",
)
@click.option(
    "--payload-com",
    default="0,0,0",
    show_default=True,
    metavar="X,Y,Z",
    help="Its position in the TCP frame [m].",
)
@click.option(
    "--start",
    default=None,
    metavar="Q1,...,QN",
    help="Start configuration (SI); default the device's current values.",
)
@click.option(
    "--gridpoints", default=300, show_default=True, type=click.IntRange(10, 100000), help=GRID_HELP
)
@json_option
@handle_errors
def impulse(
    cell,
    device,
    other_joints,
    tcp,
    target,
    direction,
    payload_mass,
    payload_com,
    start,
    gridpoints,
    json_output,
):
    """The motion from rest that reaches a target frame with the most momentum along a direction.

    The arrival direction is built into the path (the tool point moves along
    the direction at the end); the timing is time-optimal with the end speed
    free; the path's approach is searched for the largest momentum.  Limits:
    joint velocity, acceleration and torque (payload and armature included).

    \b
    Example:
      rworld plan impulse workcells/puma560 --tcp probe --target table.drop --direction 0,0,-1
      --payload-mass 2
    """
    from ..api import impulse_plan

    ctx = context(cell, device, tcp, other_joints)
    p = impulse_plan(
        ctx,
        target,
        parse_vector(direction, "--direction", 3),
        payload_mass,
        parse_vector(payload_com, "--payload-com", 3),
        parse_vector(start, "--start", ctx.device.dof) if start else None,
        gridpoints,
    )
    r, v_world, unlimited = p.result, p.end_velocity_world, p.unlimited
    out = {
        "device": ctx.device.name,
        "tcp": ctx.tcp,
        "target": target,
        "direction": p.direction_world.tolist(),
        "momentum": r.momentum if payload_mass > 0 else None,
        "speed_along": r.speed_along,
        "end_velocity": v_world.tolist(),
        "end_joint_velocity": r.end_joint_velocity.tolist(),
        "duration": r.duration,
        "binding": r.binding,
        "q_start": p.q_start.tolist(),
        "q_end": p.q_end.tolist(),
        "unlimited": unlimited,
    }
    if json_output:
        emit_json(out)
        return
    what = (
        f"momentum {r.momentum:.4f} kg m/s ({payload_mass} kg at " if payload_mass > 0 else "speed "
    )
    click.echo(
        f"{ctx.device.name}: reaches {target} in {r.duration:.4f} s with {what}"
        + (f"{r.speed_along:.4f} m/s)" if payload_mass > 0 else f"{r.speed_along:.4f} m/s")
        + " along the direction"
    )
    click.echo(
        f"  end velocity (world): [{', '.join(f'{x:.4f}' for x in v_world)}] m/s; limited at the "
        f"end by: {r.binding}"
    )
    if unlimited:
        click.echo("  " + _unlimited_line(unlimited))


@plan.command("path")
@device_options
@click.option(
    "--to",
    "to",
    required=True,
    metavar="TARGET",
    help="A frame of the cell (the TCP goes there; every joint solution is a goal), a named "
    "position of the device, 'home', or joint values Q1,...,QN (SI).",
)
@click.option(
    "--offset",
    default=None,
    metavar="X,Y,Z",
    help="A frame target moved along its own axes [m], e.g. 0,0,-0.12: 120 mm back from a "
    "grasp frame whose z points down (a free motion ends clear of what it will touch).",
)
@click.option(
    "--from",
    "start",
    default=None,
    metavar="STATE",
    help="Start: a named position, 'home' or joint values Q1,...,QN (SI); default the joints "
    "the pose files give.",
)
@click.option(
    "--clearance",
    default=None,
    metavar="LENGTH",
    help="Keep at least this far from everything, everywhere (e.g. 10mm); 0: no overlap "
    "deeper than the collision tolerance.  Default: 1 mm from every pair the start and goal "
    "leave room for.",
)
@click.option(
    "--collision-tolerance",
    default="1mm",
    show_default=True,
    metavar="LENGTH",
    help="Overlaps shallower than this are touches (as in 'rworld check').",
)
@seed_option("The search's random seed.")
@click.option(
    "--timeout",
    default=10.0,
    show_default=True,
    type=FiniteFloat(min=0, min_open=True),
    metavar="S",
    help="Give up after this many seconds of search (exit 1).",
)
@output_option("Write the path file (YAML, atomically): 'plan time-optimal --path' takes it.")
@click.option(
    "--blend/--no-blend",
    default=True,
    show_default=True,
    help="Cut the path's corners by blends the continuous check passes (the device moves "
    "through them); --no-blend: at rest at every via point.",
)
@click.option("--progress/--no-progress", default=True, help="A progress bar on stderr.")
@json_option
@handle_errors
def path_cmd(
    cell,
    device,
    other_joints,
    tcp,
    to,
    offset,
    start,
    clearance,
    collision_tolerance,
    seed,
    timeout,
    output,
    blend,
    progress,
    json_output,
):
    """A collision-free joint path from a state to a target, planned in the cell as it is.

    Bidirectional sampling (RRT-Connect) over the joint box, each edge's
    states checked in one batch with a 5 mm margin; then shortcuts; then
    every segment of the path checked continuously, as 'rworld check' checks
    a run (no contact deeper than the collision tolerance between states
    either).  The path is straight joint-space segments between its
    waypoints, each corner cut by a parabolic blend as wide as the
    continuous check allows (at rest where none passes; the file's
    'boundary: blended'), inside the joint limits.  The same cell, target
    and seed give the same path.  Exit 1 with the reason when none is found
    within --timeout.

    \b
    Examples:
      rworld plan path workcells/panda --to block.grasp --offset 0,0,-0.12 -o p.yaml
      rworld plan path workcells/panda --from home --to 0,0,0,-1.5,0,1.5,0.8 --clearance 10mm
      rworld plan time-optimal workcells/panda --path p.yaml
    """
    from ..api import parse_length_option, plan_free_path
    from .common import with_progress

    ctx = context(cell, device, tcp, other_joints)
    kept = None if clearance is None else parse_length_option(clearance, "--clearance")
    tolerance = parse_length_option(collision_tolerance, "--collision-tolerance")
    if kept is not None and kept < 0:
        raise click.BadParameter("must not be negative", param_hint="--clearance")
    if tolerance <= 0:
        raise click.BadParameter("must be above 0", param_hint="--collision-tolerance")
    planned = with_progress(
        progress and not json_output,
        lambda bar: plan_free_path(
            ctx,
            to,
            start,
            seed=seed,
            timeout=timeout,
            clearance=kept,
            tolerance=tolerance,
            output=output,
            progress=bar,
            offset=parse_vector(offset, "--offset", 3) if offset else None,
            blend=blend,
        ),
        "searching",
    )
    if json_output:
        emit_json(planned.as_dict())
        return
    p = planned.plan
    click.echo(
        f"{planned.device}: a free path to '{to}'"
        + (f" moved by [{offset}] m" if offset else "")
        + f" through {len(p.waypoints)} waypoints, "
        f"{p.length:.4g} of joint travel ({p.raw_length:.4g} before shortcuts), found in "
        f"{p.seconds:.3f} s ({p.iterations} rounds, {p.states_checked} states, "
        f"{p.segments_checked} segments checked)"
    )
    click.echo(f"  keeps {planned.kept_words()}")
    corners = len(p.waypoints) - 2
    if corners > 0:
        click.echo(
            f"  corners blended: {int((p.blends > 0).sum())} of {corners}"
            + ("" if blend else " (--no-blend)")
        )
    for k, q in enumerate(p.waypoints):
        blended = f"  blend {p.blends[k]:g}" if p.blends[k] > 0 else ""
        click.echo(f"  {k}: [" + ", ".join(f"{v:.6g}" for v in q) + "]" + blended)
    for words in p.inside_margin:
        click.echo(
            f"note: {words}: that pair was searched without the margin and keeps "
            f"{p.tight_kept * 1000:.3g} mm",
            err=True,
        )
    if planned.written:
        click.echo(f"wrote {planned.written}", err=True)
