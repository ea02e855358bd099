"""A reply that arrives after the packet timeout is never taken for the next request's.

An FTDI adapter with its latency timer at 16 ms holds a short reply a whole timer before the host
sees it, past an 8 ms packet timeout: the read fails, and the reply then arrives while the next
request waits, and was taken for its answer (a 2-byte read of the input voltage read 591.8 V).
After a failed transaction the bus waits out the adapter's timer and drops what came in."""

from __future__ import annotations

import pytest

from grasp_ctrl.emulators.bus_timing import BusTiming
from grasp_ctrl.emulators.dxl_chain import DynamixelChainEmulator
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.dynamixel.bus import DynamixelBus

VOLTAGE = (144, 2)  # present input voltage, 0.1 V
POSITION = (132, 4)  # present position, counts


def test_a_late_reply_is_not_the_answer_to_the_next_request() -> None:
    emu = DynamixelChainEmulator([1], timing=BusTiming(57_600, 0.016)).start()
    position = emu.servo(1).get(POSITION)  # torque off: it stays
    bus = DynamixelBus(emu.port, 57_600, {1: "j"}, packet_timeout_ms=8.0, retries=0, drain_s=0.016)
    bus.open()
    seen: list[tuple[str, int]] = []
    try:
        for _ in range(6):
            for name, (address, size) in (("voltage", VOLTAGE), ("position", POSITION)):
                try:
                    seen.append((name, bus.read(1, address, size)))
                except HardwareError:
                    pass  # the reply missed the timeout: that read failed, honestly
    finally:
        bus.close()
        emu.stop()
    for name, value in seen:
        assert value == (120 if name == "voltage" else position), seen
    assert {name for name, _ in seen} == {"voltage", "position"}  # both registers were read


def test_the_drain_is_a_latency_timer() -> None:
    with pytest.raises(ValueError, match="drain_s"):
        DynamixelBus("/nonexistent", 57_600, {}, drain_s=-1.0)
