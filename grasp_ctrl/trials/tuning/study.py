"""``tune`` as an Optuna study: settings sampled, seeded trials run, clearly worse settings pruned.

One Optuna trial is one *setting* of the tuned thresholds; it runs the same K
seeded trials (simulations) as every other setting, in order. The objective
(maximised, ``--rank wilson``, the default) is the lower bound of the success
rate's 95 % Wilson score interval over those trials, with ties broken by the mean
peak true grip force (lower wins: the gentlest grasp that still works)::

    value = W(successes, K) - 0.5 * d(K) * g / (1 + g)   g: mean peak true grip, N
    d(K) = the smallest step of W(s, K) from s to s + 1 successes

``--rank mean`` (the objective before) ranks by the success rate itself::

    value = (successes - 0.5 * g / (1 + g)) / K

Either tie-break term is below half a success's step, so it never outweighs one. After
each trial the setting reports the best success rate it can still reach; the
pruner stops it once that is below the success rate of a finished setting
(it can no longer win). The sampler is Optuna's grid sampler when every
parameter is a grid, else TPE. With a storage (``sqlite:///FILE``) the study
persists: a rerun of the same command loads it and runs only the settings its
budget still lacks; settings that were in progress when it was stopped (Ctrl-C,
a killed process) run again from their first trial, finished ones never.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import math
import warnings
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field
from typing import Any

import optuna
from optuna.pruners import BasePruner
from optuna.samplers import GridSampler, TPESampler
from optuna.trial import FrozenTrial, TrialState

from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.registry import default_settings, flat_settings, settings_for
from grasp_ctrl.errors import UsageError
from grasp_ctrl.sim.variation import NOMINAL, Variation
from grasp_ctrl.trials.episode.runner import trial_seed
from grasp_ctrl.trials.tuning.search_space import Param, Value, grid_size
from grasp_ctrl.trials.tuning.study_defaults import DEFAULT_BUDGET  # noqa: F401 - re-exported
from grasp_ctrl.trials.tuning.tune import SweepRow, apply_setting, controller_settings, wilson_lower
from grasp_ctrl.trials.tuning.tune_executors import TrialExecutor

OBJECTIVES = {
    "wilson": (
        "lower 95 % Wilson bound W of the success rate over the seeded trials, ties broken by the mean "
        "peak true grip force (gentler wins): value = W(successes, K) - 0.5*d*g/(1+g), d the smallest "
        "step of W between two success counts, g the mean peak true grip in N"
    ),
    "mean": (
        "success rate over the seeded trials, ties broken by the mean peak true grip force "
        "(gentler wins): value = (successes - 0.5*g/(1+g)) / K, g the mean peak true grip in N"
    ),
}
OBJECTIVE = OBJECTIVES["wilson"]  # the default (tune --rank wilson)
MAX_DUPLICATES = 50  # settings sampled again in a row: the space is exhausted
FINISHED = (TrialState.COMPLETE, TrialState.PRUNED)

optuna.logging.set_verbosity(optuna.logging.WARNING)
logging.getLogger("optuna").setLevel(logging.WARNING)


def objective_value(successes: int, trials: int, mean_peak_grip_n: float, rank: str = "wilson") -> float:
    g = mean_peak_grip_n
    tie = 0.5 * g / (1.0 + g) if math.isfinite(g) and g >= 0 else 0.5
    if rank == "wilson":
        return wilson_lower(successes, trials) - tie * _wilson_step(trials)
    return (successes - tie) / trials


@functools.lru_cache(maxsize=64)
def _wilson_step(trials: int) -> float:
    """The smallest rise of the lower Wilson bound from one success count to the next (K trials)."""
    bounds = [wilson_lower(s, trials) for s in range(trials + 1)]
    return min(b - a for a, b in zip(bounds, bounds[1:]))


@dataclass
class StudyPlan:
    obj: ObjectProfile
    params: list[Param]
    trials: int  # seeded trials per setting
    seed: int
    policy: str
    backend: str
    budget: int  # settings in the whole study
    storage: str | None = None
    name: str | None = None
    prune: bool = True
    seeds: list[int] = field(default_factory=list)
    variation: Variation | None = None  # the world's per-trial draws (sim/variation.py); None: nominal
    settings: PaperSettings | None = None  # the controller and its settings; None: the defaults
    rank: str = "wilson"  # the objective: wilson (the success rate's lower 95 % Wilson bound) or mean
    finger_joints: dict[str, int] = field(default_factory=dict)  # joints per finger (posture.FINGER.J)
    hand: str | None = None  # the hand it tunes on when not the default hand (part of the identity)

    def __post_init__(self) -> None:
        self.seeds = [trial_seed(self.seed, self.obj.name, k) for k in range(self.trials)]
        self.settings = self.settings or default_settings()

    @property
    def all_grid(self) -> bool:
        return all(p.is_grid for p in self.params)

    def identity(self) -> dict[str, Any]:
        """What makes two studies the same study (kept in the storage, checked on resume)."""
        out: dict[str, Any] = {
            "object": self.obj.name,
            "policy": self.policy,
            "backend": self.backend,
            "seed": self.seed,
            "trials": self.trials,
            "params": [p.spec() for p in self.params],
        }
        # Only a variation other than nominal is part of it: a study made before the profiles
        # (nominal draws) keeps its name and identity.
        if self.variation is not None and self.variation != NOMINAL:
            out["variation"] = self.variation.to_json()
        # Likewise the controller settings where they differ from the paper controller's defaults
        # (what every study ran before --controller), and the objective where it is not the success
        # rate (a study stored before --rank ranked by it: --rank mean).
        defaults = flat_settings(settings_for("paper"))
        assert self.settings is not None  # __post_init__ fills in the defaults
        changed = {k: v for k, v in flat_settings(self.settings).items() if v != defaults[k]}
        if changed:
            out["settings"] = changed
        if self.rank != "mean":
            out["rank"] = self.rank
        # A study on another hand is another study (a LEAP study made before hands were named keeps its identity).
        if self.hand is not None:
            out["hand"] = self.hand
        return out

    def study_name(self) -> str:
        if self.name:
            return self.name
        digest = hashlib.sha256(json.dumps(self.identity(), sort_keys=True).encode()).hexdigest()[:10]
        return f"tune-{self.obj.name}-{digest}"


class CannotWinPruner(BasePruner):
    """Prunes a setting once the best success rate it can still reach (its intermediate
    value: every remaining trial assumed a success) is below a finished setting's rate."""

    def __init__(self, trials: int) -> None:
        self.trials = trials

    def prune(self, study: optuna.Study, trial: FrozenTrial) -> bool:
        step = trial.last_step
        if step is None or step + 1 >= self.trials:
            return False
        reachable = trial.intermediate_values[step]
        best = max(
            (t.user_attrs.get("successes", 0) for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))),
            default=None,
        )
        return best is not None and reachable < best / self.trials - 1e-12


class StudyGridSampler(GridSampler):
    """Optuna's grid sampler for an ask-and-tell study whose budget this module keeps:
    no ``study.stop()`` after a trial, and a point whose setting was dropped unfinished
    (Ctrl-C) is not visited, so a rerun samples it again."""

    def after_trial(
        self, study: optuna.Study, trial: FrozenTrial, state: TrialState, values: Sequence[float] | None
    ) -> None:
        return None

    def _get_unvisited_grid_ids(self, study: optuna.Study) -> list[int]:
        taken = {
            t.system_attrs.get("grid_id")
            for t in study._storage.get_all_trials(study._study_id, deepcopy=False)
            if t.state in (*FINISHED, TrialState.RUNNING)
        }
        return [i for i in range(len(self._all_grids)) if i not in taken]


def setting_key(setting: dict[str, Value]) -> Hashable:
    return tuple(sorted((k, round(float(v), 12)) for k, v in setting.items()))


def _sampler(plan: StudyPlan, n_existing: int) -> optuna.samplers.BaseSampler:
    # A resumed study's sampler gets a seed of its own, so it does not draw the first run's points again.
    seed = int(hashlib.sha256(f"{plan.seed}:{n_existing}".encode()).hexdigest()[:8], 16)
    if plan.all_grid:
        return StudyGridSampler({p.name: list(p.values) for p in plan.params}, seed=seed)
    startup = max(2, min(10, plan.budget // 4))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return TPESampler(seed=seed, n_startup_trials=startup, multivariate=True)


def open_study(plan: StudyPlan) -> optuna.Study:
    """The plan's study: new, or loaded from the storage (its identity must match)."""
    storage: Any = None
    if plan.storage:
        try:
            storage = optuna.storages.RDBStorage(plan.storage)
        except Exception as exc:  # noqa: BLE001 - a bad URL or an unreadable file: one line
            raise UsageError(f"--storage {plan.storage}: {str(exc).splitlines()[0]}") from None
    name = plan.study_name()
    existing = 0
    if storage is not None:
        try:
            existing = len(storage.get_all_trials(storage.get_study_id_from_name(name), deepcopy=False))
        except KeyError:
            existing = 0
    pruner = CannotWinPruner(plan.trials) if plan.prune else optuna.pruners.NopPruner()
    study = optuna.create_study(
        storage=storage,
        study_name=name,
        direction="maximize",
        sampler=_sampler(plan, existing),
        pruner=pruner,
        load_if_exists=True,
    )
    identity = plan.identity()
    stored = study.user_attrs.get("identity")
    if stored is None:
        study.set_user_attr("identity", identity)
    elif stored != identity:
        diff = ", ".join(
            f"{k} {stored.get(k)!r} (now {identity.get(k)!r})"
            for k in {**stored, **identity}
            if stored.get(k) != identity.get(k)
        )
        raise UsageError(f"--study-name {name}: the stored study was made with {diff}")
    _recover(study, plan)
    return study


def _recover(study: optuna.Study, plan: StudyPlan) -> None:
    """Settings left running by a killed process are failed; settings dropped unfinished
    (and never finished since) are queued again (the grid sampler revisits them itself)."""
    storage = study._storage
    for t in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
        storage.set_trial_user_attr(t._trial_id, "interrupted", True)
        storage.set_trial_state_values(t._trial_id, TrialState.FAIL)
    if plan.all_grid:
        return
    done = set(finished_settings(study))
    queued = {
        setting_key(t.system_attrs.get("fixed_params", {}))
        for t in study.get_trials(deepcopy=False, states=(TrialState.WAITING,))
    }
    for t in study.get_trials(deepcopy=False, states=(TrialState.FAIL,)):
        key = setting_key(t.params)
        if t.user_attrs.get("interrupted") and t.params and key not in done and key not in queued:
            study.enqueue_trial(dict(t.params))
            queued.add(key)


def finished_settings(study: optuna.Study) -> dict[Hashable, FrozenTrial]:
    """Each distinct finished setting (complete or pruned) and the trial that holds its records."""
    out: dict[Hashable, FrozenTrial] = {}
    for t in study.get_trials(deepcopy=False, states=FINISHED):
        if "duplicate_of" not in t.user_attrs:
            out.setdefault(setting_key(t.params), t)
    return out


@dataclass
class _Active:
    trial: optuna.Trial
    setting: dict[str, Value]
    profile: ObjectProfile
    settings: PaperSettings
    records: list[dict[str, Any]] = field(default_factory=list)


def _short(rec: dict[str, Any], k: int, seed: int) -> dict[str, Any]:
    return {
        "trial": k,
        "seed": seed,
        "success": bool(rec["success"]),
        "reason": rec.get("reason"),
        "peak_grip_true_n": float(rec.get("peak_grip_true_n", math.nan)),
        "peak_grip_est_n": float(rec.get("peak_grip_est_n", math.nan)),
    }


def remaining(study: optuna.Study, plan: StudyPlan) -> int:
    cap = plan.budget if not plan.all_grid else min(plan.budget, grid_size(plan.params))
    return max(0, cap - len(finished_settings(study)))


def run_study(
    study: optuna.Study,
    plan: StudyPlan,
    executor: TrialExecutor,
    jobs: int,
    on_trial: Callable[[dict[str, Value], dict[str, Any]], None] | None = None,
) -> int:
    """Run settings until the study holds ``plan.budget`` distinct finished ones; returns how
    many finished here. On an error or Ctrl-C the settings in progress are marked failed
    (interrupted) and run again by a rerun."""
    todo = remaining(study, plan)
    done = finished_settings(study)
    active: dict[int, _Active] = {}
    finished_here = duplicates = 0
    try:
        while True:
            while len(active) < jobs and finished_here + len(active) < todo and duplicates < MAX_DUPLICATES:
                trial = study.ask()
                setting = {p.name: p.suggest(trial) for p in plan.params}
                key = setting_key(setting)
                if key in done or key in {setting_key(a.setting) for a in active.values()}:
                    duplicates += 1
                    _tell_duplicate(study, trial, done.get(key))
                    continue
                duplicates = 0
                act = _Active(
                    trial,
                    setting,
                    apply_setting(plan.obj, setting, plan.finger_joints),
                    controller_settings(plan.settings, setting),
                )
                trial.set_user_attr("seeds", plan.seeds)
                active[trial.number] = act
                executor.submit(trial.number, (plan.policy, act.profile, 0, plan.seeds[0], None), act.settings)
            if not active:
                break
            number, rec = executor.next_done()
            act = active[number]
            k = len(act.records)
            act.records.append(_short(rec, k, plan.seeds[k]))
            if on_trial:
                on_trial(act.setting, rec)
            successes = sum(r["success"] for r in act.records)
            act.trial.set_user_attr("records", act.records)
            act.trial.set_user_attr("successes", successes)
            act.trial.report((successes + plan.trials - k - 1) / plan.trials, k)
            if k + 1 < plan.trials and not act.trial.should_prune():
                executor.submit(number, (plan.policy, act.profile, k + 1, plan.seeds[k + 1], None), act.settings)
                continue
            del active[number]
            if k + 1 < plan.trials:
                study.tell(act.trial, state=TrialState.PRUNED)
            else:
                row = rows_of([act.records])[0]
                study.tell(act.trial, objective_value(successes, plan.trials, _grip(row), plan.rank))
            done[setting_key(act.setting)] = study._storage.get_trial(act.trial._trial_id)
            finished_here += 1
    except BaseException:
        for act in active.values():
            act.trial.set_user_attr("interrupted", True)
            study.tell(act.trial, state=TrialState.FAIL)
        executor.close(abort=True)
        raise
    executor.close(abort=False)
    return finished_here


def _tell_duplicate(study: optuna.Study, trial: optuna.Trial, same: FrozenTrial | None) -> None:
    """A setting sampled again: its finished twin's result, not run again (or failed, if in progress)."""
    if same is None:
        trial.set_user_attr("duplicate_of", -1)
        study.tell(trial, state=TrialState.FAIL)
        return
    trial.set_user_attr("duplicate_of", same.number)
    if same.state == TrialState.COMPLETE:
        study.tell(trial, same.value)
    else:
        for step, v in same.intermediate_values.items():
            trial.report(v, step)
        study.tell(trial, state=TrialState.PRUNED)


def _grip(row: SweepRow) -> float:
    g = row.mean_peak_true_n
    return g if math.isfinite(g) else row.mean_peak_est_n


def rows_of(
    record_lists: Sequence[Sequence[dict[str, Any]]],
    settings: Sequence[dict[str, Value]] | None = None,
    pruned: Sequence[bool] | None = None,
) -> list[SweepRow]:
    rows = []
    for i, recs in enumerate(record_lists):
        row = SweepRow(dict(settings[i]) if settings else {}, pruned=bool(pruned[i]) if pruned else False)
        for r in recs:
            row.add(r)
        rows.append(row)
    return rows


def study_rows(study: optuna.Study, plan: StudyPlan) -> list[tuple[SweepRow, FrozenTrial]]:
    """Every distinct finished setting as a sweep row (unranked), with its Optuna trial."""
    out = []
    names = [p.name for p in plan.params]
    for t in finished_settings(study).values():
        setting = {n: t.params[n] for n in names if n in t.params}
        (row,) = rows_of([t.user_attrs.get("records", [])], [setting], [t.state == TrialState.PRUNED])
        out.append((row, t))
    return out
