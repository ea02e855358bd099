"""Animated replay of a trial (``plot --animate OUT.gif``): the hand, the object
and each fingertip's force as arrows, from the tick log.

Two views of the world (side: x-z, front: y-z; mm). Each finger is drawn as the
chain of its joint origins to the fingertip sensor, by forward kinematics of
the logged joint angles on the trial's hand; the palm moves as logged (the arm
translates the hand, so hand axes are world axes). The object is its profile's
footprint and height at the logged height above the table (centred on the world
origin, where it is placed; the mock's few-mm jitter is not logged). Arrows:
the estimated force on each fingertip in the world frame (solid) and, on the
mock, the true force (dashed outline), ``ARROW_MM_PER_N`` long per newton.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.display.plotting import pyplot
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import output_file
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.trials.analysis.trial_view import TrialView

ARROW_MM_PER_N = 15.0
MAX_FRAMES = 100
VIEWS = (("side (x-z)", 0), ("front (y-z)", 1))  # title, horizontal world axis


def _frames(view: TrialView, hand: HandConfig, stride: int) -> dict[str, np.ndarray]:
    """Per sampled tick: finger polylines (F, n+2, 3), sensor origins and rotations, world mm."""
    kin = HandKinematics(hand)
    names = view.fingers
    n_joints = len(hand.joints)
    idx = np.arange(0, len(view.t), stride)
    q = np.stack([view.cols[f"q{j}"][idx] for j in range(n_joints)], axis=1)
    palm = np.stack([view.cols[f"palm_{a}_world"][idx] for a in "xyz"], axis=1)
    longest = max(kin.chains[n].n for n in names) + 2
    chains = np.full((len(idx), len(names), longest, 3), np.nan)
    tips = np.empty((len(idx), len(names), 3))
    rots = np.empty((len(idx), len(names), 3, 3))
    for k in range(len(idx)):
        for f, name in enumerate(names):
            chain = kin.chains[name]
            _, ps, R_s, p_s = chain._frames(q[k, kin.slices[name]])
            pts = np.vstack([chain._p_base, ps, p_s]) + palm[k]
            chains[k, f, : len(pts)] = pts
            # Chains shorter than the longest repeat their tip, so every polyline has one length.
            chains[k, f, len(pts) :] = pts[-1]
            tips[k, f] = p_s + palm[k]
            rots[k, f] = R_s
    return {"idx": idx, "chains": 1000 * chains, "tips": 1000 * tips, "rots": rots, "palm": 1000 * palm}


def _forces(view: TrialView, idx: np.ndarray, rots: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    names = view.fingers
    est = np.stack([np.stack([view.cols[f"{n}_f{a}_world"][idx] for a in "xyz"], axis=1) for n in names], axis=1)
    true_cols = [[f"{n}_true_f{a}_sensor" for a in "xyz"] for n in names]
    if not all(view.has(c) for row in true_cols for c in row):
        return est, None
    true_sensor = np.stack([np.stack([view.cols[c][idx] for c in row], axis=1) for row in true_cols], axis=1)
    return est, np.einsum("kfij,kfj->kfi", rots, true_sensor)


def animate(view: TrialView, hand: HandConfig, path: Path, fps: float = 12.0, max_frames: int = MAX_FRAMES) -> Path:
    if path.suffix.lower() != ".gif":
        raise UsageError(f"--animate {path}: the replay is written as a .gif")
    if fps <= 0:
        raise UsageError("--fps: must be positive")
    if max_frames < 2:
        raise UsageError("--frames: at least 2")
    plt = pyplot()
    from matplotlib.animation import FuncAnimation, PillowWriter
    from matplotlib.patches import Rectangle

    stride = max(1, int(np.ceil(len(view.t) / max_frames)))
    fr = _frames(view, hand, stride)
    est, true = _forces(view, fr["idx"], fr["rots"])
    obj = view.obj
    size_mm = 1000 * np.array(obj.size_m if obj else (0.06, 0.06))
    height_mm = 1000 * (obj.height_m if obj else 0.1)
    obj_z = 1000 * view.cols["object_z_world"][fr["idx"]] if view.has("object_z_world") else np.zeros(len(fr["idx"]))
    states = view.states
    t = view.t

    fig, axes = plt.subplots(1, 2, figsize=(10.0, 5.4), dpi=80)
    pts = fr["chains"].reshape(-1, 3)
    arrows_end = (fr["tips"] + ARROW_MM_PER_N * est).reshape(-1, 3)
    corners = [[-size_mm[0] / 2, -size_mm[1] / 2, 0.0], [size_mm[0] / 2, size_mm[1] / 2, height_mm + obj_z.max()]]
    everything = np.vstack([pts, arrows_end, corners])
    lo, hi = np.nanmin(everything, axis=0) - 15, np.nanmax(everything, axis=0) + 15
    lo[2] = min(lo[2], -10.0)
    artists = []
    colours = [f"C{i}" for i in range(len(view.fingers))]
    for ax, (title, h) in zip(axes, VIEWS):
        ax.set_title(title, fontsize=10)
        ax.set_xlim(lo[h], hi[h])
        ax.set_ylim(lo[2], hi[2])
        ax.set_aspect("equal")
        ax.set_xlabel(f"{'xy'[h]} (mm)")
        ax.set_ylabel("z (mm)")
        ax.axhline(0.0, color="#8d6e63", lw=2.0)  # the table
        body = Rectangle((-size_mm[h] / 2, obj_z[0]), size_mm[h], height_mm, fc="#d7ccc8", ec="#6d4c41", lw=1.0)
        ax.add_patch(body)
        fingers = [
            ax.plot([], [], "-o", color=c, lw=2.0, ms=3, label=name)[0] for c, name in zip(colours, view.fingers)
        ]
        palm_dot = ax.plot([], [], "s", color="black", ms=6)[0]
        q_est = ax.quiver(
            fr["tips"][0, :, h],
            fr["tips"][0, :, 2],
            est[0, :, h],
            est[0, :, 2],
            color=colours,
            angles="xy",
            scale_units="xy",
            scale=1.0 / ARROW_MM_PER_N,
            width=0.006,
        )
        q_true = None
        if true is not None:
            q_true = ax.quiver(
                fr["tips"][0, :, h],
                fr["tips"][0, :, 2],
                true[0, :, h],
                true[0, :, 2],
                angles="xy",
                scale_units="xy",
                scale=1.0 / ARROW_MM_PER_N,
                width=0.003,
                facecolor="none",
                edgecolor="black",
                linewidth=0.8,
                linestyle="--",
            )
        artists.append((h, body, fingers, palm_dot, q_est, q_true))
    axes[0].legend(loc="upper left", fontsize=7, frameon=False)
    note = f"arrows: force on each fingertip, {ARROW_MM_PER_N:g} mm/N" + (
        " (outline: true)" if true is not None else ""
    )
    fig.text(0.5, 0.02, note, ha="center", fontsize=8)
    heading = fig.suptitle("", fontsize=10)

    def draw(k: int) -> list:
        i = fr["idx"][k]
        heading.set_text(f"{view.title()}\nt = {t[i]:.2f} s   state: {states[i]}")
        out: list = [heading]
        for h, body, fingers, palm_dot, q_est, q_true in artists:
            body.set_y(obj_z[k])
            for f, line in enumerate(fingers):
                line.set_data(fr["chains"][k, f, :, h], fr["chains"][k, f, :, 2])
            palm_dot.set_data([fr["palm"][k, h]], [fr["palm"][k, 2]])
            offsets = np.column_stack([fr["tips"][k, :, h], fr["tips"][k, :, 2]])
            q_est.set_offsets(offsets)
            q_est.set_UVC(est[k, :, h], est[k, :, 2])
            out += [body, *fingers, palm_dot, q_est]
            if q_true is not None and true is not None:
                q_true.set_offsets(offsets)
                q_true.set_UVC(true[k, :, h], true[k, :, 2])
                out.append(q_true)
        return out

    anim = FuncAnimation(fig, draw, frames=len(fr["idx"]), blit=False)
    try:
        with output_file(path) as tmp:  # a symlink at ``path`` is replaced, not followed
            # matplotlib's stub wants an int; the writer takes any rate (--fps 2.5)
            anim.save(str(tmp), writer=PillowWriter(fps=fps))  # type: ignore[arg-type]
    finally:
        plt.close(fig)
    return path
