"""PNG charts (the ``plot`` extra): policy comparison bars and a trial's force traces.

matplotlib is imported only here and only when a chart is asked for, with the
non-interactive Agg backend, so the rest of the program runs without it.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from grasp_ctrl.display.plotting import pyplot
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import save_figure
from grasp_ctrl.loop.ticklog import read_tick_log
from grasp_ctrl.trials.analysis.compare import ordered_names, success_matrix

# One colour per controller state, for the shaded bands behind force traces.
STATE_COLOURS = {
    "tare": "#eeeeee",
    "reach": "#dde8f5",
    "close": "#fdebd0",
    "ramp": "#fad7a0",
    "lift": "#d5f5e3",
    "hold": "#abebc6",
    "lower": "#d6eaf8",
    "release": "#e8daef",
    "retreat": "#f2f3f4",
    "done": "#ffffff",
    "fault": "#f5b7b1",
}


def comparison_chart(
    summary: Mapping[str, Any],
    path: Path,
    policies: list[str] | None = None,
    objects: list[str] | None = None,
    title: str | None = None,
) -> Path:
    """Grouped bars: success rate per object (and ``all``), one bar per policy."""
    plt = pyplot()
    pols, objs = ordered_names(summary, policies, objects)
    rows = success_matrix(summary, pols, objs)
    groups = objs + ["all"]
    fig, ax = plt.subplots(figsize=(max(6.0, 1.1 * len(groups) + 1.5), 3.6), dpi=100)
    width = 0.8 / max(len(pols), 1)
    for j, p in enumerate(pols):
        xs = [i + (j - (len(pols) - 1) / 2) * width for i in range(len(groups))]
        rates = [r[j] for r in rows]
        ys = [100 * (v or 0.0) for v in rates]
        bars = ax.bar(xs, ys, width=width * 0.95, label=p)
        # Value labels, so a 0 % bar is visibly there rather than missing.
        ax.bar_label(bars, labels=["-" if v is None else f"{100 * v:.0f}" for v in rates], fontsize=7, padding=1)
    ax.set_xticks(range(len(groups)))
    ax.set_xticklabels([g.replace("_", " ") for g in groups], rotation=20, ha="right")
    ax.set_ylabel("success rate (%)")
    ax.set_ylim(0, 112)
    ax.axvline(len(groups) - 1.5, color="#888888", lw=0.8, ls=":")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.28), ncol=max(len(pols), 1), frameon=False)
    ax.set_title(title or f"lift-and-place success ({summary.get('backend', '')}, seed {summary.get('seed', '')})")
    fig.tight_layout()
    try:
        save_figure(fig, path)  # format from the extension; a symlink there is replaced, not followed
    finally:
        plt.close(fig)
    return path


def fingertips(header: list[str], frame: str) -> list[str]:
    suffix = f"_fx_{frame}"
    return [c[: -len(suffix)] for c in header if c.endswith(suffix) and "_true_" not in c]


def state_spans(t: list[float], states: list[str]) -> list[tuple[float, float, str]]:
    spans: list[tuple[float, float, str]] = []
    for i, s in enumerate(states):
        if spans and spans[-1][2] == s:
            spans[-1] = (spans[-1][0], t[i], s)
        else:
            spans.append((t[i], t[i], s))
    return spans


def force_traces(ticks_file: Path, path: Path, frame: str = "sensor", title: str | None = None) -> Path:
    """One panel per fingertip: estimated fx, fy, fz (solid) and, on the mock, the true
    force (dashed, sensor frame only) over time; controller states as shaded bands."""
    header, cols = read_tick_log(ticks_file)
    tips = fingertips(header, frame)
    if not tips:
        raise UsageError(f"{ticks_file}: no force columns in the {frame} frame, or no rows")
    plt = pyplot()
    t = [float(v) for v in cols["t"]]
    spans = state_spans(t, list(cols["state"]))
    fig, axes = plt.subplots(len(tips), 1, sharex=True, figsize=(9.0, 1.9 * len(tips) + 0.8), dpi=100, squeeze=False)
    colours = {"x": "tab:red", "y": "tab:green", "z": "tab:blue"}
    for ax, tip in zip(axes[:, 0], tips):
        for a, b, s in spans:
            ax.axvspan(a, b, color=STATE_COLOURS.get(s, "#ffffff"), lw=0)
        for axis in "xyz":
            ax.plot(t, cols[f"{tip}_f{axis}_{frame}"], color=colours[axis], lw=1.0, label=f"f{axis}")
            true_col = f"{tip}_true_f{axis}_{frame}"
            if true_col in cols:
                ax.plot(t, cols[true_col], color=colours[axis], lw=0.8, ls="--", alpha=0.7)
        ax.set_ylabel(f"{tip}\nN ({frame})")
        ax.grid(alpha=0.3, lw=0.5)
    top = axes[0, 0]
    for a, b, s in spans:
        if b - a > 0.04 * (t[-1] - t[0] or 1.0):
            top.annotate(
                s, ((a + b) / 2, 1.0), xycoords=("data", "axes fraction"), ha="center", va="bottom", fontsize=7
            )
    handles, labels = top.get_legend_handles_labels()
    if any(f"_true_fx_{frame}" in c for c in header):
        from matplotlib.lines import Line2D

        handles.append(Line2D([], [], color="black", ls="--", lw=0.8))
        labels.append("true")
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), frameon=False)
    axes[-1, 0].set_xlabel("t (s)")
    fig.suptitle(title or ticks_file.name, y=0.995, fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 0.97))
    try:
        save_figure(fig, path)  # format from the extension; a symlink there is replaced, not followed
    finally:
        plt.close(fig)
    return path
