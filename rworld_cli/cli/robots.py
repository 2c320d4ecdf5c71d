"""rworld import urdf, rworld export urdf, rworld export program"""

from __future__ import annotations

import click

from .common import (
    device_option,
    emit_json,
    handle_errors,
    json_option,
    output_option,
    shown_issues,
)


@click.group("import")
def import_group():
    """Bring robots in from other formats (urdf) and their factory calibrations
    (ur-calibration)."""


@import_group.command("urdf")
@click.argument("urdf", metavar="FILE.urdf")
@click.option("-o", "--output", required=True, metavar="DIR", help="The cell folder to create.")
@click.option(
    "--package-path",
    "package_paths",
    multiple=True,
    metavar="DIR",
    help="A folder holding ROS packages, for package:// mesh names; repeatable.",
)
@click.option(
    "--base", default=None, metavar="LINK", help="First link of the chain (default: the root)."
)
@click.option(
    "--tip",
    default=None,
    metavar="LINK",
    help="Last link of the chain (default: where the moving joints end; needed when they branch).",
)
@click.option(
    "--tcp",
    default=None,
    metavar="LINK",
    help="The link whose frame is the TCP (default: a tool frame by its name - tcp, tool0, "
    "tool_frame, end_effector_link, flange, ... - on the last link, else the tip).",
)
@click.option(
    "--name",
    "device_name",
    default=None,
    metavar="NAME",
    help="Device name (default: the robot's).",
)
@click.option(
    "--lock",
    "locks",
    multiple=True,
    metavar="JOINT=VALUE",
    help="Lock a moving joint off the chain (a gripper's finger) at VALUE with its unit, e.g. "
    "panda_finger_joint1=20mm (default 0); repeatable.",
)
@click.option(
    "--srdf",
    default=None,
    type=click.Path(dir_okay=False),
    help="A MoveIt SRDF: its disabled collision pairs become the cell's allowed_contacts.",
)
@click.option(
    "--overlap-states",
    default=8,
    show_default=True,
    type=click.IntRange(min=0),
    metavar="N",
    help="Link pairs that overlap at the home and N-1 seeded joint states become "
    "allowed_contacts, each with a warning; 0 skips the check.",
)
@click.option(
    "--xacro-arg",
    "xacro_args",
    multiple=True,
    metavar="NAME:=VALUE",
    help="A xacro file's argument ($(arg NAME)); repeatable.",
)
@click.option(
    "--joint-limits",
    default=None,
    type=click.Path(dir_okay=False),
    help="The vendor's ROS joint_limits.yaml: its velocity, acceleration and effort limits.",
)
@click.option("--force", is_flag=True, help="Overwrite cell.yaml, poses.yaml and meshes in DIR.")
@json_option
@handle_errors
def import_urdf(
    urdf,
    output,
    package_paths,
    base,
    tip,
    tcp,
    device_name,
    locks,
    srdf,
    overlap_states,
    xacro_args,
    joint_limits,
    force,
    json_output,
):
    """Write a cell for the serial chain of a URDF robot: cell.yaml, poses.yaml, meshes/.

    Joints become joint frames (origin, axis) with their position, velocity and effort limits
    and damping; links fixed to a moving link (by fixed joints, or in branches off the chain)
    are merged into it - masses combined, shapes joined into one mesh (collision geometry
    preferred over visual) - and kept as frames.  Moving joints off the chain are locked at 0
    (or at their --lock value), with a warning.  Mimic joints on the chain, floating and
    planar joints are refused.  A .xacro file is expanded first, as data (rworld's own
    expander: no code in it runs), its $(find PKG) found under --package-path and its $(arg
    NAME) from --xacro-arg: no ROS needed.  --joint-limits takes the vendor's
    joint_limits.yaml (acceleration limits, which URDF lacks).  Link pairs whose meshes
    overlap at every joint state sampled (--overlap-states) are written to allowed_contacts
    with a warning, as MoveIt disables its 'Always' pairs; --srdf takes a MoveIt SRDF's
    disabled pairs.
    Nothing is written unless the whole import succeeds.

    \b
    Examples:
      rworld import urdf ur5_robot.urdf -o workcells/ur5_urdf --package-path /opt/ros/share
      rworld import urdf panda.urdf -o workcells/panda --tip panda_hand --package-path share \
          --lock panda_finger_joint1=20mm --lock panda_finger_joint2=20mm
      rworld import urdf robot.urdf -o cells/r --base base_link --tip tool0 --json
      rworld import urdf motoman_gp7_support/urdf/gp7.xacro --package-path src/motoman \
          --joint-limits gp7_moveit_config/config/joint_limits.yaml -o cells/gp7
    """
    from ..api import import_urdf as run

    locked = _assignments(locks, "=", "JOINT=VALUE, e.g. finger=20mm", "--lock")
    lock_values = {name: value.strip() for name, value in locked.items()}
    arguments = _assignments(xacro_args, ":=", "NAME:=VALUE, e.g. prefix:=left_", "--xacro-arg")
    result = run(
        urdf,
        output,
        list(package_paths),
        base,
        tip,
        tcp,
        device_name,
        force,
        lock_values,
        srdf,
        overlap_states,
        arguments,
        joint_limits,
    )
    if json_output:
        emit_json(result.as_dict())
        return
    for w in shown_issues(result.warnings):
        click.echo(w.format(), err=True)
    click.echo(
        f"imported {result.device} ({result.dof} joints, {result.base} -> {result.tip}, TCP at "
        f"{result.tcp}) into {result.cell}: {', '.join(result.files)}"
    )
    for owner, links in result.merged.items():
        if len(links) > 1:
            click.echo(f"  {owner}: merged {', '.join(links[1:])}")
    if result.renamed:  # names rworld cannot hold, or reserves ('world': the cell's frame)
        click.echo(
            "  renamed (names hold letters, digits, '_' and '-'; 'world' is the cell's own):"
        )
        for a, b in result.renamed.items():
            click.echo(f"    {a} -> {b}: {result.renamed_where.get(a, '')}")


def _assignments(texts, sep: str, form: str, option: str) -> dict[str, str]:
    """``NAME<sep>VALUE`` option values as {name: value}; a malformed one is a usage error."""
    out = {}
    for text in texts:
        name, found, value = text.partition(sep)
        if not found or not name.strip():
            raise click.BadParameter(f"'{text}': write {form}", param_hint=option)
        out[name.strip()] = value
    return out


@import_group.command("ur-calibration")
@click.argument("calibration", metavar="FILE.yaml")
@click.option("--cell", "cell", required=True, metavar="CELL", help="The cell with the UR.")
@device_option("The UR (default: the cell's arm).")
@output_option("The overlay pose file to write (default: ur_calibration.yaml beside cell.yaml).")
@json_option
@handle_errors
def import_ur_calibration(calibration, cell, device, output, json_output):
    """Write a UR robot's factory calibration (the kinematics: file ur_calibration reads from
    its controller) as a pose-file overlay of the cell's joint frames.

    The cell's UR must be imported from ur_description (rworld import urdf): each calibration
    group is its joint's origin there; what the import merged before the shoulder (base_link
    turned by pi) is kept.  Listed last in the cell's pose_files, the overlay puts the robot's
    own kinematics under every command.

    \b
    Examples:
      rworld import ur-calibration robot_calibration.yaml --cell ur5e -o ur5e/cal.yaml

    Exit codes: 0 written, 2 bad input (a malformed file, a cell not from ur_description).
    """
    from ..api import import_ur_calibration as run

    result = run(calibration, cell, output, device)
    if json_output:
        emit_json(result)
        return
    click.echo(
        f"wrote {result['written']}: the factory calibration of {result['device']}"
        + (f" ({result['hash']})" if result["hash"] else "")
    )
    for r in result["joints"]:
        click.echo(f"  {r['joint']:<22} {r['moved_mm']:8.3f} mm {r['turned_deg']:8.4f} deg")
    click.echo(f"note: list {result['written']} last in the cell's pose_files to use it", err=True)


@click.group("export")
def export_group():
    """Write a cell's content in other formats: robot programs (program), URDF (urdf)."""


@export_group.command("program")
@click.argument("cell", metavar="CELL")
@click.argument("run", metavar="RUN|PROGRAM")
@click.option(
    "--format",
    "fmt",
    default=None,
    type=click.Choice(
        ["urscript", "krl", "rapid", "fanuc", "inform", "val3", "drl", "sunrise", "csv"]
    ),
    help="Robot language (fanuc: TP as .ls; inform: a Yaskawa .JBI job; val3: a Staubli "
    "application folder; drl: Doosan; sunrise: a KUKA LBR's Java class), or csv for a timed "
    "joint trajectory; default the language of the device's controller.vendor.",
)
@click.option("-o", "--output", required=True, metavar="DIR", help="The folder to write.")
@device_option("Only this device's program.")
@click.option(
    "--period", default=None, metavar="DT", help="csv: the controller period, e.g. 8ms (default)."
)
@click.option(
    "--against",
    multiple=True,
    metavar="POSES",
    help="Nominal pose file(s): list the targets the current poses move; repeatable.",
)
@click.option(
    "--frame",
    "user_frame",
    default=None,
    metavar="FRAME",
    help="Give Cartesian targets in this cell frame (a user frame / work object); default the "
    "robot's base.",
)
@click.option(
    "--compensate",
    is_flag=True,
    help="For a controller that keeps the nominal kinematics while the cell holds the robot's "
    "calibration (calibrate-robot): Cartesian targets are the nominal kinematics at the "
    "calibrated joint targets, so the robot reaches the true poses; with joint compliance "
    "(calibrate-robot --model compliance) the joint targets are the commands the yielding arm "
    "needs (csv too); lists how far each moved.",
)
@click.option(
    "--gripper-output", default=1, show_default=True, help="Digital output of the gripper."
)
@click.option(
    "--tool-changer-output",
    default=2,
    show_default=True,
    help="Digital output of the tool changer.",
)
@click.option(
    "--sensor-input",
    default=1,
    show_default=True,
    help="Digital input that stops a guarded move's search (the until: sensor).",
)
@click.option(
    "--contact-register",
    default=101,
    show_default=True,
    type=click.IntRange(1, 9999),
    help="fanuc: the position register, inform: the position variable of a probe program's "
    "first contact (one per contact).",
)
@click.option(
    "--camera-output",
    default=3,
    show_default=True,
    help="Digital output of the camera's trigger (capture: steps).",
)
@click.option(
    "--capture-register",
    default=151,
    show_default=True,
    type=click.IntRange(1, 9999),
    help="fanuc: the position register, inform: the position variable of the pose at a "
    "program's first capture (one per image).",
)
@json_option
@handle_errors
def export_program(
    cell,
    run,
    fmt,
    output,
    device,
    period,
    against,
    user_frame,
    compensate,
    gripper_output,
    tool_changer_output,
    sensor_input,
    contact_register,
    camera_output,
    capture_register,
    json_output,
):
    """Write the programs of RUN (or one PROGRAM file) on CELL in a robot language.

    Targets are resolved as the simulator resolves them, with the cell's current pose files (a
    calibrated overlay included): joint moves go to the joint solution the simulation chose,
    linear moves to the TCP pose in the robot's base frame (or --frame), with the TCP as tool
    data and the
    speeds and accelerations of the simulated motion.  A guarded move (until:) becomes a search
    to its planned end that stops on --sensor-input.  Grasp / release / place and tool changes
    drive digital outputs; a probe: reports its contact in a line 'rworld measure --from-log'
    reads back; a capture: stands still, triggers --camera-output and reports the pose, which
    'rworld captures --from-log' reads back with the images; syncs and waits for other devices
    become comments.  The files appear together or not at all.  An unreachable target exits 1
    with the program's file:line.

    \b
    Examples:
      rworld export program workcells/puma560 pick_place --format urscript -o out/ur
      rworld export program workcells/paper_fig9 transfer --device robot --format krl -o out/krl
      rworld export program workcells/puma560 pick_place --format rapid -o out/abb \\
          --against workcells/puma560/poses.yaml
      rworld export program workcells/puma560 pick_place --format csv --period 8ms -o out/csv
      rworld export program workcells/puma560 pick_place --format fanuc -o out/fanuc
    """
    from ..api import Signals
    from ..api import export_program as run_export

    result = run_export(
        cell,
        run,
        fmt,
        output,
        device,
        period,
        list(against) if against else None,
        Signals(
            gripper_output,
            tool_changer_output,
            sensor_input,
            contact_register,
            camera_output,
            capture_register,
        ),
        user_frame,
        compensate,
    )
    if json_output:
        emit_json(result.as_dict())
        return
    count = (
        f"{result.samples} samples every {result.period * 1000:g} ms"
        if result.samples is not None
        else f"{result.moves} moves"
    )
    click.echo(
        f"wrote {result.output}: {', '.join(result.files)} ({', '.join(result.devices)}, {count})"
    )
    if result.changes is not None:
        if not result.changes:
            click.echo("no target moved against the nominal poses")
        for c in result.changes:
            click.echo(
                f"  {c.where}: {c.step}: moved {c.translation * 1000:.3f} mm, "
                f"{c.rotation / 4.84813681109536e-06:.1f} arcsec by {c.cause}"
            )
    if result.compensated is not None:
        click.echo("compensated for the nominal controller (target moved by):")
        for c in result.compensated:
            click.echo(
                f"  {c['where']}: {c['step']}: {c['moved_mm']:.3f} mm, {c['turned_deg']:.4f} deg"
                f", joints up to {c['joints_deg']:.4f} deg"
            )
    for note in result.notes:
        click.echo(f"note: {note}", err=True)


@export_group.command("urdf")
@click.argument("cell", metavar="CELL")
@click.option("-o", "--output", required=True, metavar="FILE.urdf", help="The URDF file to write.")
@device_option("The device (needed when the cell has several).")
@json_option
@handle_errors
def export_urdf(cell, output, device, json_output):
    """Write a device of CELL as URDF, with the cell's current pose files applied.

    A calibrated overlay listed in the cell's pose_files moves the TCP and the frames on the
    links; each such frame becomes a massless link on a fixed joint.  DH devices become joint
    frames.  Meshes are referenced relative to the URDF's folder.  What URDF cannot hold
    (acceleration limits, motor inertia, asymmetric Coulomb friction) is listed in a comment.

    \b
    Examples:
      rworld export urdf workcells/puma560 -o puma.urdf
      rworld export urdf workcells/panda --device panda -o out/panda.urdf --json
    """
    from ..api import export_urdf as run

    result = run(cell, output, device)
    if json_output:
        emit_json(result.as_dict())
        return
    click.echo(
        f"wrote {result.path}: device {result.device}, {len(result.links)} links, "
        f"{len(result.joints)} joints"
    )
    note, _, carried = result.note.partition(" Carried in the cell's state")
    if "Not in URDF" in note:
        click.echo("  not in URDF:")
        for item in note.split("Not in URDF: ", 1)[1].rstrip(".").split("; "):
            click.echo(f"    {item}")
    if carried:
        click.echo(f"  carried in the cell's state{carried.rstrip('.')}")
