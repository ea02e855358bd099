"""A study's history and parameter importances as PNG (``tune --plots DIR``, the plot extra)."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import TYPE_CHECKING, cast

import optuna
from optuna.trial import TrialState

from grasp_ctrl.display.plotting import pyplot

if TYPE_CHECKING:
    import numpy as np
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def write_study_plots(study: optuna.Study, out_dir: Path, name: str) -> list[str]:
    """Writes OUT_DIR/NAME_history.png and NAME_importances.png; returns a line per file
    (or why it was not drawn)."""
    plt = pyplot()
    from optuna.visualization import matplotlib as ov

    out_dir.mkdir(parents=True, exist_ok=True)
    lines = []
    complete = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
    charts = (("history", ov.plot_optimization_history, 1), ("importances", ov.plot_param_importances, 2))
    for kind, draw, needed in charts:
        path = out_dir / f"{name}_{kind}.png"
        if len(complete) < needed:
            lines.append(f"{kind}: not drawn, {len(complete)} finished settings (needs {needed})")
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ax = draw(study)
        except (ValueError, RuntimeError) as exc:  # e.g. every setting scored the same
            lines.append(f"{kind}: not drawn ({str(exc).splitlines()[0]})")
            continue
        fig = _figure(ax)
        fig.set_size_inches(8.0, 4.5)
        fig.suptitle(f"{name}: {study.study_name}", fontsize=9)
        fig.tight_layout()
        fig.savefig(path, dpi=100)
        plt.close(fig)
        lines.append(f"{kind}: {path}")
    return lines


def _figure(drawn: Axes | np.ndarray) -> Figure:
    """The figure of an optuna chart (an Axes, or an array of them for some charts): a
    top-level figure of its own, never a SubFigure."""
    return cast("Figure", drawn.figure if hasattr(drawn, "figure") else drawn[0].figure)
