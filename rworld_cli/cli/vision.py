"""rworld calibrate-camera, plan-views, captures"""

from __future__ import annotations

import click

from .common import (
    FiniteFloat,
    device_option,
    emit_json,
    handle_errors,
    json_option,
    log_format_option,
    output_option,
    with_progress,
)


@click.command("calibrate-camera")
@click.argument("captures", metavar="CAPTURES")
@click.option(
    "--write-poses",
    metavar="FILE",
    type=click.Path(dir_okay=False),
    help="The pose file to write: the camera in its mount, the board in its holder (mm, deg).",
)
@click.option(
    "--write-camera",
    metavar="FILE",
    type=click.Path(dir_okay=False),
    help="The camera's intrinsics to write, with their sigmas (px).",
)
@click.option(
    "--save-corners",
    metavar="FILE",
    type=click.Path(dir_okay=False),
    help="The corners found, as CSV (view,corner,u,v): name it as the capture file's "
    "'corners:' to calibrate again without detecting.",
)
@click.option(
    "--holdout-every",
    default=0,
    type=click.IntRange(min=0),
    metavar="K",
    help="Hold every K-th view with the board found out of the fit and predict its corners "
    "through the robot (0: fit every view).",
)
@click.option(
    "--fix-intrinsics",
    is_flag=True,
    help="Keep the capture file's intrinsics; fit the camera's and the board's poses only.",
)
@click.option(
    "--flange-errors/--exact-robot",
    default=None,
    help="The model of the robot's poses. --flange-errors: each view's flange pose has an "
    "error of its own, estimated with its sigma and its correlation over the poses (a robot's "
    "errors are alike at near poses): intrinsics from each view's own picture of the board, "
    "the robot's pose error reported, held-out views predicted where the robot is expected "
    "to be. --exact-robot: the robot's poses exact, the parameters fitted through them. "
    "Default: chosen by the data - the exact robot, unless its corners come out more than 3x "
    "as far off as in each view's own picture (the robot's pose errors then set the fit).",
)
@click.option(
    "--through-robot",
    is_flag=True,
    help="Each view's flange pose from its joint values through the capture file's robot "
    "(its cell's pose files: a robot calibration included), not the file's flange poses.",
)
@click.option(
    "--write-robot-observations",
    metavar="FILE",
    type=click.Path(dir_okay=False),
    help="A robot observation file for 'rworld calibrate-robot': the camera and board as a "
    "6-DoF instrument (each view's PnP pose, its joint values).",
)
@click.option(
    "--with-robot",
    is_flag=True,
    help="Estimate the robot's own kinematic errors (its joint frames) with the camera in one "
    "bundle adjustment: each view's flange from its joint values through the capture file's "
    "robot, corrected by the estimate.",
)
@click.option(
    "--write-robot",
    metavar="FILE",
    type=click.Path(dir_okay=False),
    help="With --with-robot: the robot's corrections as a pose file for its cell (list it "
    "last in the cell's pose_files, as calibrate-robot's).",
)
@json_option
@handle_errors
def calibrate_camera(
    captures,
    write_poses,
    write_camera,
    save_corners,
    holdout_every,
    fix_intrinsics,
    flange_errors,
    through_robot,
    write_robot_observations,
    with_robot,
    write_robot,
    json_output,
):
    """Calibrate a camera from views of a chessboard or ChArUco board and the robot's pose at
    each: its intrinsics (OpenCV's model, k1 k2 p1 p2 k3), its pose on the flange
    (eye-in-hand) or in the robot's base (eye-to-hand), and the board's pose, in one bundle
    adjustment of every corner's reprojection error through the robot.

    The corners are found by OpenCV (findChessboardCornersSB, or the ChArUco detector); an
    image whose board is not found, partly seen or blurred is named and left out. OpenCV's
    closed forms give the start; Huber's loss keeps a bad corner from pulling the fit; the
    sigmas allow the errors of one view to be shared (a robot pose's error moves all of its
    corners). The robot's poses are taken as exact, or each given an error of its own where
    the data says they set the fit (--flange-errors/--exact-robot). A robot that only
    translates, or turns about one axis, is refused: the hand-eye is then unobservable.
    Nothing is written unless the calibration succeeds; programs are never touched
    (docs/vision.md).

    \b
    Examples:
      rworld calibrate-camera captures.yaml
      rworld calibrate-camera captures.yaml --holdout-every 4 --json
      rworld calibrate-camera captures.yaml --exact-robot
      rworld calibrate-camera captures.yaml --write-poses camera_poses.yaml \\
          --write-camera camera.yaml --save-corners corners.csv
      # the robot's own errors: the views as 6-DoF observations, calibrate-robot, again
      rworld calibrate-camera captures.yaml --write-robot-observations robot_obs.yaml
      rworld calibrate-robot cell robot_obs.yaml -o cell/robot_calibrated.yaml
      rworld calibrate-camera captures.yaml --through-robot --write-poses camera_poses.yaml
      # or in one estimate: camera, hand-eye, board and the robot's joint frames together
      rworld calibrate-camera captures.yaml --with-robot --holdout-every 4 \\
          --write-poses camera_poses.yaml --write-robot cell/robot_calibrated.yaml

    Exit codes: 0 calibrated (and written), 2 bad input, images of another size than the
    camera's, too few views, a degenerate motion.
    """
    from ..api import calibrate_camera as run

    result = with_progress(
        not json_output,
        lambda progress: run(
            captures,
            holdout_every=holdout_every,
            fix_intrinsics=fix_intrinsics,
            flange_errors=flange_errors,
            write_poses=write_poses,
            write_camera=write_camera,
            save_corners=save_corners,
            progress=progress,
            through_robot=through_robot,
            write_robot_observations=write_robot_observations,
            with_robot=with_robot,
            write_robot=write_robot,
        ),
        "finding corners",
    )
    if json_output:
        emit_json(result.as_dict())
        return
    _render(result)


def _render(run) -> None:
    import numpy as np

    r = run.result
    cam = r.camera
    s = r.sigma
    used = sum(d.refused is None for d in run.detections)
    click.echo(
        f"{run.captures}: {run.setup}, {len(run.detections)} views, board found in {used}; "
        f"{len(run.fitted)} fitted, {len(run.held_out)} held out "
        f"({run.seconds.get('corners', 0):.1f} s corners, "
        f"{run.seconds.get('calibration', 0):.1f} s calibration)"
    )
    for d in run.detections:
        if d.refused:
            click.echo(f"  {d.name}: not used: {d.refused} ({d.detail})")
    if run.turned:
        click.echo(
            f"  {len(run.turned)} views' corners renumbered to agree with the robot's motion "
            "(the chessboard counted from another corner): "
            + ", ".join(f"{name} {angle:.0f} deg" for name, angle in run.turned.items())
        )
    click.echo(f"camera {cam.name} ({cam.width}x{cam.height} px):")
    for k, name in enumerate(("fx", "fy", "cx", "cy")):
        click.echo(f"  {name} {cam.intrinsics[k]:10.3f} +- {s[k]:.3f} px")
    click.echo(
        "  distortion k1 k2 p1 p2 k3: "
        + "  ".join(f"{v:+.5f}+-{e:.5f}" for v, e in zip(cam.distortion, s[4:9], strict=True))
    )

    figures = run.as_dict()

    def pose(label: str, p: dict) -> None:
        click.echo(f"{label} in {p['parent']}:")
        xyz = zip(p["xyz_mm"], p["sigma_mm"], strict=True)
        rpy = zip(p["rpy_deg"], p["sigma_deg"], strict=True)
        click.echo("  xyz mm  " + "  ".join(f"{v:10.3f} +- {e:.3f}" for v, e in xyz))
        click.echo("  rpy deg " + "  ".join(f"{v:10.4f} +- {e:.4f}" for v, e in rpy))

    pose(run.camera_frame, figures["camera_pose"])
    pose(run.board_frame, figures["board_pose"])
    click.echo(
        f"reprojection through the robot: rms {r.rms:.3f} px over {r.observations} corners "
        f"({r.downweighted} coordinates past Huber's 3 sigma)"
    )
    if run.pictures_rms is not None:
        click.echo(
            f"each view's own picture of the board (its own pose, no robot in it): rms "
            f"{run.pictures_rms:.3f} px"
        )
    with_robot = (
        "; the capture file names the robot and each view's joints: --with-robot estimates "
        "the robot's own joint-frame errors with the camera"
        if run.robot_named
        else ""
    )
    if run.exact_robot_ratio is not None:
        if r.flange_sigma is not None:
            click.echo(
                f"model: the robot's pose errors (chosen: through its poses as given the corners "
                f"came out {run.exact_robot_ratio:.0f}x as far off as in each view's own picture; "
                "--exact-robot keeps them exact)" + with_robot
            )
        else:
            click.echo(
                f"model: the robot's poses exact (chosen: the corners through them "
                f"{run.exact_robot_ratio:.2f}x as far off as in each view's own picture)"
            )
    if run.robot_errors_dominate:
        click.echo(
            f"  the corners through the robot are {r.rms / run.pictures_rms:.0f}x as far off: "
            "the robot's pose errors set this fit, not the pictures - --flange-errors models "
            "them (docs/vision.md, 'Two models of the robot')" + with_robot
        )
    if r.flange_sigma is not None:
        click.echo(
            f"the robot's flange pose error a view (estimated): {np.degrees(r.flange_sigma[0]):.4f}"
            f" deg, {r.flange_sigma[1] * 1000:.3f} mm per axis; the corners' noise "
            f"{r.sigma0:.3f} px"
        )
        f = r.flange_field
        if f is not None:
            click.echo(
                f"  its correlation with the nearest view's: {f.neighbour_correlation:.2f} "
                f"({f.share:.2f} falling off over {f.length * 1000:.0f} mm, a turn of 1 deg "
                f"as {f.lever * np.radians(1) * 1000:.0f} mm)"
            )
    if r.robot is not None:
        robot = figures["robot"]
        click.echo(
            f"the robot's joint frames: {robot['identified']} of {robot['parameters']} "
            f"parameters identified (the others nominal); the pictures' noise "
            f"{robot['pixel_noise_px']:.3f} px, a-posteriori factor {robot['variance_factor']:.2f}"
        )
        if not robot["converged"]:
            click.echo(
                f"  warning: the fit did not converge in {robot['iterations']} iterations", err=True
            )
        for row in robot["corrections"]:
            click.echo(
                f"  {row['name']:<28} {row['correction']:+10.4f} +- {row['sigma']:.4f} "
                f"{row['unit']}"
            )
    if run.held_out_rms is not None:
        where = (
            " (each where the robot is expected: its error predicted from the fitted views')"
            if r.flange_field is not None and r.flange_field.share > 0
            else ""
        )
        click.echo(f"held out ({len(run.held_out)} views): rms {run.held_out_rms:.3f} px{where}")
    if run.axxb is not None:
        click.echo(
            f"AX = XB over the {run.axxb_views} views' pairs: rms "
            f"{np.degrees(run.axxb[0]):.4f} deg, {run.axxb[1] * 1000:.3f} mm"
        )
    for path in run.written:
        click.echo(f"wrote {path}")


@click.command("plan-views")
@click.argument("cell", metavar="CELL")
@click.option("--camera", required=True, metavar="SENSOR", help="The camera sensor (on a robot).")
@click.option(
    "--views",
    "count",
    default=15,
    show_default=True,
    type=click.IntRange(min=3),
    help="How many views to choose.",
)
@click.option(
    "--board",
    default=None,
    metavar="OBJECT",
    help="The calibration board (default: the cell's one).",
)
@click.option(
    "--candidates",
    default=1000,
    show_default=True,
    type=click.IntRange(min=3),
    help="Camera poses around the board to choose from.",
)
@click.option(
    "--refine",
    default=None,
    type=click.IntRange(min=0),
    metavar="N",
    help="Candidates drawn around the first choice (a few degrees and centimetres from each "
    "chosen view, within the same bounds; in two rounds, the second around the choice the "
    "first led to), the choice made again from all [default: two thirds of --candidates; 0: "
    "none].",
)
@click.option(
    "--with-robot",
    is_flag=True,
    help="Views for calibrate-camera --with-robot: the robot's joint-frame errors counted as "
    "parameters too, the views chosen for the camera-to-board pose at the robot's poses.",
)
@click.option("--seed", default=0, show_default=True, type=int, help="The candidates' random seed.")
@click.option(
    "--pixel-sigma",
    default=0.1,
    show_default=True,
    type=FiniteFloat(),
    metavar="PX",
    help="The corners' noise the prediction assumes [px].",
)
@click.option(
    "--captures",
    default=None,
    type=click.Path(dir_okay=False),
    metavar="FILE",
    help="Write a capture file of the views, to fill with images.",
)
@click.option(
    "--program",
    default=None,
    type=click.Path(dir_okay=False),
    metavar="FILE",
    help="Write a program that visits each view from home and takes an image there (capture: "
    "steps, exported as the camera's trigger and a logged pose).",
)
@json_option
@handle_errors
def plan_views(
    cell,
    camera,
    count,
    board,
    candidates,
    refine,
    with_robot,
    seed,
    pixel_sigma,
    captures,
    program,
    json_output,
):
    """Choose robot poses from which a camera sees the whole calibration board, and which
    together determine the camera's calibration best: the camera on the robot (eye-in-hand),
    or fixed in the cell with the board on the robot (eye-to-hand).

    Candidates are camera poses around the board (from its printed side, within 40 deg of its
    normal, at distances where it spans 35-80 % of the image's width); a candidate is usable
    when the robot reaches it, touches nothing there or on the way from home, and the camera
    sees every corner and the outer squares. Of those, the views are chosen D-optimally on the
    information of the calibration's 21 parameters, then exchanged to lower the camera's
    predicted pose error most; more candidates are drawn around that choice (--refine) and the
    choice is made again from all. Its predicted error is shown beside random choices of as
    many of the first candidates (docs/vision.md). With --with-robot the robot's joint-frame
    errors the candidates determine are parameters too, and the error is the camera-to-board
    pose's at the robot's poses (what calibrate-camera --with-robot predicts through).

    \b
    Examples:
      rworld plan-views tests/data/vision/cell --camera wrist_camera --views 12
      rworld plan-views CELL --camera wrist_camera --captures captures.yaml --program views.yaml
      rworld plan-views CELL --camera wrist_camera --views 40 --with-robot --captures c.yaml

    Exit codes: 0 planned (and written), 2 bad input or too few usable candidates.
    """
    import numpy as np

    from ..api import plan_views as run

    if not pixel_sigma > 0:
        raise click.BadParameter("must be above 0", param_hint="--pixel-sigma")
    result = with_progress(
        not json_output,
        lambda progress: run(
            cell,
            camera,
            count,
            board,
            candidates,
            seed,
            sigma_px=pixel_sigma,
            captures=captures,
            program=program,
            progress=progress,
            refine=refine,
            with_robot=with_robot,
        ),
        "reaching the candidates",
    )
    if json_output:
        emit_json(result.as_dict())
        return
    f = result.figures
    click.echo(
        f"{result.camera} on {result.device} ({result.mount}), board {result.board}: "
        f"{result.usable} of {result.candidates} candidate views usable; {len(result.joints)} "
        f"chosen ({result.seconds:.1f} s)"
    )
    for why, n in result.lost.items():
        if n:
            click.echo(f"  {n} candidates lost: {why}")
    if f.get("refine"):
        click.echo(
            f"  {f['refine']} more drawn around the choice in {f['refine_rounds']} rounds: "
            f"{f['refined']} usable, the choice made again from all"
        )
    if f["with_robot"]:
        click.echo(
            f"  with the robot's errors: {len(f['robot_parameters'])} of its joint-frame "
            "parameters determined beside the camera's; the views chosen for the camera alone "
            f"from the same candidates: {f['camera_choice_error'] * 1000:.4f} mm"
        )
    what = (
        "the camera-to-board pose at the robot's poses"
        if f["with_robot"]
        else f"the camera in its mount ({result.mount})"
    )
    click.echo(
        f"predicted error of {what} ({result.sigma_px:g} px of corner noise, at a point "
        f"{f['lever'] * 1000:.0f} mm ahead): {f['error'] * 1000:.4f} mm; random "
        f"choices of as many: {f['random_error'] * 1000:.4f} mm "
        f"({f['random_error'] / f['error']:.2f}x)"
    )
    click.echo(
        f"  the camera in its mount: position {f['position'] * 1000:.4f} mm, rotation "
        f"{np.degrees(f['rotation']):.5f} "
        f"deg (random: {f['random_position'] * 1000:.4f} mm, "
        f"{np.degrees(f['random_rotation']):.5f} deg)"
    )
    for path in result.written:
        click.echo(f"wrote {path}")


@click.command("captures")
@click.argument("cell", metavar="CELL")
@click.option(
    "--from-log",
    "log",
    required=True,
    type=click.Path(dir_okay=False),
    metavar="LOG",
    help="The controller's record of the run: its log, the file the program wrote, the .dat, "
    "POSREG.VA or VAR.DAT.",
)
@click.option("--run", required=True, metavar="RUN|PROGRAM", help="The run (or program) exported.")
@click.option(
    "--images",
    "images",
    required=True,
    multiple=True,
    metavar="GLOB|FILE",
    help="The images, in the order they were taken: files, or a quoted pattern ('shots/*.png', "
    "sorted by name); repeat for more.",
)
@log_format_option("The log's language (default: the device's controller.vendor's).")
@device_option("The robot that took the images (default: the one whose program captures).")
@click.option(
    "--frame",
    "user_frame",
    default=None,
    metavar="FRAME",
    help="The user frame the program was exported with (export program --frame).",
)
@click.option(
    "--camera", default=None, metavar="SENSOR", help="The camera, when several take images."
)
@click.option(
    "--board", default=None, metavar="OBJECT", help="The board, when the cell has several."
)
@click.option(
    "--capture-register",
    default=151,
    show_default=True,
    type=click.IntRange(1, 9999),
    help="--format fanuc: the position register, inform: the position variable of capture 1.",
)
@click.option(
    "--tolerance",
    default="5mm",
    show_default=True,
    help="How far a logged pose may lie from where the program took the image (and 1 deg).",
)
@output_option("The capture file to write (YAML), for calibrate-camera.", required=True)
@json_option
@handle_errors
def captures(
    cell,
    log,
    run,
    images,
    fmt,
    device,
    user_frame,
    camera,
    board,
    capture_register,
    tolerance,
    output,
    json_output,
):
    """A capture file from a robot's run of an exported program with capture: steps: the
    images its camera took and the flange pose its controller logged at each, for
    'rworld calibrate-camera'.

    'rworld export program' writes each capture: step as: stand still (settle), set the
    camera's trigger output, log the TCP pose (URScript textmsg, RAPID's file, KRL's .dat,
    FANUC's position registers, INFORM's position variables, DRL tp_log, VAL3 logMsg, Sunrise's
    logger), hold the trigger for the exposure, reset it (docs/export.md). This command
    matches the log's reports with the run's captures (count, step, camera, TCP, frame), maps
    each pose through the controller's base or user frame (and the robot's calibration, where
    the cell has one) to the flange, checks it lies where the program took the image, and
    writes the capture file with the images in the order taken. Give the cell with the pose
    files the program was exported with.

    \b
    Examples:
      rworld captures workcells/cam --from-log robot.log --run programs/views.yaml \\
          --images 'shots/*.png' -o captures.yaml
      rworld captures workcells/cam --from-log VIEWS.dat --run programs/views.yaml \\
          --format krl --images shots/a.png --images shots/b.png -o captures.yaml --json

    Exit codes: 0 written, 2 bad input (a malformed log, reports that are not the program's,
    a pose far from its capture's, a missing image, not one image a capture).
    """
    import glob

    from ..api import captures_from_log
    from ..errors import UserError
    from ..units import parse_length

    files: list[str] = []
    for given in images:
        if any(ch in given for ch in "*?["):
            found = sorted(glob.glob(given))
            if not found:
                raise UserError(f"--images {given}: no file matches")
            files += found
        else:
            files.append(given)
    try:
        length = parse_length(tolerance, "--tolerance", "mm")
    except ValueError as exc:
        raise UserError(str(exc)) from None
    result = captures_from_log(
        cell,
        run,
        log,
        files,
        output,
        fmt,
        device,
        user_frame,
        camera,
        board,
        capture_register,
        length,
    )
    if json_output:
        emit_json(result)
        return
    from rich.console import Console
    from rich.table import Table

    console = Console()
    table = Table(title=f"{result['camera']} on {result['device']} ({result['setup']})")
    for column in ("capture", "image", "log", "flange xyz [mm]", "off [mm]", "off [deg]"):
        table.add_column(column)
    for v in result["views"]:
        table.add_row(
            str(v["capture"]),
            v["image"],
            v["log"],
            ", ".join(f"{x:.2f}" for x in v["flange_xyz_mm"]),
            f"{v['from_simulated_mm']:.3f}",
            f"{v['from_simulated_deg']:.3f}",
        )
    console.print(table)
    for note in result["notes"]:
        console.print(f"note: {note}")
    console.print(f"wrote {result['written']}: 'rworld calibrate-camera {result['written']}'")
