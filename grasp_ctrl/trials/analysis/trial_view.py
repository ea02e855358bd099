"""One trial's files gathered for looking at it: tick log, record, hand, object.

A trial is named by its ``trial_NNN.json`` record or its tick log; the record
(outcome, transitions, world events, settings) and the run's ``run.json`` (hand
file and object profiles) are read when present, so a tick log on its own can
still be plotted (the replay needs the hand). What could not be loaded, or cannot
be trusted (a record cut short, a run.json that does not read, a hand file edited
since the run), is a note in ``TrialView.notes``: every command that loads a trial
prints them (:func:`print_notes`), and ``record_problem`` / ``hand_problem`` say it
for the commands that refuse such a trial (``export-bag`` without ``--force``).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.errors import UsageError
from grasp_ctrl.loop.ticklog import LEGACY_TICKS_SUFFIX, TICKS_SUFFIX, read_tick_log

if TYPE_CHECKING:
    from grasp_ctrl.trials.runs.manifest import RunManifest


@dataclass
class TrialView:
    ticks_path: Path
    columns: list[str]
    cols: dict[str, np.ndarray]
    record: dict[str, Any] | None = None
    hand: HandConfig | None = None
    obj: ObjectProfile | None = None
    notes: list[str] = field(default_factory=list)  # what could not be loaded, and why
    record_file: Path | None = None
    record_problem: str | None = None  # the record exists but cannot be used: why (also a note)
    hand_file: Path | None = None  # the file ``hand`` came from (None: no hand loaded)
    hand_problem: str | None = None  # why ``hand`` (or, without one, the default) may not be the trial's

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
        settings = (self.record or {}).get("settings")
        value = settings.get(name) if isinstance(settings, dict) else None
        if isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value):
            return float(value)  # (a non-finite value is written as null: storage.write_json)
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


def load_trial(trial: Path, tick_log: bool = True) -> TrialView:
    """The trial's tick log, record, object profile and hand, and notes on what could not be
    loaded or trusted. ``tick_log=False``: all but the tick log (no columns), to check a
    trial's other files before any work."""
    ticks, record_file = trial_paths(Path(trial))
    columns, cols = read_tick_log(ticks) if tick_log else ([], {})
    view = TrialView(ticks, columns, cols, record_file=record_file)
    _read_record(view, record_file)
    run_dir = ticks.parent.parent.parent.parent  # RUN_DIR/trials/POLICY/OBJECT/trial_NNN...
    manifest, why_none = _read_manifest(run_dir, ticks)
    if manifest is not None:
        obj_name = view.record["object"] if view.record else ticks.parent.name
        view.obj = next((o for o in manifest.objects if o.name == obj_name), None)
    _read_hand(view, run_dir, manifest, why_none)
    return view


def _read_record(view: TrialView, record_file: Path) -> None:
    from grasp_ctrl.trials.runs.records import read_record

    if not record_file.is_file():
        view.notes.append(f"{record_file}: no such file; the trial's outcome, settings and world events are unknown")
        return
    rec, why = read_record(record_file)
    if rec is None:
        view.record_problem = f"{record_file}: unreadable record ({why})"
        view.notes.append(view.record_problem)
    view.record = rec


def _read_manifest(run_dir: Path, ticks: Path) -> tuple[RunManifest | None, str]:
    """The run's run.json, or None and why there is none to go by (unreadable, or no run)."""
    from grasp_ctrl.trials.runs.manifest import read_manifest

    try:
        manifest = read_manifest(run_dir)
    except UsageError as exc:
        return None, str(exc)
    if manifest is None:
        return None, f"{ticks}: not in a run directory (no {run_dir / 'run.json'})"
    return manifest, ""


def _read_hand(view: TrialView, run_dir: Path, manifest: RunManifest | None, why_none: str) -> None:
    """The hand file run.json names, loaded, and checked as ``run --resume`` checks it (the
    hash the run recorded, the hand's name): what fails is ``hand_problem`` and a note."""
    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.files.paths import default_hand_file
    from grasp_ctrl.trials.runs.fingerprint import hand_changes

    if manifest is None:
        view.hand_problem = f"{why_none}; the hand the trial ran with is unknown"
        view.notes.append(view.hand_problem)
        return
    run_file = run_dir / "run.json"
    path = Path(manifest.hand_file) if manifest.hand_file else default_hand_file()
    if not path.is_file():
        view.hand_problem = f"the run's hand file {path} ({run_file}: hand_file) is gone"
    else:
        try:
            view.hand, view.hand_file = load_hand(path), path
        except Exception as exc:  # a hand file edited since: plot without it
            view.hand_problem = f"{path}: {exc}"
    changed = hand_changes(manifest) if view.hand is not None else []
    if changed:
        view.hand_problem = (
            f"{'; '.join(changed)} since the run started (its SHA-256 is not the one {run_file} recorded)"
        )
    elif view.hand is not None and view.hand.name != manifest.hand:
        view.hand_problem = f"{path} describes hand {view.hand.name!r}, the run used {manifest.hand!r} ({run_file})"
    if view.hand_problem:
        view.notes.append(view.hand_problem)


def print_notes(notes: list[str], stream: TextIO | None = None) -> None:
    """Each note once, as ``note: ...`` on stderr (a command's output may be on stdout)."""
    for note in dict.fromkeys(notes):
        print(f"note: {note}", file=stream or sys.stderr)


def replay_hand_file(view: TrialView, hand_file: Path | None) -> Path:
    """The hand file a replay or a bag draws the hand from: ``--hand``, else run.json's, else
    (when neither loads) the default one."""
    from grasp_ctrl.files.paths import default_hand_file

    if hand_file:
        return Path(hand_file)
    return view.hand_file if view.hand is not None and view.hand_file else default_hand_file()


def hand_for_replay(view: TrialView, hand_file: Path | None) -> HandConfig:
    """The hand the trial ran on (``--hand`` overrides run.json's); its joints must match the log's."""
    from grasp_ctrl.config.hand import load_hand

    hand = view.hand if not hand_file and view.hand is not None else load_hand(replay_hand_file(view, hand_file))
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
