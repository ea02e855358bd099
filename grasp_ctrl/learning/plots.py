"""Box plots like the paper's Figs. 3-4 (needs the ``plot`` extra: matplotlib)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from grasp_ctrl.errors import UsageError


def box_plots(
    per_model: Mapping[str, Mapping[str, np.ndarray]],
    path: str | Path,
    metrics: tuple[str, ...] = ("angle_deg", "magnitude_error_n"),
) -> None:
    """per_model: label -> {metric: per-sample values}; one panel per metric."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise UsageError("plots need matplotlib: pip install .[plot]") from None
    labels = list(per_model)
    fig, axes = plt.subplots(1, len(metrics), figsize=(4.5 * len(metrics), 0.5 * len(labels) + 2))
    axes = np.atleast_1d(axes)
    for ax, metric in zip(axes, metrics):
        # whiskers at 1.5 IQR, no fliers: the paper's convention
        ax.boxplot([per_model[k][metric] for k in labels], vert=False, whis=1.5, showfliers=False)
        ax.set_yticks(range(1, len(labels) + 1), labels)
        ax.set_xlabel(metric.replace("_", " "))
        ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    from grasp_ctrl.files.safe_write import save_figure

    try:
        save_figure(fig, path, "--plot", dpi=120)  # a symlink there is replaced, a stream gets the bytes
    finally:
        plt.close(fig)
