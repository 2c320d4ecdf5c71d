"""Draw docs/architecture.png: the rooms of rworld_cli and the one direction of imports.

Run: .venv/bin/python docs/architecture_picture.py
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

ROOMS = {
    # name: (x, y, width, text, colour)
    "cli": (
        3.0,
        5.0,
        6.0,
        "cli/  - one module per command: parse, call the api, render",
        "#c6dbef",
    ),
    "api": (3.0, 3.9, 6.0, "api/  - task functions per command family; no printing", "#9ecae1"),
    "schema": (
        0.2,
        2.4,
        3.6,
        "schema/  - every file format:\ncells, poses, programs, runs, paths,\n"
        "measurements, captures, tables,\nresults, logs, URDF, xacro (as data),\nJSON Schemas",
        "#fdd0a2",
    ),
    "calc": (
        4.2,
        2.4,
        7.6,
        "calculation rooms (plain SI data in, results out):\nworld (frame tree), kinematics, "
        "dynamics, motion, sensing (types/),\ncollision, calibration, planning (constraints), "
        "vision (cameras),\nsimulate (a module per step family); "
        "export (one walk, a Writer per language)",
        "#c7e9c0",
    ),
    "model": (
        3.0,
        0.9,
        6.0,
        "model/  - plain SI data: cell, rules, programs, measurements, paths, cameras",
        "#dadaeb",
    ),
    "common": (
        3.0,
        0.0,
        6.0,
        "errors, units, spatial, codegen, kernels, fileio  - shared, know no room",
        "#eeeeee",
    ),
}


def main() -> None:
    fig, ax = plt.subplots(figsize=(11, 6.2))
    boxes = {}
    for name, (x, y, w, text, colour) in ROOMS.items():
        h = 1.2 if name in ("schema", "calc") else 0.6
        ax.add_patch(
            FancyBboxPatch((x, y), w, h, boxstyle="round,pad=0.05", fc=colour, ec="#555555")
        )
        ax.text(x + w / 2, y + h / 2, text, ha="center", va="center", fontsize=9)
        boxes[name] = (x, y, w, h)

    def arrow(a: str, b: str, dx_a: float = 0.0, dx_b: float = 0.0) -> None:
        xa, ya, wa, _ = boxes[a]
        xb, yb, wb, hb = boxes[b]
        start = (xa + wa / 2 + dx_a, ya - 0.02)
        end = (xb + wb / 2 + dx_b, yb + hb + 0.07)
        ax.add_patch(
            FancyArrowPatch(start, end, arrowstyle="-|>", mutation_scale=14, color="#333333")
        )

    arrow("cli", "api")
    arrow("api", "schema", dx_a=-2.0)
    arrow("api", "calc", dx_a=2.0)
    arrow("schema", "model", dx_b=-2.0)
    arrow("calc", "model", dx_b=2.0)
    arrow("model", "common")
    ax.text(
        4.0, 3.0, "never\nimport\neach other", ha="center", va="center", fontsize=8, color="#aa0000"
    )
    ax.set_xlim(0, 12)
    ax.set_ylim(-0.2, 5.8)
    ax.axis("off")
    ax.set_title(
        "rworld_cli: imports go down only (tests/test_architecture.py checks it)", fontsize=11
    )
    out = Path(__file__).with_name("architecture.png")
    fig.savefig(out, dpi=110, bbox_inches="tight")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
