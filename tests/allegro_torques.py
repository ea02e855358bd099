"""What the Allegro's fault tests check of the torque frames (the PD loop in a thread,
tests/hardware/test_allegro_can_faults.py, or in its own process, test_allegro_can_process.py),
and the 100 Hz control loop they interrupt."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable, Iterable

import pytest

CONTROL_PERIOD_S = 0.010


def zero_torque_after(torques: Iterable[tuple[float, int, tuple[int, int, int, int]]], t_fault: float) -> float:
    """When every finger had zero torque after ``t_fault``, from ``(time, finger, pwm)`` frames in
    the order they went; asserts that no other torque followed."""
    zeroed: set[int] = set()
    t_safe = None
    for t, finger, pwm in (x for x in torques if x[0] >= t_fault):
        if t_safe is None:
            if pwm == (0, 0, 0, 0):
                zeroed.add(finger)
                if len(zeroed) == 4:
                    t_safe = t
            else:
                zeroed.discard(finger)
        else:
            assert pwm == (0, 0, 0, 0), f"finger {finger} had {pwm} {1e3 * (t - t_safe):.1f} ms after the safe state"
    assert t_safe is not None, "no zero torque on every finger after the fault"
    return t_safe


def control_loop_until_signal(
    h, q0, sig: signal.Signals, clock: Callable[[], float] = time.perf_counter, also: Callable[[], None] | None = None
) -> float:
    """A 100 Hz control loop in ``with h``; another thread sends ``sig`` to this process (after
    ``also``, e.g. the same signal to the PD process, as a terminal does to the whole group).
    Returns when it was sent (``clock``); the loop's exception goes to the caller."""
    sent: list[float] = []

    def send() -> None:
        time.sleep(0.15)
        sent.append(clock())
        if also is not None:
            also()
        os.kill(os.getpid(), sig)

    expected = KeyboardInterrupt if sig == signal.SIGINT else SystemExit
    with pytest.raises(expected):
        with h:
            threading.Thread(target=send, daemon=True).start()
            while True:
                h.read()
                h.check_health()
                h.write_goals(q0 + 0.04)
                time.sleep(CONTROL_PERIOD_S)
    assert sent
    return sent[0]
