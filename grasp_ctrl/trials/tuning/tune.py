"""Per-object threshold sweeps on the mock world.

``--param tau_n=1.0:3.0:0.25`` (start:stop:step, stop included), ``1.5,2,2.5``
or a single value; several ``--param`` give their Cartesian product. Every
setting runs the same seeded trials, so settings are compared on identical
situations. Ranking: success rate (higher first), then mean peak true grip
force (lower first: the gentlest grasp that still works).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from grasp_ctrl.config.objects import TUNABLE, ObjectProfile
from grasp_ctrl.errors import UsageError

MAX_SETTINGS = 200
ALIASES = {"tau": "tau_n", "release_threshold": "release_threshold_n", "lift_height": "lift_height_m", "hold": "hold_s"}
INTEGER = {"release_debounce"}


def split_param(spec: str, forms: str = "NAME=START:STOP:STEP, NAME=A,B,C or NAME=VALUE") -> tuple[str, str]:
    """``NAME=VALUES`` -> (the profile field NAME stands for, VALUES), or a one-line error."""
    name, sep, values = spec.partition("=")
    name = ALIASES.get(name.strip(), name.strip())
    if not sep or not values.strip():
        raise UsageError(f"--param {spec!r}: expected {forms}")
    if name not in TUNABLE:
        raise UsageError(f"--param {spec!r}: {name!r} is not tunable (tunable: {', '.join(TUNABLE)})")
    return name, values


def parse_param(spec: str) -> tuple[str, list[float | int]]:
    """``NAME=VALUES`` -> (profile field, values)."""
    name, values = split_param(spec)
    try:
        if ":" in values:
            parts = [float(v) for v in values.split(":")]
            if len(parts) != 3:
                raise ValueError
            if not all(math.isfinite(v) for v in parts):
                raise UsageError(f"--param {spec!r}: START, STOP and STEP must be finite numbers")
            start, stop, step = parts
            if step <= 0 or stop < start:
                raise UsageError(f"--param {spec!r}: need START <= STOP and STEP > 0")
            span = (stop - start) / step  # huge or inf for a tiny STEP: checked before it is counted
            if not span < MAX_SETTINGS:
                raise UsageError(f"--param {spec!r}: more than {MAX_SETTINGS} values")
            count = int(math.floor(span + 1e-9)) + 1
            if count > MAX_SETTINGS:
                raise UsageError(f"--param {spec!r}: {count} values, at most {MAX_SETTINGS}")
            out = [round(start + i * step, 10) for i in range(count)]
        else:
            out = [float(v) for v in values.split(",") if v.strip()]
    except ValueError:
        raise UsageError(f"--param {spec!r}: values must be numbers") from None
    if not out or not all(math.isfinite(v) for v in out):
        raise UsageError(f"--param {spec!r}: no finite values")
    if name in INTEGER:
        if any(v != int(v) for v in out):
            raise UsageError(f"--param {spec!r}: {name} takes whole numbers")
        return name, [int(v) for v in out]
    return name, out


def settings_grid(params: Sequence[tuple[str, list[float | int]]]) -> list[dict[str, float | int]]:
    names = [n for n, _ in params]
    if len(set(names)) != len(names):
        raise UsageError("--param: each parameter once")
    grid = [dict(zip(names, combo)) for combo in itertools.product(*(v for _, v in params))]
    if len(grid) > MAX_SETTINGS:
        raise UsageError(f"--param: {len(grid)} settings, at most {MAX_SETTINGS}")
    return grid


def apply_setting(obj: ObjectProfile, setting: dict[str, float | int]) -> ObjectProfile:
    """The profile with the setting applied; values outside the file's limits are refused."""
    from grasp_ctrl.config.objects import revalidate
    from grasp_ctrl.errors import ConfigError

    tuned = obj.with_params(**setting)
    # Re-validate through the loader so the sweep never tries what the file could not hold.
    try:
        revalidate(tuned, f"--param ({obj.name})")
    except ConfigError as exc:  # names the key and the allowed range
        raise UsageError(str(exc)) from None
    return tuned


@dataclass
class SweepRow:
    setting: dict[str, float | int]
    trials: int = 0
    successes: int = 0
    failures: dict[str, int] = field(default_factory=dict)
    peak_true_n: list[float] = field(default_factory=list)
    peak_est_n: list[float] = field(default_factory=list)
    pruned: bool = False  # stopped early by the study: it could no longer win

    @property
    def success_rate(self) -> float:
        return self.successes / self.trials if self.trials else 0.0

    @property
    def mean_peak_true_n(self) -> float:
        return sum(self.peak_true_n) / len(self.peak_true_n) if self.peak_true_n else math.nan

    @property
    def mean_peak_est_n(self) -> float:
        return sum(self.peak_est_n) / len(self.peak_est_n) if self.peak_est_n else math.nan

    def add(self, rec: dict[str, Any]) -> None:
        self.trials += 1
        if rec["success"]:
            self.successes += 1
        else:
            self.failures[rec["reason"]] = self.failures.get(rec["reason"], 0) + 1
        self.peak_true_n.append(float(rec.get("peak_grip_true_n", math.nan)))
        self.peak_est_n.append(float(rec.get("peak_grip_est_n", math.nan)))

    def to_json(self) -> dict[str, Any]:
        return {
            "setting": self.setting,
            "trials": self.trials,
            "successes": self.successes,
            "success_rate": self.success_rate,
            "failures": dict(sorted(self.failures.items())),
            "mean_peak_grip_true_n": round(self.mean_peak_true_n, 4),
            "mean_peak_grip_est_n": round(self.mean_peak_est_n, 4),
            "pruned": self.pruned,
        }


def rank(rows: Sequence[SweepRow]) -> list[SweepRow]:
    """Success rate first, then the lower mean peak force; ties keep the sweep order.
    Settings pruned before their last trial come after every finished one."""

    def force(r: SweepRow) -> float:
        f = r.mean_peak_true_n
        return f if math.isfinite(f) else r.mean_peak_est_n if math.isfinite(r.mean_peak_est_n) else math.inf

    return sorted(rows, key=lambda r: (r.pruned, -r.success_rate, force(r)))


SweepTask = tuple[int, ObjectProfile, int]  # setting index, tuned profile, trial index


def run_sweep(
    obj: ObjectProfile,
    grid: Sequence[dict[str, float | int]],
    trials: int,
    run_trial: Callable[[ObjectProfile, int], dict[str, Any]],
    on_trial: Callable[[int, dict[str, float | int], dict[str, Any]], None] | None = None,
    run_many: Callable[[list[SweepTask]], Iterable[tuple[int, dict[str, Any]]]] | None = None,
) -> list[SweepRow]:
    """``run_trial(profile, k)`` runs trial k (its seed fixed by k) and returns the record;
    ``run_many(tasks)`` may run the tasks elsewhere (in parallel), yielding
    (task index, record) in any order. Rows do not depend on the order."""
    tuned = [apply_setting(obj, s) for s in grid]  # refuse a bad value before any trial
    tasks = [(i, tuned[i], k) for i in range(len(grid)) for k in range(trials)]
    results = run_many(tasks) if run_many else ((n, run_trial(p, k)) for n, (_, p, k) in enumerate(tasks))
    got: dict[int, dict[str, Any]] = {}
    for n, rec in results:
        got[n] = rec
        if on_trial:
            on_trial(tasks[n][0], grid[tasks[n][0]], rec)
    rows = [SweepRow(dict(s)) for s in grid]
    for n, (i, _, _) in enumerate(tasks):
        rows[i].add(got[n])
    return rows


def _fmt(v: float | int) -> str:
    return str(v) if isinstance(v, int) else f"{v:g}"


def format_sweep(rows: Sequence[SweepRow], current: dict[str, float | int] | None = None) -> str:
    """The ranked table; ``*`` marks the object's current setting."""
    names = list(rows[0].setting) if rows else []
    head = ["rank"] + names + ["success", "peak grip true", "peak grip est", "failures"]
    body = []
    for i, r in enumerate(rows, 1):
        mark = "*" if current is not None and all(_close(r.setting[n], current.get(n)) for n in names) else ""
        fails = ", ".join(f"{k} x{v}" for k, v in sorted(r.failures.items())) or "-"
        if r.pruned:
            fails = f"pruned; {fails}"
        body.append(
            [f"{i}{mark}"]
            + [_fmt(r.setting[n]) for n in names]
            + [
                f"{100 * r.success_rate:.0f}% ({r.successes}/{r.trials})",
                f"{r.mean_peak_true_n:.2f} N",
                f"{r.mean_peak_est_n:.2f} N",
                fails,
            ]
        )
    widths = [max(len(str(x)) for x in col) for col in zip(head, *body)]

    def fmt(cells: list) -> str:
        return "  ".join(
            str(c).ljust(w) if j == len(cells) - 1 else str(c).rjust(w) for j, (c, w) in enumerate(zip(cells, widths))
        )

    return "\n".join(fmt(cells).rstrip() for cells in [head, *body])


def _close(a: float | int, b: float | int | None) -> bool:
    return b is not None and abs(float(a) - float(b)) <= 1e-9 * max(1.0, abs(float(a)))


def wilson_interval(successes: int, trials: int, z: float = 1.959964) -> tuple[float, float]:
    """The Wilson score interval of a success rate (95 % by default)."""
    if trials <= 0:
        return 0.0, 1.0
    p = successes / trials
    denom = 1.0 + z * z / trials
    centre = (p + z * z / (2 * trials)) / denom
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)
