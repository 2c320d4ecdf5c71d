"""rworld render"""

from __future__ import annotations

import click

from .common import (
    FiniteFloat,
    emit_json,
    handle_errors,
    joints_option,
    json_option,
    output_option,
    parse_joint_assignments,
)


@click.command()
@click.argument("cell", metavar="CELL")
@output_option("A .png picture, a .glb glTF scene or an .html viewer page.")
@click.option(
    "--html",
    "html_path",
    default=None,
    type=click.Path(dir_okay=False),
    help="Also (or only) write the state as a self-contained HTML viewer page.",
)
@joints_option
@click.option(
    "--view",
    default="25,-60",
    show_default=True,
    metavar="ELEV,AZIM",
    help="PNG camera elevation and azimuth [deg].",
)
@click.option("--no-frames", is_flag=True, help="PNG: leave out the frame triads.")
@click.option(
    "--tolerance",
    type=FiniteFloat(),
    default=None,
    help="Sensor touching tolerance [m] (default 1e-6, docs/sensing.md).",
)
@click.option(
    "--run",
    default=None,
    metavar="RUN",
    help="Simulate RUN and draw its first collision (or clearance violation), the pair "
    "highlighted.",
)
@click.option(
    "--clearance",
    default=None,
    metavar="LENGTH",
    help="With --run: the required clearance, e.g. 10mm (default: the run file's).",
)
@click.option(
    "--camera",
    default=None,
    metavar="SENSOR",
    help="Write the image this camera sensor would take (-o FILE.png): the calibration "
    "boards through its lens, the bodies in front of them, blur and noise (docs/vision.md).",
)
@click.option(
    "--blur",
    type=FiniteFloat(),
    default=0.6,
    show_default=True,
    metavar="PX",
    help="With --camera: the lens's blur, a Gaussian's sigma [px].",
)
@click.option(
    "--noise",
    type=FiniteFloat(),
    default=2.0,
    show_default=True,
    metavar="GREY",
    help="With --camera: the pixels' noise, sigma in grey levels of 255.",
)
@click.option(
    "--seed", type=int, default=0, show_default=True, help="With --camera: the noise's seed."
)
@click.option(
    "--depth",
    "depth_path",
    default=None,
    type=click.Path(dir_okay=False),
    metavar="FILE.png",
    help="With --camera: also the depth of the boards seen, a 16-bit PNG in mm (0: none).",
)
@json_option
@handle_errors
def render(
    cell,
    output,
    html_path,
    joints,
    view,
    no_frames,
    tolerance,
    run,
    clearance,
    camera,
    blur,
    noise,
    seed,
    depth_path,
    json_output,
):
    """Draw CELL: objects, devices, frame triads, sensors with colour-coded cells.

    A sensor cell is red when it senses something, green when free (the
    report's Fig. 13).  A .glb file opens in any glTF viewer (Blender,
    three.js, online viewers).

    \b
    Examples:
      rworld render workcells/paper_fig9 -o cell.png
      rworld render workcells/paper_fig9 -o cell.glb
      rworld render workcells/paper_fig9 --html cell.html     # orbit it in a browser
      rworld render workcells/puma560 --joints puma=0,0.5,-1,0,0.3,0 -o puma.png --view 20,-120
      rworld render workcells/puma560 --run through_table -o first_contact.png
      rworld render tests/data/vision/cell --camera overhead -o overhead.png
    """
    from ..api import render_run_contact, render_scene
    from .physics_common import parse_vector

    if camera is None and depth_path is not None:
        raise click.UsageError("--depth is for --camera")
    if camera is not None:
        from ..api import render_camera

        if not output or not output.lower().endswith(".png") or html_path or run:
            raise click.UsageError("--camera writes one PNG image: -o FILE.png, no --html or --run")
        if blur < 0 or noise < 0:
            raise click.UsageError("--blur and --noise are sigmas: 0 or more")
        if depth_path is not None and not depth_path.lower().endswith(".png"):
            raise click.UsageError("--depth writes a 16-bit PNG: FILE.png")
        result = render_camera(
            cell, camera, output, parse_joint_assignments(joints), blur, noise, seed, depth_path
        )
        if json_output:
            emit_json(result)
        else:
            click.echo(
                f"wrote {output}: {camera}'s view, {result['resolution'][0]}x"
                f"{result['resolution'][1]} px, {result['board_pixels']} pixels of boards "
                f"({result['seconds']:.2f} s)"
            )
        return
    elev, azim = parse_vector(view, "--view", 2)
    outputs = [path for path in (output, html_path) if path]
    if not outputs:
        raise click.UsageError("give the file to write: -o FILE (.png, .glb, .html) or --html FILE")
    if html_path and not html_path.lower().endswith(".html"):
        raise click.UsageError(f"--html writes an HTML page: '{html_path}' does not end in .html")
    if run is not None:
        if joints:
            raise click.UsageError("--run draws the run's own state: leave out --joints")
        written, contact = render_run_contact(
            cell, run, outputs, (elev, azim), not no_frames, clearance
        )
        if json_output:
            emit_json(
                {
                    "cell": cell,
                    "written": [str(path) for path in written],
                    "contact": contact.as_dict(),
                }
            )
        else:
            click.echo(contact.describe())
            for path in written:
                click.echo(f"wrote {path}")
        return
    written = render_scene(
        cell, outputs, parse_joint_assignments(joints), tolerance, (elev, azim), not no_frames
    )
    if json_output:
        emit_json({"cell": cell, "written": [str(path) for path in written]})
    else:
        for path in written:
            click.echo(f"wrote {path}")
