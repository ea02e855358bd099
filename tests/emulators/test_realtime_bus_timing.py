"""The bus's real time for the realtime dry run: wire time, return delay and the FTDI latency
timer (emulators/bus_timing.py), the timed servo-chain emulator, and the pre-flight's bus budget."""

from __future__ import annotations

import statistics
import time
from dataclasses import replace

import pytest

from grasp_ctrl.emulators import dxl_protocol as p
from grasp_ctrl.emulators.bus_timing import (
    BusTiming,
    FtdiReceiveBuffer,
    reply_schedule,
    return_delay_s,
    sync_read_reply_bytes,
    sync_read_request_bytes,
    sync_write_bytes,
    tick_bus_time_s,
    wire_time_s,
)
from grasp_ctrl.emulators.dxl_chain import DynamixelChainEmulator
from grasp_ctrl.trials.episode.preflight import adapter_latency_ms, bus_budget_warning

pytestmark = pytest.mark.skipif(not hasattr(__import__("os"), "openpty"), reason="needs POSIX pseudo-terminals")

STATE = (126, 10)  # present current, velocity, position


def test_wire_time_and_return_delay() -> None:
    assert wire_time_s(232, 4_000_000) == pytest.approx(232 * 10 / 4e6)  # 10 bits a byte
    assert wire_time_s(1, 57_600) == pytest.approx(10 / 57_600)
    assert return_delay_s(250) == pytest.approx(500e-6)  # factory default: 500 us
    assert return_delay_s(0) == 0.0


def test_packet_sizes_match_what_the_emulator_and_the_protocol_build() -> None:
    ids = bytes(range(16))
    params = bytes([STATE[0], 0, STATE[1], 0]) + ids
    assert len(p.build_packet(p.BROADCAST_ID, p.INST_FAST_SYNC_READ, params)) == sync_read_request_bytes(16)
    emu = DynamixelChainEmulator(range(16))
    fast = emu._handle(p.Packet(p.BROADCAST_ID, p.INST_FAST_SYNC_READ, params), p.BROADCAST_ID)
    plain = emu._handle(p.Packet(p.BROADCAST_ID, p.INST_SYNC_READ, params), p.BROADCAST_ID)
    assert len(fast) == sync_read_reply_bytes(16, 10) == 232
    assert len(plain) == sync_read_reply_bytes(16, 10, fast=False)
    goals = bytes([116, 0, 4, 0]) + b"".join(bytes([i, 0, 8, 0, 0]) for i in range(16))
    assert len(p.build_packet(p.BROADCAST_ID, p.INST_SYNC_WRITE, goals)) == sync_write_bytes(16, 4)


def test_a_short_reply_waits_for_the_latency_timer() -> None:
    timing = BusTiming(4_000_000, 0.016)
    adapter = FtdiReceiveBuffer(timing, anchor=0.0)
    # a ping's 14-byte status, its last byte on the wire at 5.035 ms: held until the timer's 16 ms tick
    flushes = reply_schedule(timing, adapter, t_request_end=0.005, n_reply=14, return_delay=0.0)
    assert flushes == [(pytest.approx(0.016), 14)]
    # the next one starts after that tick: it waits for the one 16 ms later
    flushes = reply_schedule(timing, adapter, t_request_end=0.0165, n_reply=14, return_delay=0.0)
    assert flushes == [(pytest.approx(0.032), 14)]


def test_full_usb_packets_go_at_once_and_restart_the_timer() -> None:
    timing = BusTiming(4_000_000, 0.016)
    adapter = FtdiReceiveBuffer(timing, anchor=0.0)
    byte = timing.byte_s
    flushes = reply_schedule(timing, adapter, t_request_end=0.001, n_reply=232, return_delay=0.0)
    # 232 bytes: three full 62-byte packets as they fill, the 46-byte tail a whole timer after the last
    assert [n for _, n in flushes] == [62, 62, 62, 46]
    for k, (t, _) in enumerate(flushes[:3]):
        assert t == pytest.approx(0.001 + 62 * (k + 1) * byte)
    assert flushes[3][0] == pytest.approx(0.001 + 186 * byte + 0.016)
    # the return delay comes before the first byte
    later = reply_schedule(timing, FtdiReceiveBuffer(timing), 0.001, 62, return_delay=return_delay_s(250))
    assert later == [(pytest.approx(0.001 + 500e-6 + 62 * byte), 62)]


def test_a_slow_line_is_flushed_byte_by_byte_by_a_short_timer() -> None:
    timing = BusTiming(9_600, 0.001)  # a byte takes 1.04 ms: the 1 ms timer fires between bytes
    flushes = FtdiReceiveBuffer(timing).flushes([0.0005 + k * 10 / 9600 for k in range(3)])
    assert [n for _, n in flushes] == [1, 1, 1]
    assert all(b > a for (a, _), (b, _) in zip(flushes, flushes[1:]))


def test_bus_timing_rejects_nonsense() -> None:
    with pytest.raises(ValueError):
        BusTiming(0, 0.001)
    with pytest.raises(ValueError):
        BusTiming(4_000_000, 0.0)


def test_a_tick_fits_at_1_ms_and_not_at_16_ms() -> None:
    fast = tick_bus_time_s(16, 4_000_000, 0.001)
    slow = tick_bus_time_s(16, 4_000_000, 0.016)
    assert fast.worst_s < 0.005 < 0.010 < slow.worst_s  # half of a 10 ms tick / more than the tick
    assert slow.state_read_s > 0.016  # every read waits for the timer


def _fast_sync_reads(timing: BusTiming, n: int) -> tuple[DynamixelChainEmulator, list[float]]:
    """``n`` back-to-back fast sync reads of 16 servos' state through the SDK; host round trips (s)."""
    from dynamixel_sdk import COMM_SUCCESS, GroupSyncRead, PacketHandler, PortHandler

    emu = DynamixelChainEmulator(range(16), timing=timing).start()
    port = PortHandler(emu.port)
    assert port.openPort() and port.setBaudRate(4_000_000)
    reader = GroupSyncRead(port, PacketHandler(2.0), *STATE)
    for i in range(16):
        reader.addParam(i)
    if not hasattr(reader, "fastSyncRead"):
        port.closePort()
        emu.stop()
        pytest.skip("dynamixel_sdk without Fast Sync Read")
    rtts = []
    try:
        for _ in range(n):
            t = time.monotonic()
            assert reader.fastSyncRead() == COMM_SUCCESS
            rtts.append(time.monotonic() - t)
    finally:
        port.closePort()
        emu.stop()
    return emu, rtts


def test_the_timed_chain_holds_replies_as_the_bus_and_the_adapter_would() -> None:
    timing = BusTiming(4_000_000, 0.016)
    emu, rtts = _fast_sync_reads(timing, 6)
    replies = list(emu.replies)
    assert len(replies) == len(rtts) == 6
    wire = wire_time_s(232, 4_000_000)
    for r, rtt in zip(replies, rtts):
        assert r.n_bytes == 232
        # the servos' return delay (factory 500 us) and the wire come first, then the adapter holds
        # the tail a whole timer after the last full USB packet
        assert r.t_last - r.t_request_end >= 500e-6 + 186 * timing.byte_s + 0.016 - 1e-9
        assert r.t_last - r.t_request_end <= 500e-6 + wire + 0.016 + 1e-6
        assert rtt >= r.t_last - r.t_request_end  # the host never has a reply before the adapter sends it
    # at 1 ms the same reads come back far sooner (generous: a loaded host)
    _, quick = _fast_sync_reads(BusTiming(4_000_000, 0.001), 6)
    assert statistics.median(quick) < 0.010 < 0.016 <= statistics.median(rtts)


def test_the_preflight_names_a_16_ms_latency_timer_and_the_fix(hand) -> None:
    assert bus_budget_warning(hand, "hand_configs/leap_hand.toml") is None  # the shipped 1 ms
    slow = replace(hand, dynamixel=replace(hand.dynamixel, latency_timer_ms=16))
    text = bus_budget_warning(slow, "my_hand.toml")
    assert text is not None and "\n" not in text
    assert "servo bus too slow for the 10 ms control tick" in text
    assert "latency timer 16 ms, [dynamixel] latency_timer_ms in my_hand.toml" in text
    assert "fix: set latency_timer_ms = 1 in the hand file" in text
    assert "echo 1 | sudo tee /sys/bus/usb-serial/devices/ttyUSB0/latency_timer" in text
    assert "udev rule" in text
    assert "outlast packet_timeout_ms = 8" in text  # replies held past the reply deadline
    slow_line = replace(hand, dynamixel=replace(hand.dynamixel, baud=57_600))
    assert "[dynamixel] baud to 4000000" in bus_budget_warning(slow_line)


def test_an_adapter_stuck_at_16_ms_is_read_from_sysfs(tmp_path, monkeypatch, hand) -> None:
    sysfs = tmp_path / "sys"
    (sysfs / "ttyUSB3").mkdir(parents=True)
    (sysfs / "ttyUSB3" / "latency_timer").write_text("16\n")
    port = tmp_path / "ttyUSB3"  # stands for /dev/ttyUSB3: only its name is used
    port.write_text("")
    assert adapter_latency_ms(str(port), 1, str(sysfs)) is None  # writable: connect sets it
    monkeypatch.setattr("grasp_ctrl.trials.episode.preflight.os.access", lambda path, mode: False)
    assert adapter_latency_ms(str(port), 1, str(sysfs)) == 16
    assert adapter_latency_ms(str(port), 16, str(sysfs)) is None  # as configured
    assert adapter_latency_ms(str(tmp_path / "ttyACM0"), 1, str(sysfs)) is None  # no latency timer
    text = bus_budget_warning(replace(hand, dynamixel=replace(hand.dynamixel, port=str(port))), None, 16)
    assert "/sys/bus/usb-serial/devices/ttyUSB3/latency_timer, which could not be set" in text
