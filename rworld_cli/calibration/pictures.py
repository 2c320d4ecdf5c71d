"""Pictures of calibration analyses."""

from __future__ import annotations

from ..fileio import save_figure


def write_error_histogram(kind: str, samples: dict, path) -> None:
    """PNG: the histogram of log10 relative element errors per trial, one series per method."""
    import matplotlib

    matplotlib.use("Agg")

    import matplotlib.pyplot as plt
    import numpy as np

    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    for name, (errors, _) in samples.items():
        ax.hist(np.log10(np.maximum(errors, 1e-18)), bins=50, alpha=0.6, label=name)
    ax.set_xlabel("log10 median relative element error per trial")
    ax.set_ylabel("trials")
    ax.set_title(f"{kind}: T with orthogonality enforced (constrained) or not")
    ax.legend()
    save_figure(fig, path)
