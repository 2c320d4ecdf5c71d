"""rworld calibrate-robot, rworld plan-robot-calibration"""

from __future__ import annotations

import click

from .common import (
    FiniteFloat,
    device_option,
    emit_json,
    handle_errors,
    json_option,
    output_option,
    seed_option,
)


@click.command("calibrate-robot")
@click.argument("cell", metavar="CELL")
@click.argument("observations", nargs=-1, required=True, metavar="OBSERVATIONS...")
@device_option("The device (checked against the files).")
@output_option("The overlay pose file to write (default: robot_calibrated.yaml beside cell.yaml).")
@click.option("--dry-run", is_flag=True, help="Identify and report; write nothing.")
@click.option(
    "--validate",
    multiple=True,
    type=click.Path(dir_okay=False),
    metavar="FILE",
    help="Observations not used in the fit: their position errors before and after; repeatable.",
)
@click.option(
    "--folds",
    default=0,
    type=click.IntRange(min=0),
    metavar="K",
    help="k-fold cross-validation: each fold predicted by a fit on the others (0: none).",
)
@click.option(
    "--loss",
    default="linear",
    show_default=True,
    type=click.Choice(["linear", "huber", "soft_l1"]),
    help="A robust loss keeps a gross outlier from pulling the fit (scale: --loss-scale).",
)
@click.option(
    "--loss-scale",
    default=None,
    metavar="LEN",
    help="Where the robust loss starts (mm, um or m; a bare number is mm; default 3 sigma).",
)
@click.option(
    "--frame-only",
    is_flag=True,
    help="Fit the instrument frame (and the target's offset) alone, the robot nominal.",
)
@click.option(
    "--max-correction",
    default="50mm",
    show_default=True,
    metavar="LEN",
    help="A joint frame moved further from the cell's, or the target or the instrument frame "
    "further from their rigid fit with the robot nominal (fitted first: the cell's guesses "
    "may be rough): refused.",
)
@click.option(
    "--max-rotation",
    default="10deg",
    show_default=True,
    metavar="ANGLE",
    help="... or turned further: refused.",
)
@click.option(
    "--accept-misfit",
    is_flag=True,
    help="Write even when the residuals are over 100 times the stated sigma.",
)
@click.option(
    "--model",
    "error_model",
    default="geometric",
    show_default=True,
    type=click.Choice(["geometric", "compliance"]),
    help="compliance: each joint's yield under the torque holding the arm against gravity "
    "(the cell's link masses and what it carries) is fitted too.",
)
@click.option("--all", "show_all", is_flag=True, help="List every identified parameter.")
@json_option
@handle_errors
def calibrate_robot(
    cell,
    observations,
    device,
    output,
    dry_run,
    validate,
    folds,
    loss,
    loss_scale,
    frame_only,
    max_correction,
    max_rotation,
    accept_misfit,
    error_model,
    show_all,
    json_output,
):
    """Identify the robot's own kinematic errors from points an instrument measured on a frame
    it carries (laser tracker, CMM arm), and write them as a pose-file overlay.

    Every joint frame takes a small pose error (three lengths, two tilts of its axis, its
    zero), the measured frame its offset, an instrument frame other than the world its pose.
    An instrument frame is first registered in closed form with the robot nominal, so any
    starting pose gives the same robot.  Parameters are taken in a stated order (instrument
    frame, target, joints from the base) while the data determine each to better than its
    typical error (1 mm, 1 mrad); the others stay exactly nominal and are listed.  The rest is
    the maximum-likelihood estimate, with each parameter's sigma scaled by the a-posteriori
    factor when the residuals exceed the stated sigma.  --model compliance adds each joint's
    compliance under the torque that holds the arm against gravity (q_arm = q + c g(q)).
    Listed last in the cell's pose_files, the overlay moves every command to the calibrated
    robot (docs/calibration.md).

    \b
    Examples:
      rworld calibrate-robot workcells/ur5 measurements/ur5/tracker.yaml --dry-run
      rworld calibrate-robot workcells/ur5 tracker.yaml --validate check.yaml -o cal.yaml --json
      rworld calibrate-robot workcells/ur5 tracker.yaml --model compliance --validate check.yaml

    Exit codes: 0 identified (and written), 2 bad input or data that do not fit the robot.
    """
    from ..api import calibrate_robot as run
    from ..api import parse_angle, parse_length

    result = run(
        cell,
        list(observations),
        device,
        output,
        dry_run,
        list(validate) or None,
        folds,
        loss,
        parse_length(loss_scale) if loss_scale is not None else None,
        frame_only,
        parse_length(max_correction),
        parse_angle(max_rotation, "--max-rotation"),
        accept_misfit,
        error_model,
    )
    if json_output:
        emit_json(result.as_dict())
        return
    mm = lambda d: (
        f"rms {d['rms'] * 1000:.4f} mm, 95 % {d['p95'] * 1000:.4f}, max {d['max'] * 1000:.4f}"
    )  # noqa: E731,E501
    click.echo(
        f"{result.device}: {result.observations} points of {result.target} in {result.frame}, "
        f"sigma {result.sigma * 1000:g} mm; {result.identified} of {result.parameters} "
        f"parameters identified, observability index O1 {result.observability:.4g}"
    )
    click.echo(
        f"  fit: {result.iterations} iteration(s), "
        f"{'converged' if result.converged else 'NOT converged'}, loss {result.loss}, "
        f"model {result.model}; "
        f"a-posteriori sigma {result.sigma * result.variance_factor * 1000:.4g} mm "
        f"({result.variance_factor:.2f} x the stated)"
    )
    click.echo(f"  fit:        before {mm(result.before)}")
    click.echo(f"              after  {mm(result.after)}")
    if result.validation_before is not None:
        click.echo(f"  validation: before {mm(result.validation_before)}")
        click.echo(f"              after  {mm(result.validation_after)}")
        if result.predicted_parts is not None:
            own, kept = result.predicted_parts
            click.echo(
                f"              predicted error of the calibrated model: rms "
                f"{result.predicted_validation * 1000:.4f} mm (the estimate {own * 1000:.4f}, "
                f"the parameters kept nominal {kept * 1000:.4f}; besides the instrument's noise)"
            )
    if result.cross_validation is not None:
        cv = result.cross_validation
        click.echo(f"  {cv['folds']}-fold:     before {mm(cv['before'])}")
        click.echo(f"              after  {mm(cv['after'])}")
    rows = sorted(
        result.parameter_rows, key=lambda r: -abs(r["correction"]) / max(r["sigma"], 1e-12)
    )
    shown = rows if show_all else rows[:8]
    click.echo("  largest corrections (in sigmas):" if not show_all else "  parameters:")
    for r in shown:
        click.echo(f"    {r['name']:<28} {r['correction']:+.4f} {r['unit']} +- {r['sigma']:.4f}")
    if result.unidentifiable:
        click.echo(
            f"  kept nominal ({len(result.unidentifiable)} combinations the data cannot determine):"
        )
        for u in result.unidentifiable[:6]:
            click.echo(f"    {u}")
        if len(result.unidentifiable) > 6:
            click.echo(f"    ... {len(result.unidentifiable) - 6} more (--json lists them)")
    for note in result.notes:
        click.echo(f"note: {note}", err=True)
    for o in result.outliers:
        click.echo(
            f"warning: {o['where']}: residual {o['residual'] * 1000:.4f} mm, far above the rest "
            "(over 5 x the median): an outlier? --loss soft_l1 keeps it from pulling the fit",
            err=True,
        )
    for line in result.warnings:
        click.echo(f"warning: {line}", err=True)
    if result.written:
        click.echo(f"wrote {result.output}")
        if not result.listed:
            click.echo(
                f"note: list {result.output} last in the cell's pose_files to use the calibrated "
                "robot",
                err=True,
            )
    else:
        click.echo("nothing written (--dry-run)")


@click.command("plan-robot-calibration")
@click.argument("cell", metavar="CELL")
@device_option("The robot to calibrate.", required=True)
@click.option("--poses", "count", required=True, type=click.IntRange(min=1), help="How many.")
@click.option(
    "--target",
    default=None,
    metavar="FRAME",
    help="The frame the instrument measures (default: the device's first TCP).",
)
@click.option(
    "--instrument",
    type=click.Choice(["tracker", "probe"]),
    default="tracker",
    show_default=True,
    help="tracker: an instrument measures the target's point (laser tracker, CMM arm); probe: "
    "the robot's own ball-tip touch probe touches --feature faces and edges (self-calibration).",
)
@click.option(
    "--feature",
    "features",
    multiple=True,
    metavar="OWNER.FEATURE",
    help="--instrument probe: a plane or edge of known geometry to touch (repeat the option).",
)
@click.option("--sigma", default="0.02mm", show_default=True, help="The instrument's 1 sigma.")
@click.option("--candidates", default=2000, show_default=True, type=click.IntRange(min=1))
@seed_option()
@click.option(
    "--program",
    default=None,
    type=click.Path(dir_okay=False),
    help="Write a program that visits the poses (joint moves, a pause at each), checked.",
)
@output_option(
    "Write an observation file of the poses with the nominal points (a probe: the "
    "contacts with the nominal joints), to fill in.",
    name="template",
)
@click.option(
    "--floor",
    default=None,
    type=FiniteFloat(),
    metavar="Z",
    help="Tracker: the target stays above this world height [m] (default: the robot's "
    "mounting plane).",
)
@click.option(
    "--instrument-at",
    default=None,
    metavar="X,Y,Z",
    help="Tracker: where the instrument stands [m, world]; the line of sight must be clear.",
)
@click.option(
    "--acceptance",
    default=None,
    metavar="ANGLE",
    help="Tracker: the reflector's acceptance half-angle about the target's z axis (30deg).",
)
@json_option
@handle_errors
def plan_robot_calibration(
    cell,
    device,
    count,
    target,
    instrument,
    features,
    sigma,
    candidates,
    seed,
    program,
    template,
    floor,
    instrument_at,
    acceptance,
    json_output,
):
    """Choose the joint states to measure for 'rworld calibrate-robot'.

    Candidates are random joint states within the limits (a tracker), or touches of the
    robot's own ball probe on the --feature planes and edges with the stylus within 40 deg of
    the normal (--instrument probe); kept where the robot touches nothing, there (a touch: at
    its approach) and on the joint path from home.  Of them, the poses that predict the
    smallest error of the calibrated model are chosen (the identification Jacobian's
    information, D- then I-optimal, with exchanges), ordered into a short tour.  The predicted
    error is printed beside that of as many and of twice as many random candidates, and the
    least any choice of as many can predict (the optimal design's bound).  --program writes a
    program that visits each from home and back - a pause for the instrument, or a guarded
    move until the probe triggers - checked in simulation (a pose the robot collides on the
    way to is replaced).  A tracker's poses keep the target above the floor (--floor, else the
    robot's mounting plane) and, with --instrument-at, facing the tracker within --acceptance
    of the target's z axis with the line of sight clear of the arm.

    \b
    Examples:
      rworld plan-robot-calibration workcells/puma560 --device puma --poses 30 --target probe
      rworld plan-robot-calibration cell --device ur5 --poses 40 --instrument-at 2.5,-3,0.4 \
          --acceptance 30deg --floor 0
      rworld plan-robot-calibration cell --device ur5 --poses 40 --program cal.yaml -o obs.yaml
      rworld plan-robot-calibration workcells/probing --device puma --poses 40 \\
          --instrument probe --feature plate.top --feature plate.front \\
          --feature bracket.upright_face --program touches.yaml -o contacts.yaml

    Exit codes: 0 planned, 1 the program still collides, 2 bad input.
    """
    import numpy as np

    from ..api import parse_angle, parse_length
    from ..api import plan_robot_calibration as run

    at = None
    if instrument_at is not None:
        try:
            at = np.array([float(v) for v in instrument_at.split(",")])
        except ValueError:
            at = np.zeros(0)
        if at.shape != (3,) or not np.all(np.isfinite(at)):
            raise click.BadParameter("give X,Y,Z in metres (world)", param_hint="--instrument-at")
    if acceptance is not None and at is None:
        raise click.UsageError("--acceptance is the reflector's, towards --instrument-at")
    if instrument != "tracker" and (floor is not None or at is not None):
        raise click.UsageError("--floor and --instrument-at are for --instrument tracker")
    result = run(
        cell,
        device,
        count,
        target,
        parse_length(sigma),
        candidates,
        seed,
        program,
        template,
        instrument,
        list(features),
        floor,
        at,
        parse_angle(acceptance, "--acceptance") if acceptance is not None else None,
    )
    if json_output:
        emit_json(result.as_dict())
        return
    what = "touches" if result.instrument == "probe" else "poses"
    click.echo(
        f"{result.device}: {result.poses} {what} of {result.target} chosen from "
        f"{result.candidates - result.rejected} usable candidates "
        f"({result.rejected} unreachable, colliding or unseen); {result.identifiable} "
        "combinations identifiable"
    )
    for why, lost in result.constraints.items():
        if lost:
            click.echo(f"  {lost} candidate(s) {why}")
    if result.features:
        counts = {f: result.features.count(f) for f in dict.fromkeys(result.features)}
        click.echo("  " + ", ".join(f"{f}: {k}" for f, k in counts.items()))
    click.echo(
        "  predicted error of the calibrated model (rms, the estimate's own): "
        f"{result.predicted * 1000:.4f} mm"
    )
    click.echo(
        f"  {result.poses} random {what}: {result.random_same * 1000:.4f} mm; "
        f"{2 * result.poses} random: {result.random_double * 1000:.4f} mm; the best any "
        f"{result.poses} of these candidates can do: {result.best_possible * 1000:.4f} mm"
    )
    if result.program:
        extra = f" ({result.dropped} replaced: collisions on the way)" if result.dropped else ""
        click.echo(f"wrote {result.program}: each from home and back, checked{extra}")
    if result.template:
        fill = "the recorded joint values" if result.features else "the measured points"
        click.echo(f"wrote {result.template}: fill in {fill}")
