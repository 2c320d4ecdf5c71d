"""rworld show CELL"""

from __future__ import annotations

import click

from .common import (
    emit_json,
    handle_errors,
    json_option,
    parse_joint_assignments,
    shown_issues,
)

KIND_STYLE = {"device": "bold cyan", "object": "bold green", "sensor": "bold magenta"}
FRAME_STYLE = {
    "auxiliary": "yellow",
    "tcp": "bold yellow",
    "link": "blue",
    "free": "white",
    "world": "bold",
}


@click.command()
@click.argument("cell", metavar="CELL")
@click.option(
    "--joints",
    "joints",
    multiple=True,
    metavar="DEVICE=q1,q2,...",
    help="Joint values (SI: rad or m) instead of the device's home; repeatable.",
)
@click.option(
    "--units",
    "units",
    type=click.Choice(["mm", "m"]),
    default="mm",
    show_default=True,
    help="Length unit of the printed positions (angles print in degrees).",
)
@json_option
@handle_errors
def show(cell: str, joints: tuple[str, ...], units: str, json_output: bool) -> None:
    """Print CELL's frame tree: every frame's world pose, affixments, masses.

    CELL is a cell.yaml or its directory.  Natural frames of devices,
    objects and sensors are shown with what holds them (rigid grasp,
    aggregation, ...; non-rigid rests_on); auxiliary frames, link frames and
    TCPs hang under their owner.  Positions are x, y, z in world; rotations
    are fixed-axis roll, pitch, yaw.  --json prints SI values (m, rad) and
    full 4x4 matrices.

    \b
    Examples:
      rworld show workcells/paper_fig9
      rworld show workcells/puma560 --joints puma=0,0.5,-1,0,0.3,0
      rworld show --json workcells/calibration_example
    """
    from ..api import summarize_cell

    summary = summarize_cell(cell, parse_joint_assignments(joints))
    if json_output:
        emit_json(summary.as_dict())
        return
    _render(summary, units)


def _rows(node, depth=0):
    """(node, display depth) in tree order; a device's link chain shows as one level (an
    explicit stack: no recursion on the tree's depth)."""
    stack = [(child, node, depth) for child in reversed(node.children)]
    while stack:
        child, parent, level = stack.pop()
        flat = child.kind == "link" and parent.kind == "link"
        child_depth = level if flat else level + 1
        yield child, child_depth
        stack.extend((grandchild, child, child_depth) for grandchild in reversed(child.children))


def _render(summary, units: str) -> None:
    import numpy as np
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    scale = 1000.0 if units == "mm" else 1.0
    digits = 1 if units == "mm" else 4  # 0.1 mm, for people; --json has every digit
    console = Console(highlight=False)
    err_console = Console(stderr=True, highlight=False)
    for w in shown_issues(summary.warnings):
        err_console.print(w.format(), style="yellow", markup=False)

    title = summary.name + (f" - {summary.description}" if summary.description else "")
    # one line per frame at any width (80 columns too): the title and the descriptions are
    # cut with an ellipsis, never wrapped; names and numbers are never cut (--json has it all)
    console.print(Text(title, style="bold"), no_wrap=True, overflow="ellipsis", crop=True)
    table = Table(show_edge=False, pad_edge=False, box=None, header_style="bold")
    rows = list(_rows(summary.root))
    name_width = max((2 * (d - 1) + (2 if d > 1 else 0) + len(n.name) for n, d in rows), default=5)
    table.add_column(
        "frame", no_wrap=True, min_width=name_width
    )  # names are what users type: never cut
    cells = []
    for node, depth in rows:
        if node.kind == "natural":
            style = KIND_STYLE.get(node.primitive, "bold")
            what = f"{node.primitive} {node.detail}".strip()
        else:
            style = FRAME_STYLE.get(node.kind, "white")
            what = f"{node.kind} frame"
        name = Text("  " * (depth - 1) + ("└ " if depth > 1 else ""), style="dim")
        name.append(node.name, style=style)
        if node.mass is not None:
            what += f", {node.mass:.4g} kg"
        if node.affixment:
            aff = node.affixment
            what += (
                ", held "
                + aff["type"].replace("_", "-")
                + (f" ({aff['kind']})" if aff["kind"] else "")
            )
        # round first so -1e-14 prints as 0.00, not -0.00
        xyz = " ".join(
            f"{v:.{digits}f}" for v in np.round(node.T_world[:3, 3] * scale, digits) + 0.0
        )
        rpy = " ".join(f"{v:.1f}" for v in np.round(np.degrees(node.rpy), 1) + 0.0)
        cells.append((name, what, xyz, rpy))
    # numbers are never cut: the description takes what the names and numbers leave of the
    # terminal's width; the units in the headers as Text, since rich reads "[mm]" as markup
    headers = (f"x y z [{units}]", "r p y [deg]")
    widths = [max([len(c[k]) for c in cells] + [len(h)]) for k, h in zip((2, 3), headers)]
    left = console.width - name_width - sum(widths) - 6  # the gaps between the columns
    what = max([len(str(c[1])) for c in cells] + [4])
    table.add_column("what", no_wrap=True, overflow="ellipsis", max_width=max(min(what, left), 8))
    for header, width in zip(headers, widths):
        table.add_column(Text(header), justify="right", no_wrap=True, min_width=width)
    for row in cells:
        table.add_row(*row)
    console.print(table)

    if summary.joints:
        _print_table(
            console,
            "Devices",
            ["device", "joint values (SI: rad, m)", "active TCP"],
            [
                [d, "[" + ", ".join(f"{v:.4g}" for v in q) + "]", summary.active_tcps[d]]
                for d, q in summary.joints.items()
            ],
        )
    if summary.conditions:
        _print_table(
            console,
            "Frame conditions (calibration)",
            ["frame", "condition", "features"],
            [
                [c["frame"], f"{c['type']} ({c['code']})", ", ".join(c["features"])]
                for c in summary.conditions
            ],
        )


def _print_table(console, title: str, columns: list[str], rows: list[list[str]]) -> None:
    from rich.table import Table

    table = Table(title=title, title_justify="left", show_edge=False, box=None, header_style="bold")
    for column in columns:
        table.add_column(column)
    for row in rows:
        table.add_row(*row)
    console.print()
    console.print(table)
