"""A trial at a glance (``plot``): one PNG with every fingertip's forces, the
release signal, the heights, the controller's states and the outcome.

Per fingertip: the normal force (along the pad normal, sensor z) and the
tangential force (across it) estimated, and on the mock the true ones (dashed),
with tau, the grip the force controller aims for. Then the release fingertip's
force on the object along the support normal (+z), ``-f_world_z``, with
``-release_threshold_n`` (docs/design.md 4: release below it), and the object's and
palm's heights. Controller states are shaded and named in every panel; the
moment the controller ended (done or fault, with its reason) and the world's
events (object fell, crushed, knocked over) are marked.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import save_figure
from grasp_ctrl.trials.analysis.plots import STATE_COLOURS, pyplot, state_spans
from grasp_ctrl.trials.analysis.trial_view import TrialView

NORMAL_COLOUR, TANGENTIAL_COLOUR = "tab:blue", "tab:orange"
WORLD_EVENTS = ("fell", "crushed", "knocked_over")


def _normal_tangential(view: TrialView, tip: str, prefix: str) -> tuple[np.ndarray, np.ndarray] | None:
    cols = [f"{tip}_{prefix}f{a}_sensor" for a in "xyz"]
    if not all(view.has(c) for c in cols):
        return None
    fx, fy, fz = (view.cols[c] for c in cols)
    return fz, np.hypot(fx, fy)


def trial_figure(view: TrialView, path: Path) -> Path:
    tips = view.fingers
    if not tips:
        raise UsageError(f"{view.ticks_path}: no fingertip force columns")
    plt = pyplot()
    t = view.t
    spans = state_spans(list(t), view.states)
    n_panels = len(tips) + 2
    fig, axes = plt.subplots(n_panels, 1, sharex=True, figsize=(10.0, 1.75 * n_panels + 1.0), dpi=100, squeeze=False)
    axes = axes[:, 0]
    for ax in axes:
        for a, b, s in spans:
            ax.axvspan(a, b, color=STATE_COLOURS.get(s, "#ffffff"), lw=0)
        ax.grid(alpha=0.3, lw=0.5)
    tau = view.cols.get("grip_target_n")
    grasping = set(view.grasp_fingers())
    for ax, tip in zip(axes, tips):
        est = _normal_tangential(view, tip, "")
        true = _normal_tangential(view, tip, "true_")
        assert est is not None
        ax.plot(t, est[0], color=NORMAL_COLOUR, lw=1.1, label="normal (estimated)")
        ax.plot(t, est[1], color=TANGENTIAL_COLOUR, lw=1.1, label="tangential (estimated)")
        if true is not None:
            ax.plot(t, true[0], color=NORMAL_COLOUR, lw=0.9, ls="--", alpha=0.8, label="normal (true)")
            ax.plot(t, true[1], color=TANGENTIAL_COLOUR, lw=0.9, ls="--", alpha=0.8, label="tangential (true)")
        if tau is not None and tip in grasping and np.isfinite(tau).any():
            ax.plot(t, tau, color="black", lw=0.8, ls=":", label="tau (grip target)")
        ax.set_ylabel(f"{tip}\nforce (N)")
    # The release signal.
    rel_ax = axes[-2]
    rel = view.release_finger()
    if view.has(f"{rel}_fz_world"):
        rel_ax.plot(
            t, -view.cols[f"{rel}_fz_world"], color="tab:purple", lw=1.1, label=f"{rel} force on object along +z"
        )
    threshold = view.setting("release_threshold_n")
    if threshold is not None:
        rel_ax.axhline(-threshold, color="tab:red", lw=0.9, ls="--", label=f"-release threshold ({threshold:g} N)")
    rel_ax.axhline(0.0, color="#777777", lw=0.6)
    rel_ax.set_ylabel("release\nsignal (N)")
    # Heights.
    h_ax = axes[-1]
    if view.has("object_z_world"):
        h_ax.plot(t, 1000 * view.cols["object_z_world"], color="tab:brown", lw=1.2, label="object height")
    if view.has("palm_z_world"):
        palm = 1000 * view.cols["palm_z_world"]
        h_ax.plot(t, palm - palm[0], color="tab:gray", lw=1.0, label="palm height (from start)")
    h_ax.set_ylabel("height\n(mm)")
    h_ax.set_xlabel("t (s)")
    # States named on the top panel, the end and the world's events everywhere.
    top = axes[0]
    for a, b, s in spans:
        if b - a > 0.035 * (t[-1] - t[0] or 1.0):
            top.annotate(
                s, ((a + b) / 2, 1.0), xycoords=("data", "axes fraction"), ha="center", va="bottom", fontsize=7
            )
    end = view.end_event()
    if end is not None:
        colour = "tab:green" if end[1] == "done" else "tab:red"
        for ax in axes:
            ax.axvline(end[0], color=colour, lw=1.4)
        h_ax.annotate(
            end[1],
            (end[0], 0.95),
            xycoords=("data", "axes fraction"),
            ha="right",
            va="top",
            fontsize=8,
            color=colour,
            fontweight="bold",
        )
    for ev in (view.record or {}).get("events", []):
        if ev.get("kind") in WORLD_EVENTS:
            h_ax.axvline(ev["t"], color="tab:red", lw=0.9, ls="-.")
            h_ax.annotate(
                ev["kind"].replace("_", " "),
                (ev["t"], 0.05),
                xycoords=("data", "axes fraction"),
                ha="left",
                va="bottom",
                fontsize=7,
                color="tab:red",
            )
    handles, labels = [], []
    for ax in (axes[0], rel_ax, h_ax):
        for hd, lb in zip(*ax.get_legend_handles_labels()):
            if lb not in labels:
                handles.append(hd)
                labels.append(lb)
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 4), frameon=False, fontsize=8)
    fig.suptitle(view.title(), y=0.995, fontsize=10)
    legend_rows = (len(labels) + 3) // 4
    fig.tight_layout(rect=(0, 0.018 * legend_rows + 0.02, 1, 0.975))
    try:
        save_figure(fig, path)  # format from the extension; a symlink there is replaced, not followed
    finally:
        plt.close(fig)
    return path
