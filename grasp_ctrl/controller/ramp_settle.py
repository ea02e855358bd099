"""When the force ramp has settled on a free object.

Each grasping fingertip ramps its own contact force toward tau. On an object that
is free to move (a real hand, MuJoCo) the fingertips push against each other
through it: the thumb carries what the index and middle push, so the per-finger
errors cannot all reach zero at once. Independent force loops with slightly
inconsistent targets then settle into a steady drift (the opposing fingers trade
the object back and forth) with every grip a little off tau and no force changing.

The ramp counts as settled when either
- every grip is within ``ramp_tolerance_n`` of tau for ``ramp_settle_s`` (the
  fixed-object case, as before), or
- the grips' mean is within ``ramp_tolerance_n`` of tau (the squeeze is at tau),
  every grip within the wider ``ramp_balance_band_n`` (the spread is the balance
  the object imposes) and no grip has moved more than ``ramp_steady_n`` for
  ``ramp_steady_s``: the grasp is balanced and steady, more ramping only pushes
  the object around.

Both rules read each grip's error averaged over the last ``ramp_filter_s``: an
estimate that flips between two readings at a steady force (a voxel network whose
contact cell toggles with sensor noise reads 1.8 and 2.1 N on and off at a true
1.76 N) must not keep the ramp from settling when its average sits on tau.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.controller.grip_load_settings import GripLoadSettings
from grasp_ctrl.controller.paper_settings import PaperSettings


class RecentRows:
    """The last ``cap`` rows appended, oldest first, as one C-contiguous (n, k) view: what
    ``np.array`` of a deque of them gives, without building it every tick. Each row is written
    twice, at i and i + cap, so that any ``cap`` consecutive rows lie in one block."""

    def __init__(self, cap: int) -> None:
        self.cap = cap
        self._buf: np.ndarray | None = None
        self._next = 0  # where the next row goes (mod cap)
        self._n = 0

    def __len__(self) -> int:
        return self._n

    def clear(self) -> None:
        self._next = self._n = 0

    def append(self, row: np.ndarray) -> None:
        buf = self._buf
        if buf is None or buf.shape[1:] != np.shape(row):
            buf = self._buf = np.empty((2 * self.cap, *np.shape(row)))
            self._next = self._n = 0
        i = self._next
        buf[i] = buf[i + self.cap] = row
        self._next = (i + 1) % self.cap
        self._n = min(self._n + 1, self.cap)

    def rows(self) -> np.ndarray:
        """The rows, oldest first (a view: read it before the next ``append``)."""
        assert self._buf is not None
        start = (self._next - self._n) % self.cap
        return self._buf[start : start + self._n]


class RampSettle:
    """Tick counters of the two settle rules. ``update(err)`` once per tick with the
    grasping fingertips' force errors tau - grip (N); ``settled(dt)`` is the guard.
    ``dt`` is the control period (s), for the averaging window."""

    def __init__(self, settings: PaperSettings, dt: float = 0.01) -> None:
        self.s = settings
        self.window = max(1, int(round(settings.ramp_filter_s / dt)))
        self.within_ticks = 0
        self.steady_ticks = 0
        self._ref_err: np.ndarray | None = None  # errors when the steady window began
        self._recent = RecentRows(self.window)  # the last ``window`` raw errors

    def reset(self) -> None:
        self.within_ticks = 0
        self.steady_ticks = 0
        self._ref_err = None
        self._recent.clear()

    def _filtered(self, err_now: np.ndarray) -> tuple[np.ndarray, bool]:
        """The errors averaged over the filter window, after counting the within-tolerance rule;
        and whether they are in the balance band (mean within tolerance, each within the band)."""
        recent = self._recent
        recent.append(np.asarray(err_now, dtype=float))
        rows = recent.rows()
        err = rows[0].copy() if len(rows) == 1 else np.mean(rows, axis=0)
        abs_err = np.abs(err)
        self.within_ticks = self.within_ticks + 1 if bool((abs_err <= self.s.ramp_tolerance_n).all()) else 0
        in_band = abs(float(err.mean())) <= self.s.ramp_tolerance_n and bool(
            (abs_err <= self.s.ramp_balance_band_n).all()
        )
        return err, in_band

    def update(self, err_now: np.ndarray) -> None:
        err, in_band = self._filtered(err_now)
        if not in_band or self._ref_err is None or bool((np.abs(err - self._ref_err) > self.s.ramp_steady_n).any()):
            self._ref_err = err.copy() if in_band else None
            self.steady_ticks = 0
        else:
            self.steady_ticks += 1

    def settled(self, dt: float) -> bool:
        return self.within_ticks * dt >= self.s.ramp_settle_s or self.steady_ticks * dt >= self.s.ramp_steady_s


class TrendRampSettle(RampSettle):
    """``RampSettle`` whose steady rule reads the grips' trend, not their tick-to-tick spread.

    With quantised servo goals (an X-series servo moves in 0.088 deg steps, a tenth of a
    millimetre at the pad, a few tenths of a newton on a stiff object) and a learned estimate's
    noise, the grips of a balanced grasp jitter by more than ``ramp_steady_n`` around a steady
    mean, so the window rule never holds and the ramp times out. Here the grasp is steady when,
    over the last ``ramp_steady_s``, every filtered error stayed in the band and each grip's mean
    over the window's second half differs from its mean over the first half by at most
    ``ramp_steady_n``: zero-mean jitter averages out, a drift does not.

    A third rule (``ramp_cycle_s`` > 0) ends a steady cycle: a light object rocking on the table
    (the lego, set down 6 mm toward the thumb) trades the thumb's grip between 3 and 5 N every
    0.6 s while the index and middle sit at their targets, and the ramp times out although the
    grasp holds on average. Over the last ``ramp_cycle_s`` each grip's mean error is in the band
    (their mean within ``ramp_tolerance_n``), the means over the window's halves differ by at
    most ``ramp_tolerance_n`` and no filtered error swung by more than ``ramp_cycle_swing_n``."""

    def __init__(self, settings: GripLoadSettings, dt: float = 0.01) -> None:
        super().__init__(settings, dt)
        self._swing_n = settings.cycle.ramp_cycle_swing_n
        self._span = max(2, int(round(settings.ramp_steady_s / dt)))
        self._history = RecentRows(self._span)
        self._cycle_span = int(round(settings.cycle.ramp_cycle_s / dt))
        self._cycle = RecentRows(max(1, self._cycle_span))
        self.cycle_ticks = 0

    def reset(self) -> None:
        super().reset()
        self._history.clear()
        self._cycle.clear()
        self.cycle_ticks = 0

    def settled(self, dt: float) -> bool:
        return super().settled(dt) or self.cycle_ticks > 0

    def _update_cycle(self, err: np.ndarray) -> None:
        if self._cycle_span < 2:
            return
        self._cycle.append(err)
        if len(self._cycle) < self._cycle_span:
            return
        window = self._cycle.rows()
        half = len(window) // 2
        mean = window.mean(axis=0)
        s = self.s
        steady = (
            abs(float(mean.mean())) <= s.ramp_tolerance_n
            and bool((np.abs(mean) <= s.ramp_balance_band_n).all())
            and bool((np.abs(window[half:].mean(axis=0) - window[:half].mean(axis=0)) <= s.ramp_tolerance_n).all())
            and bool((np.ptp(window, axis=0) <= self._swing_n).all())
        )
        self.cycle_ticks = self._cycle_span if steady else 0

    def update(self, err_now: np.ndarray) -> None:
        err, in_band = self._filtered(err_now)
        self._update_cycle(err)
        if not in_band:
            self._history.clear()
            self.steady_ticks = 0
            return
        self._history.append(err)
        if len(self._history) < self._span:
            self.steady_ticks = 0
            return
        window = self._history.rows()
        half = len(window) // 2
        drift = np.abs(window[half:].mean(axis=0) - window[:half].mean(axis=0))
        self.steady_ticks = self._span if bool((drift <= self.s.ramp_steady_n).all()) else 0
