"""The host's joint PD loop of a torque-controlled hand on CAN (the Allegro v4).

Every period (``[torque_pd] rate_hz``, 333 Hz on the Allegro: the hand reports its joint positions
every 3 ms) the loop takes the frames that arrived, and when a full set of joint positions has come
in since the last torque it sends one torque frame per finger:

    tau = kp (q_goal - q) - kd dq,   each joint within its ``torque_limit_nm``

(``JointMap.pwm`` clamps, so no frame ever carries a torque outside the limits). ``dq`` is the
finite difference of the positions, low-passed with a 5 ms time constant (SimLab's node smooths
its 3 ms samples with a weight of 0.6 on the previous value, the same order).

Hand-over: the controller's goal is one immutable ``Goal`` (a read-only array and a flag) that
``set_goal`` swaps in as a single reference; the loop reads that reference once per period. The
loop's view of the hand goes the other way as one immutable ``LoopState``. No locks.

Faults latch: no full set of positions for ``position_stale_s``, an error frame (bus errors,
bus-off), a failed send, a temperature report above ``max_temperature_c`` or the hand's own
high-temperature or internal-communication fault bits, or ``trip`` from outside. From then on the
loop sends only zero-torque frames: a PD without trusted positions, or on a hot motor, can
neither hold nor open the hand. The hand file's ``on_fault`` is the backend's business
(hardware/allegro/hand.py) while the loop is healthy.

The loop runs in its own thread (``start``) on the wall clock, in its own process
(pd_process.py, which runs ``_run`` as its main loop), or is stepped by its owner (``cycle``: the
emulated hand's lockstep and the tests); its figures (periods, missed periods, frames) are in
``stats``.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.allegro import protocol as pr
from grasp_ctrl.hardware.allegro.bus import CanLink
from grasp_ctrl.hardware.allegro.protocol import CanFrame, JointMap, ProtocolError

VELOCITY_FILTER_S = 0.005  # the joint velocity's low-pass time constant
PERIOD_SAMPLES = 1 << 15  # the periods kept for the percentiles (the latest: 98 s at 333 Hz)
HEALTH_POLL_S = 0.1  # hand information and temperatures are asked for this often


def position_period_ms(rate_hz: float) -> int:
    """The hand's joint-position report period for a PD loop at ``rate_hz`` (ms, at least 1)."""
    return max(1, int(round(1000.0 / rate_hz)))


def start_frames(device_id: int, rate_hz: float) -> list[CanFrame]:
    """Start-up in the order of SimLab's driver (AllegroHandDrv.cpp ``init``): system off, hand
    information and serial number asked for, the report periods set, system on; then every
    finger's positions asked for."""
    return [
        pr.system_off(device_id),
        pr.request(pr.RTR_HAND_INFO, device_id),
        pr.request(pr.RTR_SERIAL, device_id),
        pr.set_period(position_period_ms(rate_hz), 0, 0, device_id),
        pr.system_on(device_id),
        *(pr.request_finger_pose(f, device_id) for f in range(pr.N_FINGERS)),
    ]


def stop_frames(joints: JointMap) -> list[CanFrame]:
    """The last frames to a hand: zero torque on every finger, system off, the reports stopped."""
    dev = joints.device_id
    return [*joints.zero_torque_frames(), pr.system_off(dev), pr.set_period(0, 0, 0, dev)]


def send_stop_frames(link: CanLink, joints: JointMap) -> None:
    """``stop_frames`` on ``link``, each tried: a bus that is down carries nothing more."""
    for frame in stop_frames(joints):
        try:
            link.send(frame)
        except HardwareError:
            pass


def health_frames(device_id: int) -> list[CanFrame]:
    """The hand information (status bits) and the four temperatures asked for."""
    frames = [pr.request(pr.RTR_HAND_INFO, device_id)]
    return frames + [pr.request_temperature(s, device_id) for s in range(pr.N_TEMPERATURE_SENSORS)]


class Goal(NamedTuple):
    q_rad: np.ndarray  # read-only, the hand file's joint order
    active: bool  # False: zero torque (torque off)


class LoopState(NamedTuple):
    q: np.ndarray  # rad, the latest full set of positions
    dq: np.ndarray  # rad/s, filtered
    tau_nm: np.ndarray  # the torques last sent (clamped, as the PWM values carry them)
    t: float  # s, the loop's clock when the set was complete
    sets: int  # full sets of positions received so far


@dataclass
class LoopCounters:
    cycles: int = 0
    missed_periods: int = 0  # periods the thread started late by a whole period or more (skipped)
    no_data_cycles: int = 0  # periods without a new full set of positions (no torque sent)
    torque_frames: int = 0
    zero_torque_frames: int = 0
    frames_in: int = 0
    bad_frames: int = 0  # malformed frames from the hand (dropped)
    foreign_frames: int = 0  # frames of another device or another command (ignored)
    error_frames: int = 0
    send_failures: int = 0


def _read_only(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


def _percentiles_ms(seconds: np.ndarray) -> dict[str, float]:
    """p50/p90/p99/max of durations in seconds, as milliseconds (none: {})."""
    if not seconds.size:
        return {}
    ms = seconds * 1000.0
    out = {f"p{q}": round(float(np.percentile(ms, q)), 3) for q in (50, 90, 99)}
    out["max"] = round(float(ms.max()), 3)
    return out


def _latest_periods(periods: np.ndarray, n_periods: int) -> np.ndarray:
    p = np.array(periods[: min(n_periods, PERIOD_SAMPLES)], dtype=float)
    return p[np.isfinite(p)]


def period_figures(periods: np.ndarray, n_periods: int, missed: int, period_s: float) -> dict[str, Any]:
    """A loop's periods (``PDLoop.period_figures``) from its ring of periods and counts."""
    return {
        "rate_hz": round(1.0 / period_s, 3),
        "budget_ms": round(period_s * 1000.0, 3),
        "periods": int(n_periods),
        "period_ms": _percentiles_ms(_latest_periods(periods, n_periods)),
        "missed_periods": int(missed),
    }


def loop_stats(counters: LoopCounters, periods: np.ndarray, n_periods: int, period_s: float) -> dict[str, float]:
    """A loop's figures (``PDLoop.stats``) from its counters and ring of periods."""
    out: dict[str, float] = {k: float(v) for k, v in vars(counters).items()}
    p = _latest_periods(periods, n_periods)
    for name, value in _percentiles_ms(p).items():
        out[f"period_{name}_ms"] = value
    out["period_budget_ms"] = round(period_s * 1000.0, 3)
    return out


class PDLoop:
    def __init__(
        self,
        link: CanLink,
        joints: JointMap,
        kp_nm_per_rad: np.ndarray,
        kd_nm_s_per_rad: np.ndarray,
        rate_hz: float,
        position_stale_s: float,
        max_temperature_c: float,
        clock: Callable[[], float] = time.monotonic,
        name: str = "CAN",
    ) -> None:
        self.link = link
        self.joints = joints
        self.kp = np.asarray(kp_nm_per_rad, dtype=float)
        self.kd = np.asarray(kd_nm_s_per_rad, dtype=float)
        self.period_s = 1.0 / rate_hz
        self.stale_s = position_stale_s
        self.max_temperature_c = max_temperature_c
        self.clock = clock
        self.name = name
        n = len(joints.finger)
        self._goal = Goal(_read_only(np.zeros(n)), False)
        self._state: LoopState | None = None
        self._fault: str | None = None
        self.counters = LoopCounters()
        self.temperatures_c: dict[int, int] = {}
        self.hand_info: pr.HandInfo | None = None
        self.serial: str | None = None
        self._counts = np.zeros((pr.N_FINGERS, pr.JOINTS_PER_FINGER), dtype=np.int64)
        self._need = frozenset(joints.fingers)
        self._fresh: set[int] = set()
        self._last_set_t: float | None = None
        self._q_prev: np.ndarray | None = None
        self._dq = np.zeros(n)
        self._periods = np.full(PERIOD_SAMPLES, np.nan)
        self._n_periods = 0
        self._missed_base = 0  # missed periods before the last ``reset_periods``
        self._reset_periods = False
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._started_t: float | None = None
        self._sent_for = -1  # the set (LoopState.sets) the last torque was computed from

    # ---- the owner's side ---------------------------------------------------------------------
    def set_goal(self, q_rad: np.ndarray, active: bool = True) -> None:
        """The goal the loop drives to from its next period (one reference swap)."""
        self._goal = Goal(_read_only(q_rad), bool(active))

    @property
    def goal(self) -> Goal:
        return self._goal

    @property
    def state(self) -> LoopState | None:
        """The latest full set of positions (None before the first)."""
        return self._state

    @property
    def fault(self) -> str | None:
        return self._fault

    def trip(self, reason: str) -> None:
        """Latch a fault: only zero-torque frames from now on (the first reason is kept)."""
        if self._fault is None:
            self._fault = reason

    # ---- one period ---------------------------------------------------------------------------
    def poll(self, timeout_s: float = 0.0) -> None:
        """Take the frames that arrived (waiting up to ``timeout_s`` for the first)."""
        wait = timeout_s
        while True:
            try:
                frame = self.link.recv(wait)
            except HardwareError as exc:
                self.trip(str(exc))
                return
            if frame is None:
                return
            wait = 0.0
            self._take(frame)

    def cycle(self, now: float | None = None) -> None:
        """One period: take what arrived, check staleness, send torques (or zeros after a fault)."""
        self.poll(0.0)
        now = self.clock() if now is None else now
        self.counters.cycles += 1
        if self._started_t is None:
            self._started_t = now
        if self._fault is None:
            last = self._last_set_t if self._last_set_t is not None else self._started_t
            if now - last > self.stale_s:
                age = "none yet" if self._last_set_t is None else f"the last {now - last:.3f} s ago"
                self.trip(
                    f"CAN bus {self.name}: no full set of joint positions for {self.stale_s:g} s ({age}; "
                    "is the hand powered and on the bus?)"
                )
        if self._fault is not None:
            self._send_zero()
            return
        state = self._state
        if state is None or self._sent_for == state.sets:  # no new full set since the last torque
            self.counters.no_data_cycles += 1
            return
        self._send_torque(state)

    def _take(self, frame: CanFrame) -> None:
        c = self.counters
        c.frames_in += 1
        if frame.is_error:
            c.error_frames += 1
            self.trip(f"CAN bus {self.name}: error frame (id 0x{frame.arbitration_id:x}): bus errors or bus-off")
            return
        if frame.is_remote or frame.device_id != self.joints.device_id or frame.is_extended:
            c.foreign_frames += 1
            return
        try:
            reply = pr.decode_reply(frame)
        except ProtocolError:
            cmd = frame.command
            if cmd in (pr.CMD_SYSTEM_ON, pr.CMD_SYSTEM_OFF, pr.CMD_SET_PERIOD, pr.CMD_CONFIG) or (
                pr.CMD_SET_TORQUE <= cmd < pr.CMD_SET_TORQUE + pr.N_FINGERS
            ):
                c.foreign_frames += 1  # another host's commands
            else:
                c.bad_frames += 1
            return
        if isinstance(reply, pr.FingerPose):
            self._counts[reply.finger] = reply.counts
            self._fresh.add(reply.finger)
            if self._need <= self._fresh:
                self._complete_set()
        elif isinstance(reply, pr.Temperature):
            self.temperatures_c[reply.sensor] = reply.celsius
            if reply.celsius > self.max_temperature_c:
                self.trip(
                    f"CAN bus {self.name}: over-temperature: sensor {reply.sensor} at {reply.celsius} degC "
                    f"(limit {self.max_temperature_c:g} degC, [torque_pd] max_temperature_c); let the hand cool"
                )
        elif isinstance(reply, pr.HandInfo):
            self.hand_info = reply
            if reply.faults():
                self.trip(
                    f"CAN bus {self.name}: the hand reports {', '.join(reply.faults())} (status 0x{reply.status:02x})"
                )
            elif reply.temperature_c > self.max_temperature_c:
                self.trip(
                    f"CAN bus {self.name}: over-temperature: the hand reports {reply.temperature_c} degC "
                    f"(limit {self.max_temperature_c:g} degC)"
                )
        else:
            self.serial = reply

    def _complete_set(self) -> None:
        self._fresh = set()
        now = self.clock()
        q = self.joints.joints_rad(self._counts)
        prev, t_prev = self._q_prev, self._last_set_t
        if prev is not None and t_prev is not None and now > t_prev:
            dt = now - t_prev
            a = math.exp(-dt / VELOCITY_FILTER_S)
            self._dq = a * self._dq + (1.0 - a) * (q - prev) / dt
        self._q_prev = q
        self._last_set_t = now
        old = self._state
        self._state = LoopState(
            _read_only(q),
            _read_only(self._dq),
            old.tau_nm if old is not None else _read_only(np.zeros_like(q)),
            now,
            (old.sets if old is not None else 0) + 1,
        )

    def torque_for(self, state: LoopState, goal: Goal) -> np.ndarray:
        """The PD torque (N m) of ``goal`` at ``state``, clamped to the joints' limits."""
        if not goal.active:
            return np.zeros_like(state.q)
        return self.joints.clamp_torque(self.kp * (goal.q_rad - state.q) - self.kd * state.dq)

    def _send_torque(self, state: LoopState) -> None:
        pwm = self.joints.pwm(self.torque_for(state, self._goal))
        if not self._send(self.joints.pwm_frames(pwm)):
            return
        self._sent_for = state.sets
        if np.any(pwm):
            self.counters.torque_frames += pr.N_FINGERS
        else:
            self.counters.zero_torque_frames += pr.N_FINGERS
        self._state = state._replace(tau_nm=_read_only(self.joints.torque_nm(pwm)))

    def _send_zero(self) -> None:
        if self._send(self.joints.zero_torque_frames(), trip=False):
            self.counters.zero_torque_frames += pr.N_FINGERS

    def _send(self, frames: list[CanFrame], trip: bool = True) -> bool:
        try:
            for f in frames:
                self.link.send(f)
        except HardwareError as exc:
            self.counters.send_failures += 1
            if trip:
                self.trip(str(exc))
            return False
        return True

    # ---- in its own thread ----------------------------------------------------------------------
    def start(self) -> None:
        """Run ``cycle`` every period in a daemon thread on the wall clock (a deadline schedule:
        a period that starts a whole period late or more skips to the next release, counted)."""
        if self._thread is not None:
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=f"allegro-pd-{self.name}", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        period = self.period_s
        release = time.perf_counter()
        last_start: float | None = None
        while not self._stop.is_set():
            wait = release - time.perf_counter()
            if wait > 0:
                self.poll(wait)  # take frames as they come until the release
                continue
            start = time.perf_counter()
            if self._reset_periods:  # (the owner asked: the figures start afresh here)
                self._n_periods, self._missed_base = 0, self.counters.missed_periods
                self._reset_periods = False
            if last_start is not None:
                self._periods[self._n_periods % PERIOD_SAMPLES] = start - last_start
                self._n_periods += 1
            last_start = start
            late = int((start - release) // period)
            if late > 0:
                self.counters.missed_periods += late
                release += late * period
            try:
                self.cycle()
            except Exception as exc:  # never leave the hand on its last torque
                self.trip(f"CAN bus {self.name}: PD loop failed: {type(exc).__name__}: {exc}")
                self._send_zero()
            release += period

    def stop(self, timeout_s: float = 1.0) -> None:
        """End the thread (the owner sends what comes after)."""
        thread, self._thread = self._thread, None
        if thread is None:
            return
        self._stop.set()
        thread.join(timeout_s)

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def wait_for_positions(self, timeout_s: float, stepped: bool = False) -> LoopState:
        """The first full set of positions within ``timeout_s`` (wall time); a one-line error
        naming the bus otherwise. ``stepped``: take frames here (the thread is not running)."""
        end = time.monotonic() + timeout_s
        while self._state is None and self._fault is None and time.monotonic() < end:
            if stepped or not self.running:
                self.poll(min(0.01, max(0.0, end - time.monotonic())))
            else:
                time.sleep(0.001)
        if self._fault is not None:
            raise HardwareError(self._fault)
        if self._state is None:
            raise HardwareError(
                f"CAN bus {self.name}: no joint positions from the hand within {timeout_s:g} s "
                "(powered? on this bus at 1 Mbit/s? the CAN cable terminated?)"
            )
        return self._state

    def reset_periods(self) -> None:
        """Start the period figures (``period_figures``) afresh from the thread's next period
        (the realtime dry run: from the trial's first world step, not the start-up)."""
        self._reset_periods = True

    def period_figures(self) -> dict[str, Any]:
        """The thread's periods since the start or the last ``reset_periods``: their count, their
        percentiles (ms: p50, p90, p99, max; the latest ``PERIOD_SAMPLES``), the missed periods
        (started a whole period late or more, skipped) and the budget."""
        missed = self.counters.missed_periods - self._missed_base
        return period_figures(self._periods, self._n_periods, missed, self.period_s)

    def stats(self) -> dict[str, float]:
        """The loop's figures: periods (ms: p50, p90, p99, max of the latest), missed periods, frames."""
        return loop_stats(self.counters, self._periods, self._n_periods, self.period_s)
