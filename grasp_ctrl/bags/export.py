"""Trials and tactile recordings as ROS 2 bags (``export-bag``, ``run --mcap``).

A trial's bag holds the topics of ``trial_messages`` (docs/ros_bags.md); a recording's
(``sensors --record``) its frames as ``biotac_sensors/BioTacHand`` on ``/biotac_pub``, at
their receive times. A run's trials go to OUT_DIR/POLICY/OBJECT/trial_NNN.mcap.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from grasp_ctrl.bags import require_ros, topics
from grasp_ctrl.bags.writer import SUFFIX, check_bag_path, write_bag
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import check_new_file, check_output, check_output_dir

if TYPE_CHECKING:
    from grasp_ctrl.trials.analysis.trial_view import TrialView

NO_FRAMES_NOTE = (
    f"the tick log keeps a summary of each raw tactile frame, not the frame: no {topics.BIOTAC} in the bag "
    "(a run keeps the frames with --raw-frames or --mcap)"
)


@dataclass(frozen=True)
class Written:
    path: Path
    counts: Counter[str]  # messages per topic
    t0_s: float
    t1_s: float
    notes: tuple[str, ...] = ()

    def line(self) -> str:
        n = sum(self.counts.values())
        return f"bag: {self.path}: {n} messages on {len(self.counts)} topics, {self.t0_s:.3f} .. {self.t1_s:.3f} s"


def export_trial(trial: Path, out: Path, hand_file: Path | None = None, incomplete_ok: bool = False) -> Written:
    """The trial named by its record or tick log as a bag at ``out``. A trial whose record is
    unreadable, or whose hand is not known to be the one it ran with (and ``hand_file`` does
    not name it), is refused unless ``incomplete_ok`` (``export-bag --force``); then the
    notes say what the bag lacks."""
    from grasp_ctrl.bags.trial_messages import has_raw_frames, tick_times_ns, trial_messages
    from grasp_ctrl.trials.analysis.trial_view import hand_for_replay, load_trial

    require_ros()
    check_bag_path(out, "--out")
    view = load_trial(trial)
    if not incomplete_ok:
        check_sources(view, hand_file)
    if not len(view.t):
        raise UsageError(f"{view.ticks_path}: a tick log with no ticks")
    hand = hand_for_replay(view, hand_file)
    t_ns = tick_times_ns(view)
    if int(t_ns.min()) < 0:
        raise UsageError(f"{view.ticks_path}: times before 0 s; a bag's clock starts at 0")
    rec = view.record or {}
    meta = {"source": str(view.ticks_path), "trial": view.title(), "hand": hand.name}
    meta.update({k: str(rec[k]) for k in ("policy", "object", "trial", "seed", "backend") if k in rec})
    counts = write_bag(out, trial_messages(view, hand), meta)
    notes = [*view.notes, *_lacks(view, hand_file, out)]
    if not has_raw_frames(view):
        notes.append(NO_FRAMES_NOTE)
    return Written(out, counts, float(view.t[0]), float(view.t[-1]), tuple(notes))


def check_sources(view: TrialView, hand_file: Path | None) -> None:
    """A trial whose bag would silently lack its record, or carry a /tf from a hand it may not
    have run with, is refused on one line saying why and what to do."""
    from grasp_ctrl.trials.analysis.trial_view import replay_hand_file

    if view.record_problem:
        raise UsageError(
            f"{view.record_problem}; its bag would have no {topics.TRIAL_EVENTS} and no policy, object or seed: "
            "'export-bag --force' exports it without them"
        )
    if view.hand_problem and hand_file is None:
        raise UsageError(
            f"{view.hand_problem}; the bag's {topics.TF} would come from {replay_hand_file(view, None)}: "
            "give the trial's hand with 'export-bag --hand FILE', or 'export-bag --force' to use that one"
        )


def _lacks(view: TrialView, hand_file: Path | None, out: Path) -> list[str]:
    """What the bag at ``out`` lacks because a source was unreadable or unverified (``--force``)."""
    from grasp_ctrl.trials.analysis.trial_view import replay_hand_file

    lacks = []
    if view.record_problem:
        lacks.append(
            f"{out}: exported without its record: no {topics.TRIAL_EVENTS}, no policy, object, trial, seed or "
            f"backend in its metadata, and {topics.CONTROLLER_TRANSITIONS} at the tick log's state changes"
        )
    if view.hand_problem and hand_file is None:
        lacks.append(f"{out}: {topics.TF} from {replay_hand_file(view, None)}, not known to be the trial's hand")
    return lacks


def export_recording(path: Path, out: Path, hand_id: str = "") -> Written:
    """A tactile recording's frames as ``BioTacHand`` messages at ``out``."""
    from grasp_ctrl.bags.messages import recording_messages
    from grasp_ctrl.bags.recording import read_recording, seconds

    require_ros()
    check_bag_path(out, "--out")
    rec = read_recording(path)
    if int(rec.t_ns.min()) < 0:
        raise UsageError(f"{path}: receive times before 0 s; a bag's clock starts at 0")
    msgs = recording_messages(rec.t_ns, rec.finger, rec.values, hand_id)
    counts = write_bag(out, msgs, {"source": str(path)})
    return Written(out, counts, seconds(int(rec.t_ns.min())), seconds(int(rec.t_ns.max())))


def run_trials(run_dir: Path) -> list[Path]:
    """The tick logs of a run directory's trials, in order."""
    from grasp_ctrl.loop.ticklog import LEGACY_TICKS_SUFFIX, TICKS_SUFFIX

    found = sorted((run_dir / "trials").glob(f"*/*/*{TICKS_SUFFIX}"))
    legacy = sorted((run_dir / "trials").glob(f"*/*/*{LEGACY_TICKS_SUFFIX}"))
    have = {p.name[: -len(TICKS_SUFFIX)] for p in found}
    return found + [p for p in legacy if p.name[: -len(LEGACY_TICKS_SUFFIX)] not in have]


def bag_path(run_dir: Path, ticks: Path, out_dir: Path) -> Path:
    """OUT_DIR/POLICY/OBJECT/trial_NNN.mcap of a trial's tick log."""
    stem = ticks.name.rsplit("_ticks.", 1)[0]
    return out_dir / ticks.relative_to(run_dir / "trials").parent / f"{stem}{SUFFIX}"


def export_run(
    run_dir: Path,
    out_dir: Path,
    hand_file: Path | None = None,
    force: bool = True,
    flag: str = "--out",
    incomplete_ok: bool = False,
) -> list[Written]:
    """One bag per trial with a tick log; without ``force`` an existing bag, and without
    ``incomplete_ok`` a trial that ``check_sources`` refuses, stops it before any is written.
    ``flag``: the option that named ``out_dir``, for the errors."""
    require_ros()
    check_output_dir(out_dir, flag)
    if out_dir.exists() and not out_dir.is_dir():
        raise UsageError(f"{flag} {out_dir}: not a folder")
    logs = run_trials(run_dir)
    if not logs:
        raise UsageError(f"{run_dir}: no trial with a tick log (was the run made with --no-tick-logs?)")
    targets = [bag_path(run_dir, ticks, out_dir) for ticks in logs]
    for target in targets:
        check_output(target, flag, run_dirs=[run_dir])
        if not force and target.exists():
            raise UsageError(f"{flag}: {target} exists (use --force to overwrite)")
    if not incomplete_ok:
        from grasp_ctrl.trials.analysis.trial_view import load_trial

        for ticks in logs:
            check_sources(load_trial(ticks, tick_log=False), hand_file)
    return [export_trial(ticks, target, hand_file, incomplete_ok) for ticks, target in zip(logs, targets)]


def check_run_mcap(out_dir: str, tick_logs: bool) -> None:
    """``run --mcap DIR`` before any trial: the extra is there and the trials keep tick logs."""
    require_ros()
    check_output_dir(out_dir, "--mcap")
    if not tick_logs:
        raise UsageError("--mcap: the bags are made from the tick logs; drop --no-tick-logs")
    if Path(out_dir).exists() and not Path(out_dir).is_dir():
        raise UsageError(f"--mcap {out_dir}: not a folder")


def check_bag_out(out: Path, force: bool) -> None:
    """``export-bag --out FILE``: an .mcap file (or a stream), not one a run manages; replaced only with --force."""
    check_output(out, "--out")
    check_bag_path(out, "--out")
    check_new_file(out, "--out", force)
