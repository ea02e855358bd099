"""What ``tune --param`` searches: a grid of listed values or a continuous range per threshold.

``NAME=LOW:HIGH`` is a continuous range (``NAME=LOW:HIGH:log`` samples it on a
log scale; whole numbers for ``release_debounce``); ``NAME=START:STOP:STEP``
(STOP included), ``NAME=A,B,C`` and ``NAME=VALUE`` are grids, as before. Every
bound and value must be a finite number; a range needs LOW < HIGH (and LOW > 0
on a log scale). The study samples a grid with Optuna's grid sampler when every
parameter is a grid, else with TPE. NAME is an object-file key (``TUNABLE``), a
reach-posture joint offset ``posture.FINGER.J`` or a float controller setting
``setting.NAME``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from grasp_ctrl.errors import UsageError
from grasp_ctrl.trials.tuning.tune import (
    INTEGER,
    MAX_SETTINGS,
    SETTING_PREFIX,
    parse_param,
    posture_key,
    split_param,
)

Value = float | int


@dataclass(frozen=True)
class Param:
    """One tuned threshold: ``values`` for a grid, else ``low``..``high`` (``log`` scale)."""

    name: str
    values: tuple[Value, ...] = ()
    low: float = math.nan
    high: float = math.nan
    log: bool = False

    @property
    def is_grid(self) -> bool:
        return bool(self.values)

    @property
    def integer(self) -> bool:
        return self.name in INTEGER

    def ends(self) -> tuple[Value, ...]:
        """The values that bound what can be sampled (checked against the object file's limits)."""
        if self.is_grid:
            return self.values
        return (int(self.low), int(self.high)) if self.integer else (self.low, self.high)

    def spec(self) -> str:
        if self.is_grid:
            return f"{self.name}=" + ",".join(repr(v) for v in self.values)
        return f"{self.name}={self.low!r}:{self.high!r}" + (":log" if self.log else "")

    def suggest(self, trial: Any) -> Value:
        """The value an Optuna trial takes (a grid is categorical)."""
        if self.is_grid:
            return trial.suggest_categorical(self.name, list(self.values))
        if self.integer:
            return trial.suggest_int(self.name, int(self.low), int(self.high), log=self.log)
        return trial.suggest_float(self.name, self.low, self.high, log=self.log)


def _number(text: str, spec: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise UsageError(f"--param {spec!r}: {text.strip()!r} is not a number") from None
    if not math.isfinite(v):
        raise UsageError(f"--param {spec!r}: {text.strip()!r} is not a finite number")
    return v


def parse_space(spec: str) -> Param:
    """``NAME=LOW:HIGH[:log]`` (a range), or a grid as ``tune.parse_param`` reads it."""
    name, values = split_param(spec, "NAME=LOW:HIGH, NAME=START:STOP:STEP, NAME=A,B,C or NAME=VALUE")
    parts = values.split(":") if ":" in values else values.split(",")
    for part in parts:
        if part.strip().lower() != "log" and part.strip():
            _number(part, spec)  # every bound and value finite, before anything else
    if ":" in values:
        log = len(parts) == 3 and parts[2].strip().lower() == "log"
        if len(parts) == 2 or log:
            low, high = _number(parts[0], spec), _number(parts[1], spec)
            if not low < high:
                raise UsageError(f"--param {spec!r}: need LOW < HIGH (one value: NAME={low:g})")
            if log and low <= 0:
                raise UsageError(f"--param {spec!r}: a log scale needs LOW > 0")
            if name in INTEGER and (low != int(low) or high != int(high)):
                raise UsageError(f"--param {spec!r}: {name} takes whole numbers")
            return Param(name, low=low, high=high, log=log)
    grid_name, grid = parse_param(f"{name}={values}")
    return Param(grid_name, values=tuple(grid))


def parse_params(specs: Sequence[str]) -> list[Param]:
    params = [parse_space(s) for s in specs]
    names = [p.name for p in params]
    if len(set(names)) != len(names):
        raise UsageError("--param: each parameter once")
    if all(p.is_grid for p in params):
        size = grid_size(params)
        if size > MAX_SETTINGS:
            raise UsageError(f"--param: {size} settings, at most {MAX_SETTINGS}")
    return params


def grid_size(params: Sequence[Param]) -> int:
    return math.prod(len(p.values) for p in params) if all(p.is_grid for p in params) else 0


def check_params_for_hand(params: Sequence[Param], hand: Any) -> dict[str, int]:
    """Each ``posture.FINGER.J`` names a finger of ``hand`` and one of its joints (one line if not);
    returns the joints per finger (what ``apply_setting`` fills a finger's other offsets for)."""
    joints = {f.name: len(f.joints) for f in hand.fingers}
    for p in params:
        key = posture_key(p.name)
        if key is None:
            continue
        finger, j = key
        if finger not in joints:
            raise UsageError(
                f"--param {p.name}: {finger!r} is not a finger of hand {hand.name!r} ({', '.join(joints)})"
            )
        if j >= joints[finger]:
            raise UsageError(f"--param {p.name}: finger {finger} has joints 0 to {joints[finger] - 1}")
    return joints


def check_settings_values(params: Sequence[Param], settings: Any) -> None:
    """Every ``setting.NAME`` is a setting of ``settings``' controller and both ends of its search
    lie where its settings class allows (finite, positive: ``ControllerSettings.check``), in one
    line naming the parameter if not."""
    for p in params:
        if p.name.startswith(SETTING_PREFIX):
            for v in p.ends():
                type(settings).check({p.name[len(SETTING_PREFIX) :]: float(v)}, f"--param {p.spec()}")


def corner_settings(params: Sequence[Param]) -> list[dict[str, Value]]:
    """Each parameter at each of its ends (others at their first end): checked before any trial."""
    base = {p.name: p.ends()[0] for p in params}
    out = [dict(base)]
    for p in params:
        for v in p.ends():
            out.append({**base, p.name: v})
    return out
