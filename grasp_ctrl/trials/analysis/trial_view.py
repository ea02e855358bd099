"""One trial's files gathered for looking at it: tick log, record, hand, object.

A trial is named by its ``trial_NNN.json`` record or its tick log; the record
(outcome, transitions, world events, settings) and the run's ``run.json`` (hand
file and object profiles) are read when present, so a tick log on its own can
still be plotted (the replay needs the hand).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.errors import UsageError
from grasp_ctrl.loop.ticklog import LEGACY_TICKS_SUFFIX, TICKS_SUFFIX, read_tick_log


@dataclass
class TrialView:
    ticks_path: Path
    columns: list[str]
    cols: dict[str, np.ndarray]
    record: dict[str, Any] | None = None
    hand: HandConfig | None = None
    obj: ObjectProfile | None = None
    notes: list[str] = field(default_factory=list)  # what could not be loaded, and why

    @property
    def t(self) -> np.ndarray:
        return self.cols["t"]

    @property
    def states(self) -> list[str]:
        return [str(s) for s in self.cols["state"]]

    @property
    def fingers(self) -> list[str]:
        suffix = "_fx_sensor"
        return [c[: -len(suffix)] for c in self.columns if c.endswith(suffix) and "_true_" not in c]

    def has(self, column: str) -> bool:
        return column in self.cols

    def grasp_fingers(self) -> list[str]:
        if self.hand is not None:
            return [f.name for f in self.hand.fingers if f.grasp and f.name in self.fingers]
        return self.fingers

    def release_finger(self) -> str:
        name = self.hand.grasp.release_finger if self.hand is not None else "index"
        return name if name in self.fingers else self.fingers[0]

    def setting(self, name: str) -> float | None:
        if self.record and name in self.record.get("settings", {}):
            return float(self.record["settings"][name])
        if self.obj is not None and hasattr(self.obj, name):
            return float(getattr(self.obj, name))
        return None

    def title(self) -> str:
        rec = self.record
        if not rec:
            return self.ticks_path.name
        outcome = "success" if rec.get("success") else f"failed: {rec.get('reason')}"
        return (
            f"{rec.get('policy')} / {rec.get('object')} / trial {rec.get('trial')} (seed {rec.get('seed')}): {outcome}"
        )

    def end_event(self) -> tuple[float, str] | None:
        """(time, label) of the controller reaching done or fault."""
        rec = self.record
        if rec:
            for t, _src, dst in reversed(rec.get("transitions", [])):
                if dst in ("done", "fault"):
                    reason = rec.get("controller", {}).get("reason") or rec.get("reason")
                    return float(t), "done" if dst == "done" else f"fault: {reason}"
        states = self.states
        for i, s in enumerate(states):
            if s in ("done", "fault"):
                return float(self.t[i]), s
        return None


def trial_paths(trial: Path) -> tuple[Path, Path]:
    """(tick log, record) of a trial named by either file."""
    name = trial.name
    for suffix in (TICKS_SUFFIX, LEGACY_TICKS_SUFFIX, ".json"):
        if name.endswith(suffix):
            stem = name[: -len(suffix)]
            break
    else:
        raise UsageError(f"{trial}: give a trial_NNN.json or trial_NNN{TICKS_SUFFIX}")
    ticks = trial.with_name(f"{stem}{TICKS_SUFFIX}")
    if not ticks.is_file() and trial.with_name(f"{stem}{LEGACY_TICKS_SUFFIX}").is_file():
        ticks = trial.with_name(f"{stem}{LEGACY_TICKS_SUFFIX}")
    if not ticks.is_file():
        raise UsageError(f"{ticks}: no tick log (was the run made with --no-tick-logs?)")
    return ticks, trial.with_name(f"{stem}.json")


def load_trial(trial: Path) -> TrialView:
    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.trials.runs.manifest import read_manifest
    from grasp_ctrl.trials.runs.records import read_record

    ticks, record_file = trial_paths(Path(trial))
    columns, cols = read_tick_log(ticks)
    view = TrialView(ticks, columns, cols)
    if record_file.is_file():
        rec, why = read_record(record_file)
        if rec is None:
            view.notes.append(f"{record_file}: {why}")
        view.record = rec
    run_dir = ticks.parent.parent.parent.parent  # RUN_DIR/trials/POLICY/OBJECT/trial_NNN...
    try:
        manifest = read_manifest(run_dir)
    except UsageError as exc:
        manifest = None
        view.notes.append(str(exc))
    if manifest is not None:
        obj_name = view.record["object"] if view.record else ticks.parent.name
        view.obj = next((o for o in manifest.objects if o.name == obj_name), None)
        if manifest.hand_file and Path(manifest.hand_file).is_file():
            try:
                view.hand = load_hand(Path(manifest.hand_file))
            except Exception as exc:  # a hand file edited since: plot without it
                view.notes.append(f"{manifest.hand_file}: {exc}")
    return view


def hand_for_replay(view: TrialView, hand_file: Path | None) -> HandConfig:
    """The hand the trial ran on (``--hand`` overrides run.json's); its joints must match the log's."""
    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.files.paths import default_hand_file

    hand = load_hand(hand_file) if hand_file else (view.hand or load_hand(default_hand_file()))
    n_logged = sum(1 for c in view.columns if c.startswith("q") and c[1:].isdigit())
    if len(hand.joints) != n_logged:
        raise UsageError(
            f"{view.ticks_path}: logged {n_logged} joints, hand {hand.name!r} has "
            f"{len(hand.joints)}; give the trial's hand with --hand"
        )
    missing = [f for f in view.fingers if f not in {g.name for g in hand.fingers}]
    if missing:
        raise UsageError(
            f"{view.ticks_path}: fingertip {missing[0]!r} is not in hand {hand.name!r}; "
            f"give the trial's hand with --hand"
        )
    return hand
