"""A series of trials: objects x policies x trials with shared seeds, in this process, in
worker processes (``jobs``) or as Ray tasks, with the run directory's lock, resume and summary
(docs/design.md 5.2). One trial is trials/episode/runner.py's.

A series writes ``run.json`` first, then one fsynced record per finished trial, so an
interrupted series loses at most the trial in progress and ``run_series(..., resume=True)``
continues it. A trial in progress in this process that Ctrl-C or SIGTERM ends (a hand's, a
realtime dry run's: ``aborted``, naming the interrupt) leaves its record as
``trial_NNN.interrupted.json`` beside the records: no finished trial, so resume runs it again.
"""

from __future__ import annotations

import contextlib
import errno
import itertools
import os
import shutil
import sys
from collections.abc import Callable, Generator, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl.config.checks import check_objects_for_hand
from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.registry import default_settings, make_controller
from grasp_ctrl.errors import ConfigError, UsageError, interrupts_held
from grasp_ctrl.files.storage import (
    RUN_FILE,
    SUMMARY_FILE,
    check_object_name,
    commit_temp,
    interrupted_path,
    is_temp_file,
    record_path,
    safe_name,
    temp_path,
    ticks_path,
    write_json,
)
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.rigs.registry import DEFAULT_BACKEND
from grasp_ctrl.sim.mujoco.log import set_log_dir as set_engine_log_dir
from grasp_ctrl.sim.variation import NOMINAL, Variation
from grasp_ctrl.trials.episode.runner import TrialFn, TrialSetup, interrupted_record, trial_seed
from grasp_ctrl.trials.runs.fingerprint import stamp, sync_manifest
from grasp_ctrl.trials.runs.manifest import RunManifest, read_manifest
from grasp_ctrl.trials.runs.planned import why_unplanned
from grasp_ctrl.trials.runs.progress import Progress
from grasp_ctrl.trials.runs.records import canonical_order, load_records, record_files
from grasp_ctrl.trials.runs.runlock import RunLock
from grasp_ctrl.trials.runs.summary import summarize
from grasp_ctrl.trials.runs.workers import WorkerError, ignore_interrupts, worker_deaths_as_errors

# Worker-process side of ``run_series(jobs=N)``: each worker loads the policies once.
_WORKER_TRIAL_FN: TrialFn | None = None


def _init_worker(setup: TrialSetup) -> None:
    global _WORKER_TRIAL_FN
    ignore_interrupts()
    _WORKER_TRIAL_FN = setup.trial_fn()


def _worker_trial(policy: str, obj: ObjectProfile, trial: int, seed: int, log_path: Path | None) -> dict[str, Any]:
    assert _WORKER_TRIAL_FN is not None
    return _WORKER_TRIAL_FN(policy, obj, trial, seed, log_path)


TrialTask = tuple[str, ObjectProfile, int, int, "Path | None"]  # policy, object, trial, seed, tick log


def run_setup(hand: HandConfig, plan: RunManifest, threads: int, policies: Sequence[str] | None = None) -> TrialSetup:
    """The trial setup of a run (its policies, settings, backend, variation, raw frames and
    clock from ``plan``; ``policies``: those instead of the plan's)."""
    return TrialSetup(
        hand,
        tuple(plan.policies if policies is None else policies),
        plan.settings,
        threads,
        backend=plan.backend,
        variation=plan.variation,
        raw_frames=plan.raw_frames,
        realtime=plan.realtime,
    )


def parallel_trials(
    jobs: int, setup: TrialSetup, tasks: Sequence[TrialTask]
) -> Generator[tuple[int, dict[str, Any]], None, None]:
    """Simulated trials of ``setup`` in ``jobs`` processes: yields (task index, record) as each finishes."""
    from concurrent.futures import FIRST_COMPLETED, wait

    from grasp_ctrl.trials.runs.process_cleanup import spawn_guard
    from grasp_ctrl.trials.runs.workers import start_pool

    pool = start_pool(jobs, _init_worker, (setup,))
    finished_cleanly = False
    try:
        todo = iter(enumerate(tasks))
        running: dict[Any, int] = {}

        def submit(i: int, task: TrialTask) -> None:
            # a submit may start a worker (process_cleanup.spawn_guard)
            with spawn_guard(), worker_deaths_as_errors():
                running[pool.submit(_worker_trial, *task)] = i

        for i, task in itertools.islice(todo, 2 * jobs):  # a short queue: Ctrl-C loses little
            submit(i, task)
        while running:
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for fut in finished:
                i = running.pop(fut)
                log = tasks[i][4]
                with worker_deaths_as_errors(), naming_file(log and final_name(log), True):
                    rec = fut.result()
                yield i, rec
                nxt = next(todo, None)
                if nxt is not None:
                    submit(*nxt)
        finished_cleanly = True
    finally:
        if finished_cleanly:
            try:
                pool.shutdown(wait=True)
            except BaseException:  # Ctrl-C while the workers finish: they are stopped
                _stop_workers(pool)
                raise
        else:
            _stop_workers(pool)


def _stop_workers(pool: Any) -> None:
    """After Ctrl-C or an error: the trials in progress are abandoned (they run again on
    resume), so the workers are stopped now rather than waited for, and with them the fork
    server, a worker it forked that the pool never recorded (a start cut short) and the
    resource tracker; each is reaped before this returns (process_cleanup.abort_pool)."""
    from grasp_ctrl.trials.runs.process_cleanup import abort_pool

    abort_pool(pool)


_KEPT_ATTR = "interrupted_path"


def keep_interrupted(run_dir: Path, exc: KeyboardInterrupt, plan: RunManifest) -> None:
    """The record an interrupt carries (the trial it ended), written beside the records; its
    path noted on the interrupt (``kept_interrupted``) for the command's last line."""
    rec = interrupted_record(exc)
    if rec is None:
        return
    try:
        path = interrupted_path(run_dir, rec["policy"], rec["object"], int(rec["trial"]))
        with interrupts_held(reraise=False):  # a second Ctrl-C does not cut the write short
            write_json(path, stamp(rec, plan))
    except (OSError, KeyError, TypeError, ValueError):
        return  # the interrupt, not a failed note of it, is what the command reports
    setattr(exc, _KEPT_ATTR, path)


def kept_interrupted(exc: BaseException) -> Path | None:
    """Where ``keep_interrupted`` wrote the record of the trial ``exc`` ended, if it did."""
    path = getattr(exc, _KEPT_ATTR, None)
    return path if isinstance(path, Path) else None


def _warn(msg: str) -> None:
    print(f"warning: {msg}", file=sys.stderr, flush=True)


DISK_FULL = frozenset({errno.ENOSPC, errno.EDQUOT})


def resume_hint(run_dir: Path, done: int, total: int) -> str:
    """What a stopped run kept and how to go on (Ctrl-C, a dead worker, a full disk)."""
    return f"{done} of {total} trials are recorded in {run_dir}; continue with: grasp-ctrl run --resume {run_dir}"


def final_name(path: Path) -> Path:
    """The file a temporary name (``.NAME.PID.RANDOM.tmp``, storage.temp_path) is written for;
    a temporary file of a temporary file (the tick log's) unwinds to the final name."""
    while is_temp_file(path) and path.name.count(".") >= 4:
        path = path.with_name(path.name[1:].rsplit(".", 3)[0])
    return path


@contextlib.contextmanager
def naming_file(path: Path | None, unnamed_disk_full_only: bool = False) -> Iterator[None]:
    """An OSError in the block names the file the user knows: a temporary name is gone by the
    time they read it, and a failed write() names no file at all (then ``path``; with
    ``unnamed_disk_full_only`` only for a full disk, since a trial's other errors are not
    about its tick log)."""
    try:
        yield
    except OSError as exc:
        named = exc.filename if isinstance(exc.filename, (str, os.PathLike)) else None
        if named is not None and is_temp_file(Path(named)):
            where: Path | None = final_name(Path(named))
        elif exc.filename is None and (not unnamed_disk_full_only or exc.errno in DISK_FULL):
            where = path
        else:
            where = None
        if where is None:
            raise
        # a full disk's own words: pyarrow's text wraps them in a paragraph
        why = os.strerror(exc.errno) if exc.errno in DISK_FULL else (exc.strerror or str(exc))
        raise OSError(exc.errno, why, str(where)) from exc


def run_series(
    hand: HandConfig,
    objects: Sequence[ObjectProfile],
    policies: Sequence[str],
    trials: int,
    seed: int,
    run_dir: Path,
    settings: PaperSettings | None = None,
    progress: bool | Progress = True,
    tick_logs: bool = True,
    threads: int = 1,
    *,
    resume: bool = False,
    manifest: RunManifest | None = None,
    trial_fn: TrialFn | None = None,
    after_trial: Callable[[dict[str, Any]], None] | None = None,
    backend: str = DEFAULT_BACKEND,
    warn: Callable[[str], None] = _warn,
    jobs: int = 1,
    executor: str = "local",
    address: str | None = None,
    variation: Variation | None = None,
    raw_frames: bool = False,
) -> dict[str, Any]:
    """objects x policies x trials with shared seeds; returns the summary (docs/design.md 5.2).

    ``resume``: keep the valid records already in ``run_dir`` (the run's
    parameters must match its ``run.json``) and run only the missing trials.
    ``after_trial(record)`` is called once each new record is on disk.
    ``jobs``: simulated trials in that many worker processes (records arrive out of
    order; the summary does not depend on it). ``executor="ray"``: the trials are
    Ray tasks instead (``address``: a running cluster; else a local instance of
    ``jobs`` CPUs), see ray_executor.py. ``variation``: the simulated world's per-trial
    draws of a new run without ``manifest`` (default: nominal, the worlds' own).
    ``raw_frames``: the tick logs of a new run without ``manifest`` keep every raw frame
    whole (a manifest's own ``raw_frames`` rules otherwise; a ``trial_fn`` is made with it).
    """
    if len(set(safe_name(p) for p in policies)) != len(policies):
        raise UsageError("--policy: two policies would share one log directory; give each once")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise UsageError(f"--seed: a non-negative integer (got {seed!r})")
    if jobs < 1:
        raise UsageError("--jobs: must be at least 1")
    if jobs > 1 and trial_fn is not None:
        raise UsageError("--jobs: trials on real hardware run one at a time")
    if executor != "local" and trial_fn is not None:
        raise UsageError("--executor: trials on real hardware run here, one at a time")
    plan = manifest or RunManifest(
        backend=backend,
        hand=hand.name,
        seed=seed,
        trials=trials,
        policies=list(policies),
        objects=list(objects),
        tick_logs=tick_logs,
        raw_frames=raw_frames,
        settings=settings or default_settings(),
        variation=variation or NOMINAL,
    )
    # Everything that can be checked is checked before the first file is touched.
    for obj in plan.objects:
        check_object_name(obj.name)
    # on resume the profiles come from run.json, on a new run from the object file
    source = str(run_dir / RUN_FILE) if resume or not plan.object_file else plan.object_file
    check_objects_for_hand(plan.objects, hand, source)
    kin = HandKinematics(hand)
    for obj in plan.objects:  # the reach postures (preshape, a cap the finger must reach) fit this hand
        try:
            make_controller(hand, obj, np.zeros(3), plan.settings, kin)
        except ConfigError as exc:
            raise ConfigError(source, f"object {obj.name!r}: {exc.key}", exc.expected) from None
    setup = run_setup(hand, plan, threads, policies)
    run_trial = trial_fn or setup.trial_fn()  # bad policies fail here

    created = not run_dir.exists()
    if run_dir.exists() and not run_dir.is_dir():
        raise UsageError(f"{run_dir}: exists and is not a directory; choose another --out")
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
        with RunLock(run_dir, warn):
            existing = read_manifest(run_dir)
            if existing is not None and not resume:
                raise UsageError(
                    f"{run_dir} already holds a run; continue it with 'run --resume {run_dir}' or choose another --out"
                )
            if existing is None and record_files(run_dir):
                raise UsageError(f"{run_dir} holds trial records but no run.json; choose another --out")
            if existing is not None and not existing.same_plan(plan):
                raise UsageError(
                    f"{run_dir}/run.json describes other trials than these parameters; resume with its own parameters"
                )
            for tmp in stale_temp_files(run_dir):  # left by a writer that died; we hold the lock
                tmp.unlink(missing_ok=True)
            with naming_file(run_dir / RUN_FILE):
                sync_manifest(run_dir, plan, existing)  # new run, or a resume that recorded --force
            return _run_locked(
                plan,
                policies,
                trials,
                seed,
                run_dir,
                progress,
                resume,
                run_trial,
                after_trial,
                warn,
                jobs,
                setup,
                executor,
                address,
            )
    except BaseException:
        # A failed start leaves nothing that blocks the retry. Once run.json is in place (its
        # rename is atomic) the run has started, even if the interrupt came before the next
        # line: the directory stays, and the interrupt's message gives the --resume command.
        if created and not (run_dir / RUN_FILE).is_file():
            shutil.rmtree(run_dir, ignore_errors=True)
        raise


def check_slot(path: Path, what: str) -> None:
    """A trial's file cannot replace a directory of its name (a symlink or any other file it
    replaces): refused before the first trial runs, naming the directory, rather than failing on
    the trial's temporary file once it has run."""
    if path.is_dir() and not path.is_symlink():
        raise UsageError(f"{path}: a directory, not a {what}; move it out of the run and resume again")


def stale_temp_files(run_dir: Path) -> list[Path]:
    """Temporary files of interrupted writes (``.NAME.PID.RANDOM.tmp``) in the run's tree."""
    return [p for p in run_dir.rglob(".*.tmp") if is_temp_file(p)]


def _run_locked(
    plan: RunManifest,
    policies: Sequence[str],
    trials: int,
    seed: int,
    run_dir: Path,
    progress: bool | Progress,
    resume: bool,
    run_trial: TrialFn,
    after_trial: Callable[[dict[str, Any]], None] | None,
    warn: Callable[[str], None],
    jobs: int,
    setup: TrialSetup,
    executor: str = "local",
    address: str | None = None,
) -> dict[str, Any]:
    done: dict[tuple[str, str, int], dict[str, Any]] = {}
    notes: list[str] = []  # said once every slot is known to be writable
    if resume:
        loaded = load_records(run_dir)
        for path, why in loaded.problems:
            notes.append(f"skipping {path}: {why}; that trial will run again")
        for rec in loaded.records:
            key = (rec["policy"], rec["object"], rec["trial"])
            unplanned = why_unplanned(rec, plan)
            if unplanned is None:
                done[key] = rec
            else:
                notes.append(f"ignoring {record_path(run_dir, *key)}: not a trial of this run ({unplanned})")

    pending = []
    tick_logs: dict[tuple[str, str, int], tuple[Path, Path]] = {}  # key -> (temporary, final) tick log
    for policy in policies:
        for obj in plan.objects:
            for k in range(trials):
                if (policy, obj.name, k) not in done:
                    record_path(run_dir, policy, obj.name, k).parent.mkdir(parents=True, exist_ok=True)
                    check_slot(record_path(run_dir, policy, obj.name, k), "trial record")
                    log = None
                    if plan.tick_logs:
                        final = ticks_path(run_dir, policy, obj.name, k)
                        check_slot(final, "tick log")
                        log = temp_path(final)  # renamed onto ``final`` just before the record is written
                        tick_logs[(policy, obj.name, k)] = (log, final)
                    pending.append((policy, obj, k, trial_seed(seed, obj.name, k), log))
    for note in notes:
        warn(note)
    reporter = progress if isinstance(progress, Progress) else Progress(plan.total, enabled=bool(progress))
    reporter.resumed(canonical_order(list(done.values()), list(policies), plan.object_names))

    def finish(rec: dict[str, Any]) -> None:
        key = (rec["policy"], rec["object"], rec["trial"])
        if key in tick_logs and tick_logs[key][0].exists():
            with naming_file(tick_logs[key][1]):
                commit_temp(*tick_logs[key])
        with naming_file(record_path(run_dir, *key)):
            write_json(record_path(run_dir, *key), stamp(rec, plan))
        done[key] = rec
        reporter.trial_done(rec)
        if after_trial:
            after_trial(rec)

    set_engine_log_dir(run_dir)  # MuJoCo's warnings of in-process trials: the run directory, not ./
    try:
        if executor == "ray" and pending:
            from grasp_ctrl.trials.runs.ray_executor import ray_trials

            with contextlib.closing(ray_trials(address, jobs, setup, pending)) as results:
                for _, rec in results:
                    finish(rec)
        elif jobs > 1 and len(pending) > 1:
            try:
                # closing: the workers are stopped at once on Ctrl-C or an error, not when collected.
                with contextlib.closing(parallel_trials(min(jobs, len(pending)), setup, pending)) as results:
                    for _, rec in results:
                        finish(rec)
            except WorkerError as exc:
                raise WorkerError(f"{exc}; {resume_hint(run_dir, len(done), plan.total)}") from None
        else:
            for args in pending:
                with naming_file(args[4] and final_name(args[4]), True):
                    try:
                        rec = run_trial(*args)
                    except KeyboardInterrupt as exc:
                        keep_interrupted(run_dir, exc, plan)
                        raise
                finish(rec)
    finally:
        set_engine_log_dir(None)
        reporter.close()
        for tmp, _final in tick_logs.values():  # the trial in progress when interrupted
            tmp.unlink(missing_ok=True)
    records = canonical_order(list(done.values()), list(policies), plan.object_names)
    summary = summarize(records, str(run_dir), plan.backend, plan.hand, plan.seed)
    with naming_file(run_dir / SUMMARY_FILE):
        write_json(run_dir / SUMMARY_FILE, summary)
    return summary
