"""rworld clearance"""

from __future__ import annotations

import sys

import click

from .common import (
    EXIT_CHECK_FAILED,
    emit_json,
    handle_errors,
    joints_option,
    json_option,
    parse_joint_assignments,
)


@click.command()
@click.argument("cell", metavar="CELL")
@joints_option
@click.option(
    "--clearance",
    "required",
    default=None,
    metavar="LENGTH",
    help="Required distance between bodies that may not touch, e.g. 10mm; closer fails.",
)
@click.option("--all", "show_all", is_flag=True, help="List every pair (default: the 15 nearest).")
@json_option
@handle_errors
def clearance(cell, joints, required, show_all, json_output):
    """Exact distances between all bodies of CELL in one state, nearest first.

    Each pair has its distance, or its penetration depth where the bodies overlap (--json
    adds the closest points).
    Pairs that may touch (adjacent links, a grasped or resting object, a tool on its flange,
    a mounted device, the cell's allowed_contacts) say why.  Exit 1 when bodies that may
    not touch overlap or come closer than --clearance; 0 otherwise.

    \b
    Examples:
      rworld clearance workcells/puma560
      rworld clearance workcells/puma560 --joints puma=0,0.6,-2.4,0,-1.2,0 --clearance 10mm
      rworld clearance workcells/paper_fig9 --json | jq '.pairs[0]'
    """
    from ..api import clearance as pair_table
    from ..api import parse_length_option

    need = parse_length_option(required, "--clearance") if required is not None else 0.0
    pairs, model = pair_table(cell, parse_joint_assignments(joints))
    failing = [p for p in pairs if p.allowed is None and (p.distance <= 0 or p.distance < need)]
    if json_output:
        emit_json(
            {
                "cell": cell,
                "required_clearance": need,
                "ok": not failing,
                "pairs": [p.as_dict() for p in pairs],
                "not_checked": model.unchecked,
                "open_meshes": model.open_meshes,
            }
        )
        if failing:
            sys.exit(EXIT_CHECK_FAILED)
        return
    from rich.console import Console
    from rich.table import Table

    console = Console(highlight=False)
    table = Table(title=f"{cell}: body pairs, nearest first", title_justify="left", box=None)
    for col, justify in (("pair", "left"), ("distance [mm]", "right"), ("may touch", "left")):
        table.add_column(col, justify=justify)
    for p in pairs if show_all else pairs[:15]:
        bad = p.allowed is None and (p.distance <= 0 or p.distance < need)
        text = (
            f"overlap, depth {1000 * p.depth:.1f}" + (" (buried)" if p.buried else "")
            if p.distance <= 0
            else f"{1000 * p.distance:.1f}"
        )
        table.add_row(
            f"{p.a} / {p.b}",
            f"[red]{text}[/]" if bad else text,
            p.allowed or "",
        )
    console.print(table)
    if not show_all and len(pairs) > 15:
        console.print(f"... {len(pairs) - 15} more pairs (--all lists them)")
    for label in model.unchecked:
        console.print(f"[yellow]note[/]: {label} has no geometry: not checked")
    for label in model.open_meshes:
        console.print(f"[yellow]note[/]: {label}'s mesh is not closed: checked as a surface only")
    if failing:
        console.print(
            f"[red]failed[/]: {len(failing)} pair(s) that may not touch "
            + ("overlap or come too close" if need else "overlap")
        )
        sys.exit(EXIT_CHECK_FAILED)
