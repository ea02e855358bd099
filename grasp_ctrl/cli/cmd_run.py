"""``run``: lift-and-place trials (objects x policies x trials) and the run summary."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

from grasp_ctrl.errors import GraspCtrlError
from grasp_ctrl.rigs.registry import BACKEND_FLAGS, DEFAULT_BACKEND

NAME = "run"
HELP = "run lift-and-place trials and score them (the main job)"
DESCRIPTION = (
    "Run lift-and-place trials: every policy runs the same trials (same seeds) on every object. "
    "Writes RUN_DIR/run.json, one fsynced record (and tick log) per finished trial and "
    "RUN_DIR/summary.json, and prints a per-object success table. An interrupted run loses at most "
    "the trial in progress: continue it with 'run --resume RUN_DIR'. On --backend dynamixel the "
    "operator labels each trial's outcome at a prompt."
)
ORDER = 1

# Worker processes take about a second to start (imports, compiled kernels): the
# automatic --jobs gives each at least this many trials.
MIN_TRIALS_PER_JOB = 4
MAX_AUTO_JOBS = 8


def auto_jobs(backend: str, trials: int, cpus: int | None = None) -> int:
    """The default --jobs: simulated trials spread over the CPU cores when there are enough."""
    from grasp_ctrl.rigs.registry import backend as backend_entry

    if not backend_entry(backend).parallel:
        return 1
    cpus = cpus or os.cpu_count() or 1
    return max(1, min(cpus, MAX_AUTO_JOBS, trials // MIN_TRIALS_PER_JOB))


# The flags that define which trials a run holds (run.json stores them).
PLAN_FLAGS = (
    "hand",
    "object_file",
    "backend",
    "emulate",
    "objects",
    "policy",
    "trials",
    "seed",
    "preset",
    "no_tick_logs",
    "raw_frames",
    "controller",
    "variation",
    "realtime",
)


class _ForceBoth(argparse.Action):
    """``--force``, run's flag before --force-resume and --force-capacity: both."""

    def __call__(self, parser: Any, namespace: Any, values: Any, option_string: str | None = None) -> None:
        namespace.force_resume = namespace.force_capacity = True


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.cli._common_options import (
        add_controller,
        add_hand_file,
        add_jobs_options,
        add_object_file,
        add_object_list,
        hidden_alias,
    )
    from grasp_ctrl.estimators.registry import DEFAULT_POLICY
    from grasp_ctrl.trials.runs.presets import PRESETS

    presets = "; ".join(f"{k}: {v.description} ({', '.join(v.policies)})" for k, v in PRESETS.items())
    add_hand_file(
        p,
        resolved=False,
        help="hand config TOML (default: hand_configs/leap_hand.toml; the paper preset: hand_configs/allegro_hand.toml)",
    )
    add_object_file(p, resolved=False)
    add_controller(
        p,
        default_note="the paper preset: paper",
        more="paper: the paper's fixed grasp, ramp and lift; grip_load: a load phase "
        "and a slip response from the force vectors (docs/controller.md)",
    )
    p.add_argument(
        "--backend",
        choices=BACKEND_FLAGS,
        default=None,
        help="mujoco (default): the reference world, a MuJoCo scene built from the hand and "
        "object files (docs/mujoco.md); mock: the hand-written world, a fast test double whose "
        "success rates are not results (docs/results.md); dynamixel: the real hand, the operator "
        "labels each trial",
    )
    from grasp_ctrl.sim.variation import add_variation_argument

    add_variation_argument(p)
    p.add_argument(
        "--emulate",
        action="store_true",
        default=None,
        help="with --backend dynamixel: the servo chain (Protocol 2.0) and the fingertip stream "
        "(protocol v1) are emulated on pseudo-terminals with the MuJoCo world's physics behind "
        "them, so the whole hardware path runs without hardware; scored from that world",
    )
    p.add_argument(
        "--realtime",
        action="store_true",
        default=None,
        help="with --emulate: a wall-clock dry run: the loop ticks every 10 ms of wall time on a deadline "
        "schedule against emulators that take the bus's real time (baud rate, return delay, the hand "
        "file's USB latency_timer_ms) and the bridge's 10 ms frames; each trial record keeps the "
        "loop's cycle-time percentiles and deadline misses (timings.loop; with --backend allegro_can, "
        "also its host PD loop's 333 Hz periods). One trial at a time; "
        "kept in run.json for --resume",
    )
    p.add_argument(
        "--yes",
        action="store_true",
        help="answer the pre-flight confirmation (arm at its start pose) with yes, for scripted runs",
    )
    add_object_list(p, help="objects to run, separated by commas, or all (default: the object file's default_set)")
    p.add_argument(
        "--policy",
        nargs="+",
        action="extend",
        metavar="NAME|PATH",
        help=f"force estimator(s): a name in policies/, a path to a policy .json/.onnx, "
        f"or on the mock 'oracle' / 'oracle:scale=K' (0 < K <= 1e6) (default: {DEFAULT_POLICY}); repeatable",
    )
    p.add_argument("--trials", type=int, default=None, metavar="N", help="trials per object and policy (default 5)")
    p.add_argument("--seed", type=int, default=None, metavar="S", help="base random seed (default 0)")
    p.add_argument(
        "--preset",
        default=None,
        choices=tuple(PRESETS),
        help=f"a named protocol; flags given beside it override it. {presets}",
    )
    p.add_argument(
        "--out", default=None, metavar="DIR", help="run directory for logs (default: runs/<date>-<time>-seed<S>)"
    )
    p.add_argument(
        "--resume",
        default=None,
        metavar="RUN_DIR",
        help="continue an interrupted run with the parameters in RUN_DIR/run.json",
    )
    p.add_argument("--json", default=None, metavar="FILE", help="also write the run summary JSON here")
    p.add_argument(
        "--force-resume",
        action="store_true",
        help="with --resume: continue although a policy, hand or object file or run.json's settings "
        "changed since the run started (recorded in run.json)",
    )
    p.add_argument(
        "--force-capacity",
        action="store_true",
        help="on a Dynamixel hand (real or --emulate): run objects the grasp cannot carry at the "
        "configured currents and tau (the capacity preflight refuses them otherwise)",
    )
    # the older --force: both at once, as before the split
    hidden_alias(p, "force_resume", "--force", nargs=0, action=_ForceBoth)
    p.add_argument(
        "--threads", type=int, default=1, metavar="N", help="inference threads per policy, 1 to 1024 (default 1)"
    )
    add_jobs_options(
        p,
        jobs_default=None,
        jobs_help="simulated trials (mujoco, mock) run in N processes at once (default: one per CPU core, at most "
        f"{MAX_AUTO_JOBS}, for runs of {MIN_TRIALS_PER_JOB * 2}+ trials; else 1); "
        "results do not depend on it",
        executor_help="local: trials in this machine's processes (default); ray: as tasks on Ray (the ray "
        "extra), a local instance of --jobs CPUs or the cluster at --address",
    )
    p.add_argument(
        "--record-video",
        default=None,
        metavar="DIR",
        help="with --backend mujoco: render each trial offscreen to DIR/POLICY-OBJECT-TRIAL.mp4 (.gif "
        "without imageio-ffmpeg); needs a GL backend (MUJOCO_GL=egl or osmesa), else says so and "
        "runs without video; trials then run one at a time",
    )
    p.add_argument(
        "--rrd",
        default=None,
        metavar="DIR",
        help="also write a Rerun recording of every trial, DIR/POLICY/OBJECT/trial_NNN.rrd (the viz extra)",
    )
    p.add_argument(
        "--mcap",
        default=None,
        metavar="DIR",
        help="also write every trial as a ROS 2 bag, DIR/POLICY/OBJECT/trial_NNN.mcap (the ros extra; "
        "docs/ros_bags.md); a new run's tick logs then keep the raw frames (--raw-frames), for /biotac_pub",
    )
    p.add_argument("--no-tick-logs", action="store_true", default=None, help="skip the per-tick logs (faster)")
    p.add_argument(
        "--raw-frames",
        action="store_true",
        default=None,
        help="the tick logs keep every fingertip's whole raw frame each tick (42 more uint16 columns per "
        "fingertip beside the summary; recorded in run.json, kept on --resume); --mcap turns it on",
    )
    p.add_argument("--quiet", action="store_true", help="no progress line (shown only on a terminal anyway)")
    p.add_argument(
        "--port",
        default=None,
        metavar="PORT",
        help="dynamixel: the servo bus port (default: the hand file's [dynamixel] port)",
    )
    p.add_argument(
        "--sensor-port",
        default=None,
        metavar="PORT",
        help="dynamixel: one serial port for all fingertip sensors (default: the hand file's [tactile])",
    )


def _plan(args: argparse.Namespace) -> tuple[Any, Any]:
    """A new run's hand and manifest from the flags (and preset)."""
    from grasp_ctrl.cli._ranges import check_trials_and_seed
    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.estimators.registry import DEFAULT_POLICY
    from grasp_ctrl.files.paths import default_hand_file, default_objects_file, hand_configs_dir
    from grasp_ctrl.trials.runs.manifest import RunManifest, file_sha256
    from grasp_ctrl.trials.runs.presets import get_preset
    from grasp_ctrl.trials.runs.selection import select_objects

    preset = get_preset(args.preset) if args.preset else None
    trials = args.trials if args.trials is not None else (preset.trials if preset else 5)
    check_trials_and_seed(trials, args.seed)
    preset_hand = hand_configs_dir() / preset.hand if preset and preset.hand else None
    hand_file = Path(args.hand or preset_hand or default_hand_file())
    object_file = Path(args.object_file or default_objects_file())
    hand = load_hand(hand_file)
    objects_spec = args.objects if args.objects is not None else (",".join(preset.objects) if preset else None)
    objects = select_objects(object_file, objects_spec, hand=hand.name)
    if args.raw_frames and args.no_tick_logs:
        raise UsageError("--raw-frames: the frames go into the tick logs; drop --no-tick-logs")
    policies = args.policy or (list(preset.policies) if preset else [DEFAULT_POLICY])
    if len(set(policies)) != len(policies):
        raise UsageError("--policy: each policy once")
    from grasp_ctrl.rigs.registry import from_flags

    entry = from_flags(args.backend or DEFAULT_BACKEND, bool(args.emulate))
    backend = entry.name
    if entry.on_hand:  # the real hand's backends, or their emulation: the hand's kind, the extra they need
        entry.check_hand(hand)
    if args.realtime and not args.emulate:
        raise UsageError(
            "--realtime: only with --backend dynamixel --emulate or --backend allegro_can --emulate "
            "(a wall-clock dry run of the emulated hand)"
        )
    from grasp_ctrl.controller.registry import DEFAULT_CONTROLLER, controller_class, settings_for

    controller = args.controller or (preset.controller if preset else DEFAULT_CONTROLLER)
    controller_class(controller)  # an unknown name: one line listing the controllers
    from grasp_ctrl.sim.variation import DEFAULT_VARIATION, variation

    # The world's per-trial draws (the paper preset too); the real hand has none to choose.
    if not entry.truth and args.variation is not None:
        raise UsageError("--variation: only for a simulated world (mujoco, mock, or --emulate)")
    preset_variation = preset.variation if preset else None
    drawn = variation(args.variation or preset_variation or DEFAULT_VARIATION) if entry.truth else None
    manifest = RunManifest(
        variation=drawn,
        settings=settings_for(controller, hand),
        backend=backend,
        hand=hand.name,
        seed=args.seed if args.seed is not None else 0,
        trials=trials,
        policies=policies,
        objects=objects,
        tick_logs=not args.no_tick_logs,
        # the bags of --mcap carry the raw frames, so its trials keep them
        raw_frames=(bool(args.raw_frames) or args.mcap is not None) and not args.no_tick_logs,
        hand_file=str(hand_file.resolve()),
        hand_sha256=file_sha256(hand_file),
        object_file=str(object_file.resolve()),
        preset=args.preset,
        realtime=bool(args.realtime),
    )
    return hand, manifest


def _resumed(args: argparse.Namespace, run_dir: Path) -> tuple[Any, Any]:
    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.files.paths import default_hand_file
    from grasp_ctrl.trials.runs.fingerprint import check_resume
    from grasp_ctrl.trials.runs.manifest import read_manifest

    given = [f"--{f.replace('_', '-')}" for f in PLAN_FLAGS if getattr(args, f) is not None]
    if given or args.out:
        flags = ", ".join(given + (["--out"] if args.out else []))
        raise UsageError(f"--resume continues with the parameters in {run_dir}/run.json; drop {flags}")
    manifest = read_manifest(run_dir)
    if manifest is None:
        raise UsageError(f"--resume: {run_dir} has no run.json (not a run directory, or a run from an older version)")
    # A run started through the Python API may not name its hand file: use the default one.
    hand_file = Path(manifest.hand_file) if manifest.hand_file else default_hand_file()
    if not hand_file.is_file():
        raise UsageError(f"--resume: the run's hand file {hand_file} ({run_dir}/run.json: hand_file) is gone")
    hand = load_hand(hand_file)
    if hand.name != manifest.hand:
        raise UsageError(
            f"--resume: {hand_file} describes hand {hand.name!r}, the run used {manifest.hand!r} "
            f"({run_dir}/run.json: hand)"
        )
    check_resume(manifest, run_dir / "run.json", args.force_resume)  # no mixed experiments (trials/runs/fingerprint.py)
    return hand, manifest


def _hardware_trial_fn(hand: Any, manifest: Any, threads: int, port: str | None, sensor_port: str | None) -> Any:
    """The real-hand trial runner wrapped with the operator's labelling prompt."""
    from grasp_ctrl.trials.episode.hardware import hardware_trial_fn
    from grasp_ctrl.trials.episode.labelling import OperatorLabeller, labelled

    trial_fn = hardware_trial_fn(
        hand,
        manifest.policies,
        manifest.settings,
        threads,
        port=port,
        sensor_port=sensor_port,
        raw_frames=manifest.raw_frames,
    )
    return labelled(trial_fn, OperatorLabeller())


def _preflight(hand: Any, manifest: Any, args: argparse.Namespace) -> None:
    """Check every servo and fingertip, then ask for the go-ahead (before any trial)."""
    from grasp_ctrl.rigs.registry import backend as backend_entry
    from grasp_ctrl.trials.episode.preflight import confirm_start, preflight_emulated, preflight_hardware
    from grasp_ctrl.trials.episode.runner import trial_seed

    if backend_entry(manifest.backend).kind == "emulated":
        obj = manifest.objects[0]
        seed = trial_seed(manifest.seed, obj.name, 0)
        report = preflight_emulated(
            hand, obj, seed, manifest.variation, manifest.realtime, manifest.hand_file, manifest.backend
        )
    else:
        report = preflight_hardware(hand, args.port, args.sensor_port, manifest.hand_file)
    say = lambda text: print(text, file=sys.stderr, flush=True)  # noqa: E731
    say(report.summary())
    confirm_start(args.yes, ask=lambda q: input(q), say=say)


def _flagged(summary: dict[str, Any], short: Any, run_dir: Path) -> dict[str, Any]:
    """The summary with its flags (short objects, the mock's test-double flag), written into
    summary.json when they change it."""
    from grasp_ctrl.files.storage import SUMMARY_FILE, write_json
    from grasp_ctrl.trials.runs.series import naming_file
    from grasp_ctrl.trials.runs.summary_flags import flag_summary

    flagged = flag_summary(summary, short)
    if flagged != summary:
        with naming_file(run_dir / SUMMARY_FILE):
            write_json(run_dir / SUMMARY_FILE, flagged)
    return flagged


def _resume_hint(run_dir: Path, total: int) -> str | None:
    """What a stopped run kept and the command that continues it; None when it stopped before
    run.json existed (nothing to resume)."""
    from grasp_ctrl.trials.runs.records import load_records
    from grasp_ctrl.trials.runs.series import resume_hint

    if not (run_dir / "run.json").is_file():
        return None
    return resume_hint(run_dir, len(load_records(run_dir).records), total)


def _disk_full(exc: OSError, run_dir: Path, total: int) -> GraspCtrlError | None:
    """A full disk (or quota) as one line naming the file and, as Ctrl-C does, how to continue
    once there is room; None for any other error."""
    from grasp_ctrl.trials.runs.series import DISK_FULL

    if exc.errno not in DISK_FULL:
        return None
    where = f"{exc.filename}: " if exc.filename else ""
    hint = _resume_hint(run_dir, total) or "nothing was recorded"
    return GraspCtrlError(f"{where}{os.strerror(exc.errno)}; free some space, then: {hint}")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.errors import Terminated, UsageError
    from grasp_ctrl.files.safe_write import check_output, check_run_tree, write_output
    from grasp_ctrl.trials.episode.labelling import OperatorQuit
    from grasp_ctrl.trials.runs.series import kept_interrupted, run_series
    from grasp_ctrl.trials.runs.summary import format_table

    if args.threads < 1:
        raise UsageError("--threads: must be at least 1")
    for flag in ("resume", "out", "json"):
        if getattr(args, flag) is not None and not getattr(args, flag).strip():
            raise UsageError(f"--{flag}: an empty path")
    if args.resume:
        run_dir = Path(args.resume)
        hand, manifest = _resumed(args, run_dir)
    else:
        hand, manifest = _plan(args)
        stamp = time.strftime("%Y%m%d-%H%M%S")
        tag = f"-{manifest.preset}" if manifest.preset else ""
        run_dir = Path(args.out) if args.out else Path("runs") / f"{stamp}{tag}-seed{manifest.seed}"
    check_output(args.json, "--json", run_dirs=[run_dir])
    check_run_tree(run_dir, "--resume" if args.resume else "--out")
    from grasp_ctrl.rigs.registry import backend as backend_entry
    from grasp_ctrl.trials.runs.ray_executor import check_executor

    entry = backend_entry(manifest.backend)
    check_executor(args.executor, args.address)
    if args.executor != "local" and not entry.parallel:
        raise UsageError(
            "--executor ray: only simulated trials (mujoco, mock); a (real or emulated) hand runs "
            "here, one trial at a time"
        )
    trial_fn = None
    if args.record_video is not None:
        from grasp_ctrl.files.safe_write import check_output_dir

        check_output_dir(args.record_video, "--record-video")
    if args.record_video is not None and not entry.video:
        raise UsageError("--record-video: only with --backend mujoco")
    if manifest.realtime and args.jobs not in (None, 1):
        raise UsageError("--jobs: a --realtime dry run keeps one trial at a time on the wall clock; drop --jobs")
    from grasp_ctrl.trials.episode.capacity_check import preflight_capacity
    from grasp_ctrl.trials.runs.summary_flags import MOCK_NOTE

    short = preflight_capacity(
        hand,
        list(manifest.objects),
        manifest.settings,
        on_hand=entry.on_hand,
        force=args.force_capacity,
        say=lambda text: print(text, file=sys.stderr, flush=True),
        source=str(run_dir / "run.json") if args.resume else str(manifest.object_file),
    )
    if entry.on_hand:
        _preflight(hand, manifest, args)
    if entry.kind == "real":
        trial_fn = _hardware_trial_fn(hand, manifest, args.threads, args.port, args.sensor_port)
    elif entry.kind == "emulated":
        from grasp_ctrl.trials.runs.series import run_setup

        trial_fn = run_setup(hand, manifest, args.threads).trial_fn()
    elif args.record_video:
        from grasp_ctrl.trials.episode.mujoco_video import video_trial_fn

        trial_fn = video_trial_fn(
            hand,
            manifest.policies,
            manifest.settings,
            args.threads,
            Path(args.record_video),
            manifest.variation,
            raw_frames=manifest.raw_frames,
        )
    if args.rrd is not None:
        from grasp_ctrl.trials.analysis.rerun_log import check_run_rrd

        check_run_rrd(args.rrd, manifest.tick_logs)
    if args.mcap is not None:
        from grasp_ctrl.bags.export import check_run_mcap

        check_run_mcap(args.mcap, manifest.tick_logs)
        if not manifest.raw_frames:  # a resumed run that started without them
            print(
                f"note: --mcap: {run_dir}/run.json keeps no raw frames (raw_frames: false); "
                "its bags have no /biotac_pub",
                file=sys.stderr,
            )
    if args.executor == "ray":
        jobs = args.jobs if args.jobs is not None else (os.cpu_count() or 1)
    else:
        jobs = args.jobs if args.jobs is not None else auto_jobs(manifest.backend, manifest.total)
    try:
        summary = run_series(
            hand,
            manifest.objects,
            manifest.policies,
            manifest.trials,
            manifest.seed,
            run_dir,
            # On the real hand the operator's prompts own the terminal: no progress bar there.
            settings=manifest.settings,
            progress=not args.quiet and entry.kind != "real",
            tick_logs=manifest.tick_logs,
            raw_frames=manifest.raw_frames,
            threads=args.threads,
            resume=bool(args.resume),
            manifest=manifest,
            trial_fn=trial_fn,
            backend=manifest.backend,
            jobs=jobs,
            executor=args.executor,
            address=args.address,
        )
        summary = _flagged(summary, short, run_dir)
    except (KeyboardInterrupt, OperatorQuit) as exc:
        why = "interrupted" if isinstance(exc, KeyboardInterrupt) else str(exc)
        hint = _resume_hint(run_dir, manifest.total)
        kept = kept_interrupted(exc)  # the record of the trial it ended
        if hint and kept is not None:
            hint += f" (the trial in progress: {kept})"
        print(f"{why}: {hint}" if hint else f"{why} before the run started; nothing was recorded", file=sys.stderr)
        return 143 if isinstance(exc, Terminated) else 130
    except OSError as exc:
        full = _disk_full(exc, run_dir, manifest.total)
        if full is None:
            raise
        raise full from None
    print(format_table(summary))
    if manifest.variation is not None:
        print(f"variation: {manifest.variation.describe()}")
    print(f"logs: {run_dir}  (compare: grasp-ctrl compare {run_dir})")
    if summary.get("test_double"):
        print(f"note: {MOCK_NOTE}")
    if args.rrd is not None:
        from grasp_ctrl.trials.analysis.rerun_log import record_run

        print(f"recordings: {len(record_run(run_dir, Path(args.rrd)))} in {args.rrd}  (open: rerun FILE.rrd)")
    if args.mcap is not None:
        from grasp_ctrl.bags.export import export_run

        bags = export_run(run_dir, Path(args.mcap), flag="--mcap")
        print(f"bags: {len(bags)} in {args.mcap}  (open in Foxglove, or: ros2 bag play FILE.mcap)")
    if args.json:
        write_output(args.json, json.dumps(summary, indent=2) + "\n")
        print(f"summary: {args.json}")
    return 0
