"""Pictures of planned timings."""

from __future__ import annotations

from ..fileio import save_figure


def write_timing_plot(title, timing, info, t, ratios, path) -> None:
    """PNG: path speed against its limit curve and controllable set; the limit ratios along the
    trajectory.
    """
    import matplotlib

    matplotlib.use("Agg")

    import matplotlib.pyplot as plt
    import numpy as np

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 7), constrained_layout=True)
    ax1.plot(
        timing.s,
        np.sqrt(np.maximum(info["x_limit"], 0)),
        color="grey",
        label="limit curve (constraints at each s)",
    )
    ax1.plot(
        timing.s,
        np.sqrt(np.maximum(info["K_hi"], 0)),
        color="orange",
        linestyle="--",
        label="controllable (can still stop)",
    )
    ax1.plot(timing.s, np.sqrt(timing.x), color="C0", linewidth=2, label="time-optimal")
    ax1.set_xlabel("path parameter s")
    ax1.set_ylabel("path speed ds/dt [1/s]")
    top = np.sqrt(np.max(timing.x)) * 1.6
    ax1.set_ylim(0, top)
    ax1.legend(loc="upper right", fontsize=8)
    ax1.set_title(f"{title}: cycle time {timing.duration:.4f} s")
    for name, style in (("torque", "-"), ("velocity", ":"), ("acceleration", "--")):
        if name in ratios:
            for j in range(ratios[name].shape[1]):
                ax2.plot(
                    t,
                    ratios[name][:, j],
                    style,
                    color=f"C{j}",
                    label=f"{name} {j + 1}" if name == "torque" or j == 0 else None,
                )
    ax2.axhline(1.0, color="red", linewidth=1)
    ax2.set_xlabel("time [s]")
    ax2.set_ylabel("|value| / limit")
    ax2.set_ylim(0, 1.1)
    ax2.legend(loc="lower right", fontsize=7, ncol=3)
    save_figure(fig, path)
