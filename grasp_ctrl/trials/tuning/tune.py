"""Per-object threshold sweeps: the settings, their rows and their ranking.

``--param tau_n=1.0:3.0:0.25`` (start:stop:step, stop included), ``1.5,2,2.5``
or a single value; several ``--param`` give their Cartesian product. Every
setting runs the same seeded trials, so settings are compared on identical
situations. Ranking: the success rate's lower 95 % Wilson bound (or the success
rate itself, ``rank(by="mean")``; higher first), then mean peak true grip force
(lower first: the gentlest grasp that still works).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from grasp_ctrl.config.identifiers import is_identifier
from grasp_ctrl.config.objects import TUNABLE, ObjectProfile
from grasp_ctrl.errors import UsageError

MAX_SETTINGS = 200
ALIASES = {"tau": "tau_n", "release_threshold": "release_threshold_n", "lift_height": "lift_height_m", "hold": "hold_s"}
INTEGER = {"release_debounce"}
#: ``posture.FINGER.J``: the reach posture's offset of joint J (from 0, in the hand file's order) of
#: FINGER (the object file's ``posture_offsets_rad``); ``setting.NAME``: a float controller setting.
POSTURE_PREFIX = "posture."
SETTING_PREFIX = "setting."
TUNABLE_FORMS = (
    f"{', '.join(TUNABLE)}, posture.FINGER.J (a reach-posture joint offset), setting.NAME (a controller setting)"
)


def float_settings() -> list[str]:
    """The controller settings ``setting.NAME`` may name (any registered controller's, by flat key):
    those of float type. Whether the run's controller has it is checked with its settings
    (``search_space.check_settings_values``)."""
    from grasp_ctrl.controller.registry import flat_defaults

    return [key for key, default in flat_defaults().items() if type(default) is float]


def split_param(spec: str, forms: str = "NAME=START:STOP:STEP, NAME=A,B,C or NAME=VALUE") -> tuple[str, str]:
    """``NAME=VALUES`` -> (the profile field NAME stands for, VALUES), or a one-line error."""
    name, sep, values = spec.partition("=")
    name = ALIASES.get(name.strip(), name.strip())
    if not sep or not values.strip():
        raise UsageError(f"--param {spec!r}: expected {forms}")
    if name.startswith(POSTURE_PREFIX):
        finger, dot, joint = name[len(POSTURE_PREFIX) :].rpartition(".")
        if not dot or not is_identifier(finger) or not joint.isdigit() or not joint.isascii():
            raise UsageError(f"--param {spec!r}: posture.FINGER.J, J a joint of FINGER counted from 0")
        return f"{POSTURE_PREFIX}{finger}.{int(joint)}", values
    if name.startswith(SETTING_PREFIX):
        floats = float_settings()
        if name[len(SETTING_PREFIX) :] not in floats:
            raise UsageError(f"--param {spec!r}: not a controller setting of float type (one of {', '.join(floats)})")
        return name, values
    if name not in TUNABLE:
        raise UsageError(f"--param {spec!r}: {name!r} is not tunable (tunable: {TUNABLE_FORMS})")
    return name, values


def posture_key(name: str) -> tuple[str, int] | None:
    """``posture.FINGER.J`` -> (FINGER, J); None for another name."""
    if not name.startswith(POSTURE_PREFIX):
        return None
    finger, _, joint = name[len(POSTURE_PREFIX) :].rpartition(".")
    return finger, int(joint)


def controller_settings(base: Any, setting: dict[str, float | int]) -> Any:
    """``base`` (a controller's settings) with the setting's ``setting.NAME`` values."""
    own = {k[len(SETTING_PREFIX) :]: float(v) for k, v in setting.items() if k.startswith(SETTING_PREFIX)}
    return base.replace(**own) if own else base


def current_value(obj: ObjectProfile, settings: Any, name: str) -> float | int | None:
    """What the object file (or the controller settings) holds now for a tuned name (None: unset)."""
    key = posture_key(name)
    if key is not None:
        offsets = obj.posture_offsets().get(key[0])
        return offsets[key[1]] if offsets is not None and key[1] < len(offsets) else 0.0
    if name.startswith(SETTING_PREFIX):
        return settings.setting(name[len(SETTING_PREFIX) :])
    return getattr(obj, name)


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


def apply_setting(
    obj: ObjectProfile, setting: dict[str, float | int], finger_joints: dict[str, int] | None = None
) -> ObjectProfile:
    """The profile with the setting applied; values outside the file's limits are refused.
    ``posture.FINGER.J`` sets joint J of the finger's ``posture_offsets_rad`` (a finger without
    offsets gets zeros for its other joints, ``finger_joints[FINGER]`` of them); ``setting.NAME``
    values are controller settings (:func:`controller_settings`), not the profile's."""
    from grasp_ctrl.config.objects import revalidate
    from grasp_ctrl.errors import ConfigError

    params: dict[str, Any] = {}
    posture = {f: list(v) for f, v in obj.posture_offsets().items()}
    for name, value in setting.items():
        key = posture_key(name)
        if key is not None:
            finger, joint = key
            count = (finger_joints or {}).get(finger, joint + 1)
            offsets = posture.setdefault(finger, [0.0] * count)
            if joint >= len(offsets):
                raise UsageError(f"--param {name}: finger {finger} has {len(offsets)} joints (J from 0)")
            offsets[joint] = float(value)
        elif not name.startswith(SETTING_PREFIX):
            params[name] = value
    if posture != {f: list(v) for f, v in obj.posture_offsets().items()}:
        params["posture_offsets_rad"] = tuple((f, tuple(v)) for f, v in posture.items())
    tuned = obj.with_params(**params)
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


RANKS = ("wilson", "mean")  # tune --rank: the 95 % Wilson score interval's lower bound, or the success rate


def rank(rows: Sequence[SweepRow], by: str = "wilson") -> list[SweepRow]:
    """The success rate's lower 95 % Wilson bound (``by="wilson"``) or the success rate
    (``"mean"``) first, then the lower mean peak force; ties keep the sweep order.
    Settings pruned before their last trial come after every finished one."""

    def force(r: SweepRow) -> float:
        f = r.mean_peak_true_n
        return f if math.isfinite(f) else r.mean_peak_est_n if math.isfinite(r.mean_peak_est_n) else math.inf

    def score(r: SweepRow) -> float:
        return wilson_lower(r.successes, r.trials) if by == "wilson" else r.success_rate

    return sorted(rows, key=lambda r: (r.pruned, -score(r), force(r)))


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


def format_sweep(rows: Sequence[SweepRow], current: Mapping[str, float | int | None] | None = None) -> str:
    """The ranked table; ``*`` marks the object's current setting (a None value: unset, no match)."""
    names = list(rows[0].setting) if rows else []
    head = ["rank"] + names + ["success", "wilson lb", "peak grip true", "peak grip est", "failures"]
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
                f"{wilson_lower(r.successes, r.trials):.3f}",
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


def wilson_lower(successes: int, trials: int) -> float:
    """The lower end of the 95 % Wilson score interval (z = 1.96): 5/5 -> 0.566, 3/5 -> 0.231, 0/5 -> 0."""
    return wilson_interval(successes, trials)[0]
