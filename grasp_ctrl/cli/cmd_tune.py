"""``tune``: an Optuna study of an object's controller thresholds (MuJoCo, mock, or the real hand)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from grasp_ctrl.rigs.registry import BACKEND_FLAGS, DEFAULT_BACKEND, REFERENCE_WORLD

NAME = "tune"
HELP = "tune an object's thresholds and grasp (tau, approach, standoff, posture, ...) with an Optuna study"
DESCRIPTION = (
    "An Optuna study per object: each setting of the --param thresholds, grasp parameters or controller "
    "settings runs the same --trials seeded trials (same seeds for every setting). Objective, maximised "
    "(--rank wilson, the default): the lower bound W of the success rate's 95 % Wilson score interval, "
    "ties broken by the mean peak true grip force (gentler wins): value = W(successes, K) - 0.5*d*g/(1+g), "
    "d the smallest step of W between two success counts, g the mean peak true grip in N, K = --trials; "
    "--rank mean: value = (successes - 0.5*g/(1+g))/K. TPE samples the settings (the grid sampler when "
    "every --param is a grid); a setting that can no longer reach the best finished success rate is "
    "pruned after any trial. Prints the settings ranked with their Wilson lower bounds and the best one's "
    "success rate with its 95 % Wilson interval. --storage sqlite:///FILE keeps the study: Ctrl-C, then "
    "the same command again, continues it without repeating finished settings. With --write the best "
    "setting's object-file keys go into the object file's [objects.NAME.hands.HAND] table of the hand "
    "tuned on (HAND: the hand file's name; only those lines change, the table is added when missing, and "
    "a '# chosen by:' comment with the command and the hand file goes above it; the diff is shown)."
)
ORDER = 5


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.cli._common_options import (
        add_controller,
        add_hand_file,
        add_jobs_options,
        add_object_file,
        add_object_list,
    )
    from grasp_ctrl.config.objects import TUNABLE
    from grasp_ctrl.estimators.registry import DEFAULT_POLICY
    from grasp_ctrl.trials.tuning.study_defaults import DEFAULT_BUDGET

    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument("--object", metavar="NAME", help="the object to tune")
    add_object_list(
        which,
        help="tune each of these objects, separated by commas, or all (its own study each); --write puts "
        "every best setting into the one object file",
    )
    p.add_argument(
        "--param",
        required=True,
        action="append",
        metavar="NAME=LOW:HIGH",
        help="a threshold and where to search it: LOW:HIGH a continuous range (LOW:HIGH:log on a "
        "log scale), START:STOP:STEP (STOP included), A,B,C or one value a grid; repeat for "
        f"several. Tunable: {', '.join(TUNABLE)} (tau and release_threshold also accepted); "
        "posture.FINGER.J: the reach posture's offset of joint J (from 0) of FINGER, rad; "
        "setting.NAME: a controller setting of float type (not written by --write)",
    )
    p.add_argument(
        "--trials",
        type=int,
        default=3,
        metavar="K",
        help="seeded trials per setting, the same seeds for every setting (default 3)",
    )
    p.add_argument(
        "--budget",
        type=int,
        default=None,
        metavar="N",
        help=f"settings in the study (default: the whole grid when every --param is a grid, "
        f"else {DEFAULT_BUDGET}); a resumed study runs only those it lacks",
    )
    p.add_argument(
        "--policy", default=DEFAULT_POLICY, metavar="NAME|PATH", help=f"force estimator (default {DEFAULT_POLICY})"
    )
    add_controller(p)
    from grasp_ctrl.trials.tuning.tune import RANKS

    p.add_argument(
        "--rank",
        choices=RANKS,
        default="wilson",
        help="the objective: wilson (default), the lower bound of the success rate's 95 %% Wilson interval; "
        "mean, the success rate (the objective of studies stored before --rank); ties: the gentler grip",
    )
    p.add_argument(
        "--seed", type=int, default=0, metavar="S", help="base random seed of the trials and sampler (default 0)"
    )
    add_hand_file(p)
    add_object_file(p)
    p.add_argument(
        "--backend",
        choices=BACKEND_FLAGS,
        default=DEFAULT_BACKEND,
        help="mujoco: the reference world (default); mock: the fast test-double world; "
        "dynamixel: the real hand, each trial labelled by the operator",
    )
    from grasp_ctrl.sim.variation import add_variation_argument

    add_variation_argument(p)
    p.add_argument("--port", default=None, metavar="PORT", help="dynamixel: the servo bus port")
    p.add_argument("--sensor-port", default=None, metavar="PORT", help="dynamixel: the fingertip sensors' port")
    p.add_argument(
        "--storage",
        default=None,
        metavar="sqlite:///FILE",
        help="keep the study in this database (an existing FILE must be empty or an Optuna storage); the same command again continues it",
    )
    p.add_argument(
        "--study-name",
        default=None,
        metavar="NAME",
        help="the study's name in --storage (default: tune-OBJECT-<hash of object, policy, backend, "
        "seed, trials and params>)",
    )
    p.add_argument("--no-prune", action="store_true", help="run every setting's trials to the end")
    p.add_argument(
        "--write",
        action="store_true",
        help="write the best setting into the object file, under [objects.NAME.hands.HAND] of this hand",
    )
    p.add_argument("--json", default=None, metavar="FILE", help="write the ranked settings as JSON")
    p.add_argument(
        "--plots",
        default=None,
        metavar="DIR",
        help="write the study's history and parameter importances as PNG (the plot extra)",
    )
    add_jobs_options(
        p,
        jobs_default=1,
        jobs_help="settings run in N processes at once (with --executor ray: the local instance's CPUs). "
        "Default 1, not one per core as in run: with TPE the settings a study tries depend on N and the "
        "order results arrive, so a core-count default would search differently on another machine "
        "(N > 1 is safe: only this process writes the study and --storage; a grid's results do not "
        "depend on N)",
        executor_help="local: settings in this machine's processes (default); ray: the trials as Ray "
        "tasks (the ray extra), on a local instance or --address",
    )
    p.add_argument("--quiet", action="store_true", help="no progress line (shown only on a terminal anyway)")


def _entry(args: argparse.Namespace) -> Any:
    from grasp_ctrl.rigs.registry import from_flags

    return from_flags(args.backend)


def _on_real_hand(args: argparse.Namespace) -> bool:
    return _entry(args).kind == "real"


def _check_args(args: argparse.Namespace) -> None:
    from grasp_ctrl.cli._ranges import check_trials_and_seed
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.trials.runs.ray_executor import check_executor

    if _on_real_hand(args) and args.jobs != 1:
        raise UsageError("--jobs: the real hand runs one trial at a time")
    check_executor(args.executor, args.address)
    if _on_real_hand(args) and args.executor != "local":
        raise UsageError("--executor ray: the real hand runs here, one trial at a time")
    if _on_real_hand(args) and args.variation is not None:
        raise UsageError("--variation: only for a simulated world (mujoco, mock)")
    _variation(args)  # an unknown name: one line listing the profiles
    _settings(args)  # an unknown controller: one line listing them
    check_trials_and_seed(args.trials, args.seed)
    from grasp_ctrl.files.safe_write import check_output

    check_output(args.json, "--json")  # before any trial: a bad path costs nothing
    if args.plots is not None:
        from grasp_ctrl.files.safe_write import check_output_dir

        check_output_dir(args.plots, "--plots")
    if args.jobs < 1:
        raise UsageError("--jobs: must be at least 1")
    if args.budget is not None and args.budget < 1:
        raise UsageError("--budget: must be at least 1")
    if args.object is not None and ("," in args.object or args.object.strip() == "all"):
        raise UsageError("--object: one object name (several: --objects a,b or --objects all)")
    for flag in ("json", "storage", "plots", "study_name"):
        value = getattr(args, flag)
        if value is not None and not value.strip():
            raise UsageError(f"--{flag.replace('_', '-')}: empty")
    if args.storage:
        from grasp_ctrl.trials.tuning.study_defaults import check_storage

        check_storage(args.storage)


def _variation(args: argparse.Namespace) -> Any:
    """The simulated world's variation profile (sim/variation.py; default bench); None on the real hand."""
    if _on_real_hand(args):
        return None
    from grasp_ctrl.sim.variation import DEFAULT_VARIATION, variation

    return variation(args.variation or DEFAULT_VARIATION)


def _settings(args: argparse.Namespace, hand: Any = None) -> Any:
    """The controller settings every setting starts from: ``--controller``'s (default the
    registry's), with the hand file's own choices (``[controllers.NAME]``) where ``hand`` is given."""
    from grasp_ctrl.controller.registry import DEFAULT_CONTROLLER, settings_for

    return settings_for(args.controller or DEFAULT_CONTROLLER, hand)


def _executor(args: argparse.Namespace, hand: Any, trial_fn: Any) -> Any:
    from grasp_ctrl.trials.tuning.tune_executors import (
        ProcessExecutor,
        RayExecutor,
        SerialExecutor,
    )

    settings = _settings(args, hand)
    if _on_real_hand(args):
        # No ground truth on the real hand: the operator labels every trial.
        from grasp_ctrl.trials.episode.hardware import hardware_trial_fn
        from grasp_ctrl.trials.episode.labelling import OperatorLabeller, labelled

        labeller = OperatorLabeller()

        def on_hand(s: Any) -> Any:
            return labelled(
                hardware_trial_fn(hand, [args.policy], s, 1, port=args.port, sensor_port=args.sensor_port), labeller
            )

        return SerialExecutor(on_hand(settings), on_hand, settings)
    if args.executor == "ray":
        return RayExecutor(
            args.address,
            args.jobs if args.jobs > 1 else None,
            hand,
            args.policy,
            args.backend,
            _variation(args),
            settings,
        )
    if args.jobs > 1:
        return ProcessExecutor(args.jobs, hand, args.policy, args.backend, _variation(args), settings)
    from grasp_ctrl.trials.episode.runner import sim_trial_fn

    def in_sim(s: Any) -> Any:
        return sim_trial_fn(hand, [args.policy], s, backend=args.backend, variation=_variation(args))

    return SerialExecutor(trial_fn, in_sim, settings)


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.trials.tuning.study_defaults import require_optuna

    _check_args(args)
    require_optuna()
    if _entry(args).world == REFERENCE_WORLD:  # MuJoCo, before any study is opened
        from grasp_ctrl.sim.mujoco.world import _mujoco

        _mujoco()
    from grasp_ctrl.config.checks import check_objects_for_hand
    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.files.paths import default_hand_file
    from grasp_ctrl.trials.runs.selection import select_objects
    from grasp_ctrl.trials.tuning.search_space import (
        check_params_for_hand,
        check_settings_values,
        corner_settings,
        grid_size,
        parse_params,
    )
    from grasp_ctrl.trials.tuning.study import StudyPlan
    from grasp_ctrl.trials.tuning.study_defaults import DEFAULT_BUDGET
    from grasp_ctrl.trials.tuning.tune import apply_setting

    params = parse_params(args.param)
    hand = load_hand(args.hand)
    if args.write:  # its tables are [objects.NAME.hands.HAND]: refused before any trial
        from grasp_ctrl.config.identifiers import check_identifier_arg

        check_identifier_arg(hand.name, f"--write: {args.hand}: the hand's name")
    finger_joints = check_params_for_hand(params, hand)
    settings = _settings(args, hand)
    check_settings_values(params, settings)
    if args.object is not None:
        objects = select_objects(args.object_file, args.object, flag="--object", hand=hand.name)
    else:
        objects = select_objects(args.object_file, args.objects, flag="--objects", hand=hand.name)
    corners = corner_settings(params)
    for obj in objects:
        # every end of the search must fit the object file's limits and the hand (tau below its force limit, ...)
        tuned = [apply_setting(obj, s, finger_joints) for s in corners]
        check_objects_for_hand(tuned, hand, f"--param ({obj.name})")
    if args.study_name and len(objects) > 1:
        from grasp_ctrl.errors import UsageError

        raise UsageError("--study-name: one object only (each object has its own study)")
    budget = args.budget or (grid_size(params) or DEFAULT_BUDGET)
    plans = [
        StudyPlan(
            obj,
            params,
            args.trials,
            args.seed,
            args.policy,
            args.backend,
            budget,
            args.storage,
            args.study_name,
            prune=not args.no_prune,
            variation=_variation(args),
            settings=settings,
            rank=args.rank,
            finger_joints=finger_joints,
            hand=None if Path(args.hand).resolve() == default_hand_file().resolve() else hand.name,
        )
        for obj in objects
    ]
    trial_fn = None
    if not _on_real_hand(args):  # the policy and world load here, so a bad one fails before any study
        from grasp_ctrl.trials.episode.runner import sim_trial_fn

        trial_fn = sim_trial_fn(hand, [args.policy], settings, backend=args.backend, variation=_variation(args))
    docs = []
    for plan in plans:
        doc = _tune_one(plan, args, hand, trial_fn)
        if isinstance(doc, int):  # interrupted: 130 (Ctrl-C) or 143 (SIGTERM)
            return doc
        docs.append(doc)
    if args.json:
        from grasp_ctrl.files.safe_write import write_output

        out = docs[0] if args.object is not None else {"objects": docs}
        write_output(args.json, json.dumps(out, indent=2) + "\n")
    if not args.write:
        return 0
    return _write(args, docs, plans, hand.name)


def _tune_one(plan: Any, args: argparse.Namespace, hand: Any, trial_fn: Any) -> dict[str, Any] | int:
    """One object's study: run what it lacks, print and return the ranked settings (after Ctrl-C
    or SIGTERM: the exit status, 130 or 143)."""
    from grasp_ctrl.trials.runs.progress import Progress
    from grasp_ctrl.trials.tuning.study import open_study, remaining, run_study
    from grasp_ctrl.trials.tuning.study_report import report

    study = open_study(plan)
    todo = remaining(study, plan)
    progress = Progress(todo * plan.trials, enabled=not args.quiet)

    def on_trial(setting: dict[str, Any], rec: dict[str, Any]) -> None:
        progress.trial_done(dict(rec, policy=", ".join(f"{k}={v:g}" for k, v in setting.items())))

    ran = 0
    if todo:
        executor = _executor(args, hand, trial_fn)
        try:
            ran = run_study(study, plan, executor, args.jobs, on_trial)
        except KeyboardInterrupt as exc:
            # run_study stopped the workers, unless its bookkeeping was cut short first
            executor.close(abort=True)
            progress.close()
            from grasp_ctrl.trials.tuning.study import finished_settings

            kept = (
                (
                    f"{len(finished_settings(study))} of {plan.budget} settings are kept in {plan.storage}; "
                    f"run the same command again to continue"
                )
                if plan.storage
                else "nothing is kept without --storage"
            )
            print(f"interrupted: {plan.obj.name}: {kept}", file=sys.stderr)
            from grasp_ctrl.errors import Terminated

            return 143 if isinstance(exc, Terminated) else 130
        finally:
            progress.close()
    text, doc = report(study, plan, ran)
    print(text)
    if args.plots:
        from grasp_ctrl.trials.tuning.study_plots import write_study_plots

        for line in write_study_plots(study, Path(args.plots), plan.obj.name):
            print(line)
    return doc


def _write(args: argparse.Namespace, docs: list[dict[str, Any]], plans: list[Any], hand: str) -> int:
    """The best settings into ``[objects.NAME.hands.HAND]`` of ``hand`` (the tuned hand's name)."""
    from grasp_ctrl.trials.tuning.toml_edit import update_objects_file

    chosen = {d["object"]: d["best"]["setting"] for d in docs if d.get("best") and d["best"]["successes"] > 0}
    for d in docs:
        if d["object"] not in chosen:
            print(f"{d['object']}: no setting succeeded; left unchanged in {args.object_file}", file=sys.stderr)
    if not chosen:
        return 1
    values = {}
    for plan in plans:
        if plan.obj.name in chosen:
            values[plan.obj.name] = _file_values(plan, chosen[plan.obj.name])
            others = [f"{k}={v:g}" for k, v in chosen[plan.obj.name].items() if k.startswith("setting.")]
            if others:
                print(
                    f"{plan.obj.name}: controller settings are not object-file keys, not written: {', '.join(others)}"
                )
    diff = update_objects_file(
        Path(args.object_file), {k: v for k, v in values.items() if v}, _chosen_by(args), hand=hand
    )
    print(diff.rstrip() if diff else f"{args.object_file}: the best settings are already there; unchanged")
    return 0


def _file_values(plan: Any, setting: dict[str, Any]) -> dict[str, Any]:
    """The object-file keys of a chosen setting: its keys as they are, ``posture.FINGER.J`` as the
    whole ``posture_offsets_rad`` table of the tuned profile."""
    from grasp_ctrl.trials.tuning.tune import POSTURE_PREFIX, SETTING_PREFIX, apply_setting

    out: dict[str, Any] = {k: v for k, v in setting.items() if not k.startswith((POSTURE_PREFIX, SETTING_PREFIX))}
    if any(k.startswith(POSTURE_PREFIX) for k in setting):
        tuned = apply_setting(plan.obj, setting, plan.finger_joints)
        out["posture_offsets_rad"] = {f: list(v) for f, v in tuned.posture_offsets().items()}
    return out


def _chosen_by(args: argparse.Namespace) -> str:
    """The command that chose the values, the hand file it tuned on and today's date:
    ``grasp-ctrl tune ... (hand file hand_configs/leap_hand.toml, 2026-11-27)``."""
    import datetime
    import shlex

    from grasp_ctrl.cli import PROG

    argv = getattr(args, "_argv", None) or sys.argv[1:]
    return f"{PROG} {shlex.join(argv)} (hand file {_shown_path(args.hand)}, {datetime.date.today().isoformat()})"


def _shown_path(path: str) -> str:
    """``path`` relative to the checkout when it lies in it (the shipped hand files), else absolute."""
    from grasp_ctrl.files.paths import REPO_ROOT

    full = Path(path).resolve()
    try:
        return full.relative_to(REPO_ROOT).as_posix()
    except ValueError:
        return str(full)
