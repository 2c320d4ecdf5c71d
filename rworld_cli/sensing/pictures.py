"""Pictures of sensor readings: colour-coded PNG maps (each type says what its panel shows)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_maps_png(readings, path: str | Path) -> Path:
    """One panel per tactile or proximity sensor: contact red, free green (the report's Fig. 13
    colours).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    from .types import sensor_type

    panels = [(r, sensor_type(r.type).panel(r)) for r in readings]
    panels = [(r, p) for r, p in panels if p is not None]
    if not panels:
        from ..errors import UserError

        raise UserError("no tactile or proximity sensor among those read: nothing to draw")
    cmap = ListedColormap(["#3a9d5d", "#d62728"])
    fig, axes = plt.subplots(
        1, len(panels), figsize=(3.2 * len(panels), 3.6), squeeze=False, constrained_layout=True
    )
    for ax, (r, (cells, title, xlabel, ylabel)) in zip(axes[0], panels):
        ax.imshow(
            cells.astype(int), cmap=cmap, vmin=0, vmax=1, origin="lower", interpolation="nearest"
        )
        ax.set_xticks(np.arange(-0.5, cells.shape[1], 1), minor=True)
        ax.set_yticks(np.arange(-0.5, cells.shape[0], 1), minor=True)
        ax.grid(which="minor", color="white", linewidth=1.5)
        ax.tick_params(which="both", length=0)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_title(title + ("\n" + ", ".join(r.objects) if r.objects else ""), fontsize=9)
    fig.text(
        0.5,
        0.005,
        "red: contact / something in range    green: free",
        ha="center",
        va="bottom",
        fontsize=8,
        color="#444444",
    )
    from ..fileio import save_figure

    return save_figure(fig, path, dpi=120)
