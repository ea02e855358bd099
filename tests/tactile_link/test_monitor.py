"""The live monitor's tare against the sensor-bridge emulator: a silent fingertip fails fast, a slow
stream is tared."""

from __future__ import annotations

import sys
import time

import pytest

from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.emulators.tactile_bridge import TactileBridgeEmulator
from grasp_ctrl.errors import SensorStaleError
from grasp_ctrl.files.paths import default_hand_file
from grasp_ctrl.tactile_link.monitor import Monitor
from grasp_ctrl.tactile_link.serial_sensors import SerialSensors

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="the emulator needs POSIX pseudo-terminals")


@pytest.fixture
def hand():
    return load_hand(default_hand_file())


def _monitor(hand, emu: TactileBridgeEmulator) -> tuple[Monitor, SerialSensors]:
    sensors = SerialSensors.from_hand(hand, port=emu.port, mode="binary", keep_history=100_000)
    sensors.start()
    return Monitor(hand, sensors, out=None), sensors


def test_a_silent_fingertip_fails_the_tare_after_the_silence_not_the_whole_timeout(hand) -> None:
    ids = [f.sensor_id for f in hand.fingers]
    silent = hand.fingers[2]
    with TactileBridgeEmulator(ids, rate_hz=hand.rate_hz, mode="binary") as emu:
        monitor, sensors = _monitor(hand, emu)
        try:
            emu.pause(60.0, [silent.sensor_id])
            emu.start()
            t0 = time.monotonic()
            with pytest.raises(SensorStaleError, match=rf"taring: no frame for 0.3 s: {silent.name} \(0/"):
                monitor.take_tare(timeout_s=30.0, silent_s=0.3)
            assert time.monotonic() - t0 < 10.0  # well before the 30 s timeout
        finally:
            sensors.close()


def test_a_slow_stream_is_tared_within_the_timeout(hand) -> None:
    """At a quarter of the hand's rate (a loaded machine, a slow bridge) the tare still completes."""
    ids = [f.sensor_id for f in hand.fingers]
    with TactileBridgeEmulator(ids, rate_hz=hand.rate_hz / 4, mode="binary") as emu:
        monitor, sensors = _monitor(hand, emu)
        try:
            emu.start()
            monitor.take_tare()  # the default timeout, as `sensors` uses it
            assert monitor.pipeline.tare.ready
        finally:
            sensors.close()
