"""Options and I/O shared by the kinematics and dynamics commands."""

from __future__ import annotations

import click

from .common import emit_json, shown_issues


def device_options(fn):
    """CELL argument, --device (optional when the cell has one device) and --tcp."""
    fn = click.option(
        "--tcp",
        default=None,
        metavar="FRAME",
        help="Tool frame (default: the device's active TCP); 'tool' means DEVICE.tool.",
    )(fn)
    fn = click.option(
        "--joints",
        "other_joints",
        multiple=True,
        metavar="DEVICE=q1,...",
        help="Joint values (SI) of other devices, e.g. the conveyor carrying the arm; repeatable.",
    )(fn)
    fn = click.option(
        "--device",
        "-d",
        default=None,
        metavar="NAME",
        help="Device (default: the cell's only device).",
    )(fn)
    return click.argument("cell", metavar="CELL")(fn)


def output_options(fn):
    return click.option(
        "-o",
        "--output",
        default=None,
        type=click.Path(dir_okay=False),
        help="Write CSV to this file (atomically) instead of stdout.",
    )(fn)


def parse_vector(text: str, name: str, length: int | None = None) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise click.BadParameter(
            f"'{text}': expected numbers separated by commas", param_hint=name
        ) from None
    if any(v != v or abs(v) == float("inf") for v in values):
        raise click.BadParameter(f"'{text}': values must be finite", param_hint=name)
    if length is not None and len(values) != length:
        raise click.BadParameter(
            f"'{text}': expected {length} values, got {len(values)}", param_hint=name
        )
    return values


def context(cell: str, device: str | None, tcp: str | None, other_joints: tuple[str, ...] = ()):
    from ..api import device_context, the_device
    from .common import parse_joint_assignments

    return device_context(
        cell, the_device(cell, device), tcp, parse_joint_assignments(other_joints)
    )


def joint_rows(ctx, states: str | None, q: str | None, groups: list[str]):
    """Joint arrays from --states FILE or --q (q only); returns (dict group -> (N, n), warnings)."""
    from ..api import joint_states

    n = ctx.device.dof
    if (states is None) == (q is None or groups != ["q"]):
        if groups == ["q"]:
            raise click.UsageError(
                "give the joint values with --q q1,...,qn or --states FILE (one of them)"
            )
        raise click.UsageError(
            "give --states FILE with columns " + ", ".join(f"{g}1..{g}{n}" for g in groups)
        )
    return joint_states(ctx, states, parse_vector(q, "--q", n) if states is None else None, groups)


def emit(
    columns, rows, payload: dict, json_output: bool, output: str | None, warnings, notes=()
) -> None:
    """JSON on stdout, or CSV to a file or stdout; warnings and notes (what loads a result
    includes) on stderr, in the JSON with --json."""
    from ..api import table_text, write_table

    if json_output:
        payload["warnings"] = [w.as_dict() for w in warnings]
        payload["notes"] = list(notes)
        emit_json(payload)
        return
    for w in shown_issues(warnings):
        click.echo(w.format(), err=True)
    for note in notes:
        click.echo(f"note: {note}", err=True)
    if output:
        write_table(output, columns, rows)
        click.echo(f"wrote {output} ({len(rows)} row(s))", err=True)
    else:
        click.echo(table_text(columns, rows), nl=False)
