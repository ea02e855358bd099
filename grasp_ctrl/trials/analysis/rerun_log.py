"""A trial as a Rerun recording (``plot TRIAL --rrd OUT.rrd``, ``run --rrd DIR``; the viz extra).

Written from the trial's tick log (and its record and run.json when present), on
the timeline ``time`` (s of simulated time), world frame in metres, z up:

- ``world/table`` (a thin box at z = 0) and ``world/object``: the object's body
  (box or cylinder from its profile) whose pose over time is its logged height
  above the table, centred on the world origin where it is placed (the mock's and
  MuJoCo's few-mm placement jitter and tilt are not logged);
- ``world/hand/palm`` and ``world/hand/FINGER``: each finger's links as a line
  through its joint origins to the fingertip sensor, by forward kinematics of
  the logged joint angles on the trial's hand (the same on MuJoCo: the log holds
  the joint angles its bodies took), the palm where logged;
- ``world/forces/FINGER/estimated`` and ``.../true`` (the true force on the mock
  and MuJoCo): the force on each fingertip as an arrow at the sensor,
  ``ARROW_M_PER_N`` long per newton, in the world frame;
- ``controller/state``: a text log line at each state change (the fault, with its
  reason, as an error) and the world's events (contacts, crush, fall);
- ``signals/grip/FINGER``, ``signals/tau`` (the grip target), ``signals/release``
  (the release fingertip's force on the object along +z, ``-f_world_z``) and
  ``signals/release_threshold``, ``signals/object_z``: time series.

Open with ``rerun OUT.rrd``; ``rerun rrd verify OUT.rrd`` checks a file.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import check_output_dir, destination, output_file
from grasp_ctrl.trials.analysis.trial_view import TrialView

ARROW_M_PER_N = 0.015
TIMELINE = "time"
COLOURS = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189), (140, 86, 75)]
TABLE_HALF_M = (0.15, 0.15, 0.002)


def require_rerun() -> Any:
    try:
        import rerun as rr
    except ImportError:
        raise UsageError("Rerun recordings need rerun-sdk: pip install -e '.[viz]'") from None
    return rr


def _hand_frames(view: TrialView, hand: HandConfig) -> dict[str, np.ndarray]:
    """Per tick: each finger's polyline (T, P, 3), its sensor origin (T, 3) and rotation (T, 3, 3), m."""
    from grasp_ctrl.kinematics.chain import HandKinematics

    kin = HandKinematics(hand)
    n_ticks = len(view.t)
    q = np.stack([view.cols[f"q{j}"] for j in range(len(hand.joints))], axis=1).astype(float)
    palm = np.stack([view.cols[f"palm_{a}_world"] for a in "xyz"], axis=1).astype(float)
    out: dict[str, np.ndarray] = {"palm": palm}
    for name in view.fingers:
        chain = kin.chains[name]
        lines = np.empty((n_ticks, chain.n + 2, 3))
        tips = np.empty((n_ticks, 3))
        rots = np.empty((n_ticks, 3, 3))
        for k in range(n_ticks):
            _, ps, R_s, p_s = chain._frames(q[k, kin.slices[name]])
            lines[k] = np.vstack([chain._p_base, ps, p_s]) + palm[k]
            tips[k] = p_s + palm[k]
            rots[k] = R_s
        out[f"{name}/lines"], out[f"{name}/tip"], out[f"{name}/rot"] = lines, tips, rots
    return out


def _vec(view: TrialView, name: str, kind: str) -> np.ndarray | None:
    cols = [f"{name}_{kind}f{a}_{'world' if kind == '' else 'sensor'}" for a in "xyz"]
    if not all(view.has(c) for c in cols):
        return None
    return np.stack([view.cols[c] for c in cols], axis=1).astype(float)


def write_recording(view: TrialView, hand: HandConfig, path: Path, *, follow: bool = False) -> Path:
    """The trial's recording at ``path`` (a .rrd file). ``follow``: the viewer opens at the last
    tick (else it plays the lift and hold in a loop)."""
    rr = require_rerun()
    if path.suffix.lower() != ".rrd" and not destination(path, "--rrd").is_stream:
        raise UsageError(f"--rrd {path}: a Rerun recording is written as a .rrd file")
    with output_file(path) as tmp:  # a symlink at ``path`` is replaced, not followed; a stream gets the bytes
        _record(rr, view, hand, tmp, follow)
    return path


def _record(rr: Any, view: TrialView, hand: HandConfig, path: Path, follow: bool) -> None:
    rec_meta = view.record or {}
    app = "grasp_ctrl"
    rec = rr.RecordingStream(app, recording_id=f"{rec_meta.get('policy', '')}-{view.ticks_path.stem}")
    rec.save(str(path), default_blueprint=_blueprint(view, follow))
    t = view.t.astype(float)
    times = [rr.TimeColumn(TIMELINE, duration=t)]
    frames = _hand_frames(view, hand)

    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    rec.log(
        "world/table",
        rr.Boxes3D(
            centers=[[0.0, 0.0, -TABLE_HALF_M[2]]],
            half_sizes=[TABLE_HALF_M],
            colors=[(141, 110, 99)],
            fill_mode="solid",
        ),
        static=True,
    )
    _log_object(rr, rec, view, times)
    rec.send_columns(
        "world/hand/palm",
        indexes=times,
        columns=rr.Points3D.columns(positions=frames["palm"], radii=np.full(len(t), 0.006)),
    )
    for f, name in enumerate(view.fingers):
        colour = COLOURS[f % len(COLOURS)]
        rec.log(f"world/hand/{name}", rr.LineStrips3D.from_fields(colors=[colour], radii=[0.003]), static=True)
        rec.send_columns(
            f"world/hand/{name}", indexes=times, columns=rr.LineStrips3D.columns(strips=list(frames[f"{name}/lines"]))
        )
        tips = frames[f"{name}/tip"]
        est = _vec(view, name, "")
        if est is not None:
            rec.log(
                f"world/forces/{name}/estimated", rr.Arrows3D.from_fields(colors=[colour], radii=[0.0025]), static=True
            )
            rec.send_columns(
                f"world/forces/{name}/estimated",
                indexes=times,
                columns=rr.Arrows3D.columns(vectors=ARROW_M_PER_N * est, origins=tips),
            )
        true_sensor = _vec(view, name, "true_")
        if true_sensor is not None:
            true_world = np.einsum("kij,kj->ki", frames[f"{name}/rot"], true_sensor)
            rec.log(
                f"world/forces/{name}/true", rr.Arrows3D.from_fields(colors=[(60, 60, 60)], radii=[0.0008]), static=True
            )
            rec.send_columns(
                f"world/forces/{name}/true",
                indexes=times,
                columns=rr.Arrows3D.columns(vectors=ARROW_M_PER_N * true_world, origins=tips),
            )
    _log_signals(rr, rec, view, times)
    _log_states(rr, rec, view)
    rec.flush()
    rec.disconnect()


def _blueprint(view: TrialView, follow: bool = False) -> Any:
    """The layout a recording opens with: the 3D scene beside the grips with tau, the release
    signal with its threshold and the controller's log; played in a loop over the lift and hold."""
    import rerun.blueprint as rrb

    views = rrb.Horizontal(
        rrb.Spatial3DView(
            origin="world",
            name="hand, object, forces",
            eye_controls=rrb.EyeControls3D(position=[0.36, -0.34, 0.32], look_target=[0.0, 0.0, 0.12]),
        ),
        rrb.Vertical(
            rrb.TimeSeriesView(origin="signals", contents=["$origin/grip/**", "$origin/tau"], name="grip and tau (N)"),
            rrb.TimeSeriesView(
                origin="signals", contents=["$origin/release", "$origin/release_threshold"], name="release signal (N)"
            ),
            rrb.TextLogView(origin="controller", name="controller"),
        ),
        column_shares=[3, 2],
    )
    panel: dict[str, Any] = {"timeline": TIMELINE}
    entered = {dst: float(t) for t, _src, dst in reversed((view.record or {}).get("transitions", []))}
    if follow:
        panel["play_state"] = "following"
    elif "lift" in entered:
        import rerun as rr

        start = entered["lift"]
        end = entered.get("lower", start + 2.0)
        panel.update(
            time_selection=rr.encodings.AbsoluteTimeRange(int(start * 1e9), int(end * 1e9)),
            loop_mode="selection",
            play_state="playing",
        )
    return rrb.Blueprint(views, rrb.TimePanel(**panel), collapse_panels=True)


def _log_object(rr: Any, rec: Any, view: TrialView, times: list) -> None:
    obj = view.obj
    size = np.array(obj.size_m if obj else (0.06, 0.06), dtype=float)
    height = float(obj.height_m if obj else 0.1)
    colour = (215, 204, 200)
    if obj is not None and obj.shape == "cylinder":
        body = rr.Cylinders3D(lengths=[height], radii=[size[0] / 2], colors=[colour], fill_mode="solid")
    else:
        body = rr.Boxes3D(half_sizes=[[size[0] / 2, size[1] / 2, height / 2]], colors=[colour], fill_mode="solid")
    rec.log("world/object", body, static=True)
    z = view.cols["object_z_world"].astype(float) if view.has("object_z_world") else np.zeros(len(view.t))
    centre = np.column_stack([np.zeros_like(z), np.zeros_like(z), z + height / 2])
    rec.send_columns("world/object", indexes=times, columns=rr.Transform3D.columns(translation=centre))


def _log_signals(rr: Any, rec: Any, view: TrialView, times: list) -> None:
    def series(entity: str, values: np.ndarray, name: str) -> None:
        rec.log(entity, rr.SeriesLines(names=[name]), static=True)
        rec.send_columns(entity, indexes=times, columns=rr.Scalars.columns(scalars=values.astype(float)))

    for name in view.grasp_fingers():
        if view.has(f"{name}_grip_n"):
            series(f"signals/grip/{name}", view.cols[f"{name}_grip_n"], f"grip {name} (N)")
    if view.has("grip_target_n"):
        series("signals/tau", view.cols["grip_target_n"], "tau: grip target (N)")
    release = view.release_finger()
    if view.has(f"{release}_fz_world"):
        series("signals/release", -view.cols[f"{release}_fz_world"], f"release signal -f_world_z {release} (N)")
        threshold = view.setting("release_threshold_n")
        if threshold is not None:
            series("signals/release_threshold", np.full(len(view.t), -threshold), "-release_threshold_n (N)")
    if view.has("object_z_world"):
        series("signals/object_z", view.cols["object_z_world"], "object height (m)")


def _log_states(rr: Any, rec: Any, view: TrialView) -> None:
    states = view.states
    t = view.t
    rec_meta = view.record or {}
    reason = (rec_meta.get("controller") or {}).get("reason") or rec_meta.get("reason")
    for i, s in enumerate(states):
        if i and s == states[i - 1]:
            continue
        rec.set_time(TIMELINE, duration=float(t[i]))
        text, level = f"state: {s}", rr.TextLogLevel.INFO
        if s == "fault":
            text, level = f"state: fault ({reason})", rr.TextLogLevel.ERROR
        rec.log("controller/state", rr.TextLog(text, level=level))
    for event in rec_meta.get("events", []):
        rec.set_time(TIMELINE, duration=float(event.get("t", 0.0)))
        rec.log(
            "controller/events",
            rr.TextLog(f"{event.get('kind')}: {event.get('detail', '')}", level=rr.TextLogLevel.WARN),
        )
    if rec_meta:
        rec.set_time(TIMELINE, duration=float(t[-1]))
        rec.log(
            "controller/outcome",
            rr.TextLog(view.title(), level=rr.TextLogLevel.INFO if rec_meta.get("success") else rr.TextLogLevel.ERROR),
        )


def record_run(run_dir: Path, out_dir: Path) -> list[Path]:
    """A recording of every trial with a tick log in ``run_dir``: OUT_DIR/POLICY/OBJECT/trial_NNN.rrd."""
    from grasp_ctrl.loop.ticklog import TICKS_SUFFIX
    from grasp_ctrl.trials.analysis.trial_view import hand_for_replay, load_trial, print_notes

    written = []
    for ticks in sorted((run_dir / "trials").glob(f"*/*/*{TICKS_SUFFIX}")):
        view = load_trial(ticks)
        print_notes(view.notes)  # the run's own command prints only the count
        hand = hand_for_replay(view, None)
        rel = ticks.relative_to(run_dir / "trials")
        out = out_dir / rel.parent / (ticks.name[: -len(TICKS_SUFFIX)] + ".rrd")
        written.append(write_recording(view, hand, out))
    return written


def check_run_rrd(out_dir: str, tick_logs: bool) -> None:
    """``run --rrd DIR`` before any trial: the extra is there and the trials keep tick logs."""
    require_rerun()
    check_output_dir(out_dir, "--rrd")
    if not tick_logs:
        raise UsageError("--rrd: the recordings are made from the tick logs; drop --no-tick-logs")
    if Path(out_dir).exists() and not Path(out_dir).is_dir():
        raise UsageError(f"--rrd {out_dir}: not a folder")
