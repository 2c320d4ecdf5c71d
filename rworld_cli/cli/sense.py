"""rworld sense"""

from __future__ import annotations

import click

from .common import (
    FiniteFloat,
    device_option,
    emit_json,
    handle_errors,
    joints_option,
    json_option,
    parse_joint_assignments,
)


@click.command()
@click.argument("cell", metavar="CELL")
@joints_option
@device_option("With --q: the device whose joint values --q gives.")
@click.option("--q", default=None, metavar="Q1,...,QN", help="Joint values (SI) of --device.")
@click.option(
    "--sensor",
    "sensors",
    multiple=True,
    metavar="NAME",
    help="Read only these sensors; repeatable.",
)
@click.option(
    "--tolerance",
    type=FiniteFloat(),
    default=None,
    help="Surfaces this close to a cell touch it [m] (default 1e-6).",
)
@click.option(
    "--png",
    "png",
    default=None,
    type=click.Path(dir_okay=False),
    help="Write the tactile and proximity maps as a PNG.",
)
@json_option
@handle_errors
def sense(cell, joints, device, q, sensors, tolerance, png, json_output):
    """Read CELL's sensors by interference checking: touch, tactile, proximity, presence, force.

    Tactile maps print as grids ('#' contact, '.' free; top line = the
    pad's +y edge); proximity gives the nearest slice that meets something
    (1 = nearest the sensor); force the overlap volume through the
    sensor's calibration curve.

    \b
    Examples:
      rworld sense workcells/paper_fig9
      rworld sense workcells/paper_fig9 --sensor pad_a --png pad.png
      rworld sense workcells/paper_fig9 --joints hand_a=0.02 --json
      rworld sense workcells/puma560 --device puma --q 0,0.6,-2.4,0,0.3,0
    """
    from ..api import describe_reading, sense, write_sensor_maps

    if (device is None) != (q is None):
        raise click.UsageError("--device and --q go together")
    assignments = parse_joint_assignments(joints + ((f"{device}={q}",) if device else ()))
    _, readings = sense(cell, assignments, list(sensors) or None, tolerance)
    written = write_sensor_maps(readings, png) if png else None
    if json_output:
        emit_json(
            {
                "cell": cell,
                "readings": [r.as_dict() for r in readings],
                "png": str(written) if written else None,
            }
        )
        return
    for r in readings:
        for line in describe_reading(r):
            click.echo(line)
    if written:
        click.echo(f"wrote {written}")
