"""The wall-clock loop of a realtime dry run (``run --backend dynamixel --emulate --realtime``).

``WallClockLoop`` paces a trial's control ticks on a deadline schedule, as the real hand's
loop runs: tick ``k`` is released at ``t0 + k * period`` (the thread sleeps until then) and
must finish before the next release; one that finishes later is a deadline miss, and the next
tick then starts at once rather than bursting to catch up. Before each tick the simulated
world steps as often as it takes to reach the wall clock (one step normally, more after a
slow tick; at most ``max_catchup_s`` of world time at once, the rest is dropped and counted:
the world then runs behind the wall clock).

Per tick it keeps the cycle time (the control tick alone: bus transactions, sensing,
controller, log row: what the real hand's loop spends), the bus time within it, and the
world's stepping time (which a real hand does not spend, but which counts against the
deadline here, so a dry run without misses leaves the real loop that much more headroom).
``figures`` is what a trial record keeps under ``timings.loop``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import numpy as np

from grasp_ctrl.hardware.base import JointState

MAX_CATCHUP_S = 0.25  # world time one tick may step to catch up with the wall clock
PERCENTILES = (50, 90, 99)


def percentiles_ms(seconds: list[float]) -> dict[str, float]:
    """p50/p90/p99/max of durations in seconds, as milliseconds (empty: {})."""
    if not seconds:
        return {}
    ms = np.asarray(seconds, dtype=float) * 1000.0
    p = np.percentile(ms, PERCENTILES)
    out = {f"p{q}": round(float(v), 3) for q, v in zip(PERCENTILES, p)}
    out["max"] = round(float(ms.max()), 3)
    return out


class TrialClock:
    """A realtime trial's clock (seconds, the world's time base): the world's start time until
    the loop ``start``s, then that plus the wall time since. The backends stamp frames and
    joint states with it and the loop paces on it, so a frame's age is its age on the wall
    clock, not a multiple of the world's step."""

    def __init__(self, t_start: float) -> None:
        self.t_start = float(t_start)
        self._wall0: float | None = None

    def start(self) -> None:
        self._wall0 = time.perf_counter()

    def now(self) -> float:
        return self.t_start if self._wall0 is None else self.t_start + (time.perf_counter() - self._wall0)

    def __call__(self) -> float:
        return self.now()


@runtime_checkable
class WallClockLink(Protocol):
    """A backend that serves the real hand's links while the world steps on the wall clock
    (``run --emulate --realtime``): it publishes the world's state after each step."""

    trial_clock: TrialClock | None  # the clock its links run on (None: not on the wall clock)

    def after_world_step(self) -> None: ...


@runtime_checkable
class WallClockHand(WallClockLink, Protocol):
    """The hand's side of ``WallClockLink``: the goals its servos hold drive the next step, and
    the bus it was measured on goes into the record."""

    def before_world_step(self) -> None: ...

    def bus_figures(self) -> dict[str, float]: ...


class TimedHand:
    """A hand backend whose bus transactions (health poll, read, torque, goal write) are timed
    into ``loop``; everything else is the hand's."""

    def __init__(self, hand: Any, loop: WallClockLoop) -> None:
        self.hand = hand
        self.loop = loop

    def _timed(self, fn: Callable[..., Any], *args: Any) -> Any:
        t = self.loop.clock()
        try:
            return fn(*args)
        finally:
            self.loop.bus_s += self.loop.clock() - t

    def check_health(self) -> None:
        self._timed(self.hand.check_health)

    def read(self) -> JointState:
        state: JointState = self._timed(self.hand.read)
        return state

    def write_goals(self, q_goal: np.ndarray) -> None:
        self._timed(self.hand.write_goals, q_goal)

    def set_torque(self, enabled: bool) -> None:
        self._timed(self.hand.set_torque, enabled)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.hand, name)


class WallClockLoop:
    """Deadline pacing and timing figures of one trial's loop (see the module docstring)."""

    def __init__(
        self,
        period_s: float,
        world_dt: float,
        *,
        clock: Callable[[], float] = time.perf_counter,
        sleep: Callable[[float], None] = time.sleep,
        max_catchup_s: float = MAX_CATCHUP_S,
    ) -> None:
        if not period_s > 0 or not world_dt > 0:
            raise ValueError(f"period and world step must be positive (got {period_s!r}, {world_dt!r})")
        self.period_s = float(period_s)
        self.world_dt = float(world_dt)
        self.clock = clock
        self.sleep = sleep
        self.max_catchup_steps = max(1, int(round(max_catchup_s / world_dt)))
        self.t0 = 0.0
        self.release = 0.0
        self.ticks = 0
        self.misses = 0
        self.world_steps = 0
        self.dropped_steps = 0  # world steps skipped because the world could not keep up
        self.bus_s = 0.0  # bus time of the tick in progress (TimedHand adds to it)
        self.cycle_s: list[float] = []
        self.tick_bus_s: list[float] = []
        self.world_s: list[float] = []
        self._tick_start = 0.0
        self._started = False

    def start(self) -> None:
        self.t0 = self.release = self.clock()
        self._started = True

    def wait_for_release(self) -> None:
        """Sleep until this tick's release time."""
        if not self._started:
            self.start()
        delay = self.release - self.clock()
        if delay > 0:
            self.sleep(delay)

    def world_steps_due(self) -> int:
        """World steps that bring the world's time up to the wall clock's (capped)."""
        elapsed = self.clock() - self.t0
        # (a hair of slack: a release that lands exactly on a step boundary counts that step)
        due = math.floor(elapsed / self.world_dt + 1e-9) + 1 - self.world_steps - self.dropped_steps
        if due > self.max_catchup_steps:  # far behind (a stalled host): skip, do not spiral
            self.dropped_steps += due - self.max_catchup_steps
            due = self.max_catchup_steps
        return max(due, 0)

    def step_world(self, step: Callable[[], None]) -> None:
        """Run ``step`` (one world step) as often as the wall clock asks; timed."""
        t = self.clock()
        n = self.world_steps_due()
        for _ in range(n):
            step()
        self.world_steps += n
        self._tick_start = self.clock()
        self.world_s.append(self._tick_start - t)
        self.bus_s = 0.0

    def tick_done(self) -> None:
        """The tick's work is done: its cycle time, a miss if past its deadline, the next release."""
        end = self.clock()
        self.ticks += 1
        self.cycle_s.append(end - self._tick_start)
        self.tick_bus_s.append(self.bus_s)
        self.release += self.period_s
        if end > self.release:
            self.misses += 1
            self.release = end  # start the next tick at once; no burst to catch up

    def figures(self) -> dict[str, Any]:
        """What a trial record keeps under ``timings.loop``."""
        return {
            "clock": "wall",
            "period_ms": round(self.period_s * 1000.0, 3),
            "ticks": self.ticks,
            "deadline_misses": self.misses,
            "cycle_ms": percentiles_ms(self.cycle_s),
            "bus_ms": percentiles_ms(self.tick_bus_s),
            "world_step_ms": percentiles_ms(self.world_s),
            "world_steps": self.world_steps,
            "world_behind_s": round(self.dropped_steps * self.world_dt, 3),
        }
