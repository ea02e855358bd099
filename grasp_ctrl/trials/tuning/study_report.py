"""A finished (or resumed) study as the ranked table, the best setting with its 95 % Wilson
interval, and the same as a JSON document."""

from __future__ import annotations

from typing import Any

import optuna

from grasp_ctrl.trials.tuning.study import OBJECTIVES, StudyPlan, study_rows
from grasp_ctrl.trials.tuning.tune import current_value, format_sweep, rank, wilson_interval, wilson_lower


def report(study: optuna.Study, plan: StudyPlan, ran_here: int) -> tuple[str, dict[str, Any]]:
    pairs = study_rows(study, plan)
    by_row = {id(row): t for row, t in pairs}
    rows = rank([row for row, _ in pairs], plan.rank)
    names = [p.name for p in plan.params]
    current = {n: current_value(plan.obj, plan.settings, n) for n in names}
    sampler = "grid" if plan.all_grid else "TPE"
    pruned = sum(r.pruned for r in rows)
    varied = f", variation {plan.variation.name}" if plan.variation is not None else ""
    controller = plan.settings.controller if plan.settings is not None else "paper"
    head = (
        f"{plan.obj.name}, policy {plan.policy}, controller {controller}, backend {plan.backend}{varied}, "
        f"{plan.trials} trials per setting, seed {plan.seed}; study {plan.study_name()} ({sampler}): "
        f"{len(rows)} settings finished ({ran_here} now, {pruned} pruned) (* = current)"
    )
    lines = [head, f"objective (--rank {plan.rank}): {OBJECTIVES[plan.rank]}"]
    doc: dict[str, Any] = {
        "object": plan.obj.name,
        "policy": plan.policy,
        "controller": controller,
        "backend": plan.backend,
        "variation": plan.variation.to_json() if plan.variation is not None else None,
        "seed": plan.seed,
        "trials": plan.trials,
        "seeds": plan.seeds,
        "budget": plan.budget,
        "sampler": sampler,
        "study": plan.study_name(),
        "storage": plan.storage,
        "rank": plan.rank,
        "objective": OBJECTIVES[plan.rank],
        "params": [p.spec() for p in plan.params],
        "current": current,
        "best": None,
        "ranked": [
            dict(
                r.to_json(),
                wilson_lower=round(wilson_lower(r.successes, r.trials), 4),
                study_trial=by_row[id(r)].number,
                value=by_row[id(r)].value if by_row[id(r)].value is not None else None,
            )
            for r in rows
        ],
    }
    if not rows:
        lines.append("no finished setting yet")
        return "\n".join(lines), doc
    lines.append(format_sweep(rows, current))
    best = rows[0]
    lo, hi = wilson_interval(best.successes, best.trials)
    setting = ", ".join(f"{k}={v:g}" for k, v in best.setting.items())
    lines.append(
        f"best: {setting}: {best.successes}/{best.trials} succeeded "
        f"({100 * best.success_rate:.0f} %, 95 % Wilson interval {100 * lo:.0f}-{100 * hi:.0f} %), "
        f"mean peak true grip {best.mean_peak_true_n:.2f} N"
    )
    doc["best"] = dict(best.to_json(), wilson_95=[round(lo, 4), round(hi, 4)])
    return "\n".join(lines), doc
