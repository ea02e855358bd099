"""The real pyserial backend against the sensor-bridge emulator on a pseudo-terminal."""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.emulators.tactile_bridge import FaultConfig, RecordingSource, SyntheticSource, TactileBridgeEmulator
from grasp_ctrl.errors import ConfigError, HardwareError, SensorStaleError
from grasp_ctrl.files.paths import default_hand_file
from grasp_ctrl.hardware.base import SensorBackend
from grasp_ctrl.tactile_link.serial_sensors import SerialSensors

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="the emulator needs POSIX pseudo-terminals")

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"
TIPS = (0, 1, 2, 3)
NAMES = {0: "index", 1: "middle", 2: "ring", 3: "thumb"}


def wait_until(cond, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.005)
    return cond()


@pytest.fixture
def emulator():
    emus: list[TactileBridgeEmulator] = []

    def make(*args, **kwargs) -> TactileBridgeEmulator:
        emus.append(TactileBridgeEmulator(*args, **kwargs))
        return emus[-1]

    yield make
    for e in emus:
        e.close()


def test_backend_implements_the_sensor_seam(emulator) -> None:
    emu = emulator(TIPS)
    assert isinstance(SerialSensors({emu.port: TIPS}), SensorBackend)


def test_no_intact_frame_lost_at_100hz_4_tips_with_1pct_corruption(emulator) -> None:
    faults = FaultConfig(corrupt_prob=0.006, truncate_prob=0.004, garbage_prob=0.01)
    emu = emulator(TIPS, faults=faults, seed=3)
    with SerialSensors({emu.port: TIPS}, names=NAMES, keep_history=100_000) as sens:
        emu.start()
        time.sleep(3.0)
        emu.stop()
        time.sleep(0.1)
        frames = sens.drain_frames()
        stats = sens.stats()
    got = {(f.sensor_id, f.seq) for f in frames}
    intact, corrupted = emu.intact_sent(), emu.corrupted_sent()
    assert emu.bytes_dropped == 0
    assert len(emu.sent) >= 4 * 250  # ~100 Hz per fingertip for 3 s
    assert len(corrupted) >= 3  # the faults really happened
    assert intact - got == set()  # every uncorrupted frame arrived ...
    assert got & corrupted == set()  # ... and no damaged one got through
    assert len(frames) == len(got) == len(intact) == stats["frames"]
    assert stats["crc_errors"] >= 1 and stats["resyncs"] >= 1
    # Every loss shows up in the sequence counters: lost = damaged frames followed by a good one.
    last_good = {sid: max(seq for s, seq in intact if s == sid) for sid in TIPS}
    assert stats["seq_lost"] == sum(1 for sid, seq in corrupted if seq < last_good[sid])
    for sid in TIPS:
        t = [f.t_recv for f in frames if f.sensor_id == sid]
        assert all(b >= a for a, b in zip(t, t[1:]))
        assert all(f.values.shape == (44,) for f in frames)


def test_read_latest_gives_newest_frame_per_tip(emulator) -> None:
    emu = emulator(TIPS, seed=1)
    with SerialSensors({emu.port: TIPS}) as sens:
        assert sens.read_latest() == {}
        emu.start()
        sens.wait_for_frames(timeout_s=2.0, min_frames=20)
        latest = sens.read_latest()
        assert set(latest) == set(TIPS)
        for sid, frame in latest.items():
            assert frame.sensor_id == sid and frame.values.shape == (44,)
            assert abs(frame.t_recv - time.monotonic()) < 0.5
        counts = sens.frame_counts()
        assert min(counts.values()) >= 20
        # the newest seq, not the first: seq increments by one per frame from 0
        assert all(latest[s].seq >= counts[s] - 1 for s in TIPS)
        sens.check_stale()


def test_pause_makes_the_tip_stale_and_it_recovers(emulator) -> None:
    emu = emulator(TIPS, seed=2)
    with SerialSensors({emu.port: TIPS}, names=NAMES, stale_after_s=0.05) as sens:
        emu.start()
        sens.wait_for_frames(timeout_s=2.0, min_frames=10)
        sens.check_stale()
        t_pause = time.monotonic()
        emu.pause(0.2, sensor_ids=[2])
        caught: SensorStaleError | None = None
        t_caught = None
        while time.monotonic() - t_pause < 0.19:  # a 100 Hz control loop calling check_stale every tick
            try:
                sens.check_stale()
            except SensorStaleError as exc:
                caught, t_caught = exc, time.monotonic()
                break
            time.sleep(0.01)
        assert caught is not None, "a 0.2 s pause must make the fingertip stale"
        assert caught.reason == "sensor_stale" and isinstance(caught, HardwareError)
        assert "ring (sensor 2" in str(caught)
        assert t_caught - t_pause < 0.05 + 0.1
        # After the pause the tip streams again and the fault clears.
        assert wait_until(lambda: _healthy(sens), 1.0)
        assert sens.stats()["seq_gaps"] >= 1


def _healthy(sens: SerialSensors) -> bool:
    try:
        sens.check_stale()
        return True
    except HardwareError:
        return False


def test_tip_that_never_sends_is_stale(emulator) -> None:
    emu = emulator((0, 1))
    with SerialSensors({emu.port: (0, 1, 5)}, names={5: "pinky"}) as sens:
        emu.start()
        time.sleep(0.2)
        with pytest.raises(SensorStaleError, match=r"pinky \(sensor 5 .*since start"):
            sens.check_stale()
        with pytest.raises(SensorStaleError, match="pinky"):
            sens.wait_for_frames(timeout_s=0.1)


def test_unplug_is_reported_clearly_and_replug_reconnects(emulator) -> None:
    emu = emulator(TIPS, seed=4)
    with SerialSensors({emu.port: TIPS}, names=NAMES, reconnect_interval_s=0.05) as sens:
        emu.start()
        sens.wait_for_frames(timeout_s=2.0, min_frames=5)
        emu.disconnect()
        assert wait_until(lambda: not sens.connected, 1.0)
        with pytest.raises(HardwareError) as info:
            sens.check_stale()
        err = info.value
        # an unplugged tactile port is a stale sensor, not a servo fault
        assert isinstance(err, SensorStaleError) and err.reason == "sensor_stale"
        msg = str(err)
        assert f"tactile port {emu.port} disconnected" in msg and "index, middle, ring, thumb" in msg
        assert "reconnecting" in msg
        assert sens.stats()["disconnects"] == 1
        emu.replug()
        assert wait_until(lambda: sens.connected, 1.0)
        assert wait_until(lambda: _healthy(sens), 1.0)
        assert sens.stats()["reconnects"] == 1


def test_unplug_without_reconnect_stays_down(emulator) -> None:
    emu = emulator((0,))
    with SerialSensors({emu.port: (0,)}, reconnect=False) as sens:
        emu.start()
        sens.wait_for_frames(timeout_s=2.0)
        emu.disconnect()
        assert wait_until(lambda: not sens.connected, 1.0)
        emu.replug()
        time.sleep(0.2)
        assert not sens.connected
        with pytest.raises(HardwareError, match="reconnect is off"):
            sens.check_stale()


def test_missing_port_fails_at_start_with_the_port_name(tmp_path) -> None:
    sens = SerialSensors({str(tmp_path / "ttyNOPE"): (0,)})
    with pytest.raises(HardwareError, match=r"tactile port .*ttyNOPE: cannot open"):
        sens.start()


def test_text_mode_over_pty(emulator) -> None:
    emu = emulator((0, 1), mode="text", seed=5)
    with SerialSensors({emu.port: (0, 1)}, mode="text", keep_history=10_000) as sens:
        emu.start()
        time.sleep(0.8)
        emu.stop()
        time.sleep(0.05)
        got = {(f.sensor_id, f.seq) for f in sens.drain_frames()}
    assert len(got) >= 100 and got == emu.intact_sent()


def test_unexpected_sensor_id_is_counted_not_delivered(emulator) -> None:
    emu = emulator((0, 7))
    with SerialSensors({emu.port: (0,)}) as sens:
        emu.start()
        sens.wait_for_frames(timeout_s=2.0, min_frames=10)
        assert set(sens.read_latest()) == {0}
        assert sens.stats()["unexpected_sensor_frames"] >= 5


def test_one_port_per_fingertip_from_the_hand_file(emulator, tmp_path) -> None:
    hand = load_hand(default_hand_file())
    emus = {
        f.name: emulator((f.sensor_id,), link_dir=tmp_path, link_name=f"tty_{f.name}", seed=f.sensor_id)
        for f in hand.fingers
    }
    tactile = dataclasses.replace(hand.tactile, ports=tuple((n, e.port) for n, e in emus.items()))
    sens = SerialSensors.from_hand(dataclasses.replace(hand, tactile=tactile))
    with sens:
        for e in emus.values():
            e.start()
        sens.wait_for_frames(timeout_s=2.0, min_frames=5)
        assert sens.stats()["ports"] == 4
        assert set(sens.read_latest()) == {f.sensor_id for f in hand.fingers}
    # --port puts every fingertip on one port
    single = SerialSensors.from_hand(hand, port="/dev/null-tactile")
    assert single.stats()["ports"] == 1 and single.stale_after_s == hand.tactile.stale_after_s


def test_hand_file_tactile_ports_are_parsed_and_checked(tmp_path) -> None:
    text = default_hand_file().read_text()
    good = tmp_path / "hand.toml"
    good.write_text(text.replace("[tactile]\n", '[tactile]\nports = { index = "/dev/ttyACM7" }\n', 1))
    hand = load_hand(good)
    assert hand.tactile.port_for("index") == "/dev/ttyACM7"
    assert hand.tactile.port_for("thumb") == hand.tactile.port
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("[tactile]\n", '[tactile]\nports = { pinky = "/dev/ttyACM7" }\n', 1))
    with pytest.raises(ConfigError, match="tactile.ports.pinky"):
        load_hand(bad)


def test_synthetic_source_presses_like_a_biotac() -> None:
    src = SyntheticSource(seed=0)
    frames = np.array([src(0, k) for k in range(500)])
    assert np.ptp(frames[:100, 19]) < 20  # free of contact at first (time to tare)
    assert frames.min() >= 0 and frames.max() <= 4095
    pdc = frames[:, 19].astype(float)
    pad = frames[:, 16:19].mean(axis=1)
    assert pdc.max() - pdc.min() > 200
    assert np.corrcoef(pdc, pad)[0, 1] < -0.9  # electrodes drop as pdc rises


def test_recording_source_replays_the_real_recording() -> None:
    path = DATA / "robotic_finger" / "robotic_finger_tidy.csv"
    if not path.is_file():
        pytest.skip("shared data folder absent")
    src = RecordingSource(path, max_rows=500)
    import csv

    with open(path, newline="") as fh:
        row = next(iter(csv.DictReader(fh)))
    frame = src(0, 0)
    assert list(frame[:19]) == [int(row[f"e{i}"]) for i in range(1, 20)]
    assert frame[19] == int(row["pdc"])
    assert frame.shape == (44,) and frame.max() <= 4095
