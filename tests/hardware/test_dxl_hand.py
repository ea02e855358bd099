"""DynamixelHand against the servo-chain emulator, through the real dynamixel_sdk."""

from __future__ import annotations

import time
from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from grasp_ctrl.emulators.dxl_chain import DynamixelChainEmulator
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.base import HandBackend
from grasp_ctrl.hardware.dynamixel import DynamixelHand
from grasp_ctrl.hardware.dynamixel import control_table as ct
from grasp_ctrl.hardware.dynamixel.calibration import Calibration
from tests.dxl_helpers import leap


@pytest.fixture()
def emu() -> Iterator[DynamixelChainEmulator]:
    e = DynamixelChainEmulator.for_hand(leap()).start()
    yield e
    e.stop()


@pytest.fixture()
def hand(emu: DynamixelChainEmulator) -> Iterator[DynamixelHand]:
    h = DynamixelHand(leap(), emu.port, handle_signals=False)
    h.connect()
    yield h
    h.close()


def wait_until(pred, timeout_s: float = 2.0) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(0.01)
    return pred()


def test_is_a_hand_backend(hand: DynamixelHand) -> None:
    assert isinstance(hand, HandBackend)


def test_connect_configures_every_servo(emu: DynamixelChainEmulator, hand: DynamixelHand) -> None:
    cal = Calibration.from_joints(hand.joints)
    lo, hi = cal.limit_counts()
    for k, j in enumerate(hand.joints):
        s = emu.servo(j.servo_id)
        assert s.get((ct.ADDR_OPERATING_MODE, 1)) == ct.MODE_CURRENT_BASED_POSITION
        assert s.get((ct.ADDR_RETURN_DELAY_TIME, 1)) == 0
        assert s.get((ct.ADDR_CURRENT_LIMIT, 2)) == round(j.current_limit_a / 0.001)
        assert s.get((ct.ADDR_MIN_POSITION_LIMIT, 4), True) == lo[k]
        assert s.get((ct.ADDR_MAX_POSITION_LIMIT, 4), True) == hi[k]
        assert s.torque_on
    assert hand.bus.fast_sync_read
    # configuration happened with torque off: the emulator refuses EEPROM writes otherwise
    with pytest.raises(HardwareError, match="access_error"):
        hand.bus.write(0, ct.ADDR_OPERATING_MODE, 1, 3)


def test_read_write_round_trip_in_radians(emu: DynamixelChainEmulator, hand: DynamixelHand) -> None:
    q0 = np.array([j.open_rad for j in hand.joints])
    s = hand.read()
    np.testing.assert_allclose(s.q, q0, atol=2 * ct.RAD_PER_COUNT)
    target = np.array([j.pregrasp_rad for j in hand.joints]) + 0.02
    for _ in range(40):  # open -> pregrasp moves a joint up to 0.6 rad, 0.05 rad per write
        hand.write_goals(target)
    hand.read()  # request/reply: the emulator has handled every earlier packet
    cal = Calibration.from_joints(hand.joints)
    sent = np.array([emu.servo(j.servo_id).goal_history[-1] for j in hand.joints])
    np.testing.assert_array_equal(sent, cal.to_counts(target))
    assert wait_until(lambda: np.allclose(hand.read().q, target, atol=2 * ct.RAD_PER_COUNT))
    state = hand.read()
    assert state.dq.shape == state.current_a.shape == (16,)


def test_units_and_signs_of_velocity_and_current(emu: DynamixelChainEmulator, hand: DynamixelHand) -> None:
    emu.servo(1).set((ct.ADDR_PRESENT_CURRENT, 2), -250)
    emu.servo(1).set((ct.ADDR_PRESENT_VELOCITY, 4), 100)
    hand.torque_enabled = False
    for j in hand.joints:  # torque off freezes the emulated state so we can plant values
        emu.servo(j.servo_id).set((ct.ADDR_TORQUE_ENABLE, 1), 0)
    emu.servo(1).step = lambda dt: None  # type: ignore[method-assign]
    s = hand.read()
    k = [j.servo_id for j in hand.joints].index(1)  # joint vectors follow the file, not the ids
    assert s.current_a[k] == pytest.approx(-0.25)
    assert s.dq[k] == pytest.approx(100 * 0.229 * 2 * np.pi / 60)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.lists(st.floats(-10, 10), min_size=16, max_size=16), min_size=1, max_size=4))
def test_no_goal_outside_the_limits_is_ever_sent(emu: DynamixelChainEmulator, hand: DynamixelHand, goals) -> None:
    cal = Calibration.from_joints(hand.joints)
    lo, hi = cal.limit_counts()
    step_counts = hand.hand.safety.max_joint_step_rad / ct.RAD_PER_COUNT + 1.0
    before = {j.servo_id: len(emu.servo(j.servo_id).goal_history) for j in hand.joints}
    for g in goals:
        hand.write_goals(np.array(g))
    hand.read()
    assert np.all(hand.last_goal >= hand.lower) and np.all(hand.last_goal <= hand.upper)
    for k, j in enumerate(hand.joints):
        hist = emu.servo(j.servo_id).goal_history
        new = np.array(hist[before[j.servo_id] - 1 :], dtype=float)  # include the previous goal
        assert len(new) == len(goals) + 1
        assert np.all((new >= lo[k]) & (new <= hi[k])), j.name
        assert np.all(np.abs(np.diff(new)) <= step_counts), j.name


def test_missing_servo_is_reported_by_name(emu: DynamixelChainEmulator) -> None:
    emu.set_missing(5)
    h = DynamixelHand(leap(), emu.port, handle_signals=False)
    with pytest.raises(HardwareError, match=r"no reply from middle_mcp \(id 5\)"):
        h.connect()
    assert not h.connected


def test_servo_lost_mid_run_is_named(emu: DynamixelChainEmulator, hand: DynamixelHand) -> None:
    emu.set_missing(9)
    with pytest.raises(HardwareError, match=r"ring_mcp \(id 9\)"):
        hand.read()


def test_model_mismatch_is_reported() -> None:
    with DynamixelChainEmulator(range(16), model_number=1020) as e:
        with pytest.raises(HardwareError, match=r"index_abd \(id 0\) is XM430-W350-T, expected XC330-M288-T"):
            DynamixelHand(leap(), e.port, handle_signals=False).connect()


def test_corrupted_replies_are_retried(emu: DynamixelChainEmulator, hand: DynamixelHand) -> None:
    retries = hand.bus.stats.retries
    emu.corrupt_next(2)
    hand.read()
    assert hand.bus.stats.retries == retries + 2
    emu.corrupt_next(3)  # more than the 2 retries of the hand file
    with pytest.raises(HardwareError, match="sync read"):
        hand.read()
    hand.read()  # and the bus is usable again


def test_a_dropped_reply_costs_a_short_timeout(emu: DynamixelChainEmulator) -> None:
    with DynamixelHand(leap(packet_timeout_ms=8.0, retries=5), emu.port, handle_signals=False) as hand:
        hand.read()
        emu.drop_next(1)
        t0 = time.perf_counter()
        hand.read()
        elapsed_ms = (time.perf_counter() - t0) * 1e3
        assert hand.bus.stats.retries >= 1
    # packet_timeout_ms = 8 plus transmission time, not the SDK's ~34 ms
    assert elapsed_ms < 30.0


def test_plain_sync_read_fallback(emu: DynamixelChainEmulator) -> None:
    emu.fast_sync_read_supported = False
    with DynamixelHand(leap(), emu.port, handle_signals=False) as h:
        assert not h.bus.fast_sync_read
        q = h.read().q
        np.testing.assert_allclose(q, [j.open_rad for j in h.joints], atol=2 * ct.RAD_PER_COUNT)
        assert h.bus.stats.plain_sync_reads >= 1


@pytest.mark.parametrize("fast", [True, False])
def test_byte_stuffed_replies_are_decoded(emu: DynamixelChainEmulator, fast: bool) -> None:
    from grasp_ctrl.hardware.dynamixel.bus import DynamixelBus

    # Present position bytes FF FF FD 00 force byte stuffing in the reply.
    s = emu.servo(3)
    s.position_counts = float(0x00FDFFFF)
    s.reset_ram()
    bus = DynamixelBus(emu.port, 4_000_000, {}, fast_sync_read=fast)
    bus.open()
    try:
        res = bus.sync_read([2, 3, 4], ct.ADDR_PRESENT_POSITION, 4)
        assert res.data[3] == b"\xff\xff\xfd\x00"
        assert int.from_bytes(res.data[4], "little") == emu.servo(4).get((132, 4))
    finally:
        bus.close()


def test_overload_mid_run_leads_to_a_safe_stop(emu: DynamixelChainEmulator, hand: DynamixelHand) -> None:
    emu.servo(1).motor.overload_after_s = 0.1
    cal = Calibration.from_joints(hand.joints)
    k = [j.servo_id for j in hand.joints].index(1)  # index_mcp
    emu.block_joint(1, float(cal.to_counts_float(np.array([j.open_rad for j in hand.joints]))[k] + 20))
    target = np.array([j.pregrasp_rad for j in hand.joints])
    target[k] = 1.0  # push index_mcp into the wall
    with pytest.raises(HardwareError) as info:
        for _ in range(300):
            hand.read()
            hand.write_goals(target)
            hand.check_health()
            time.sleep(0.01)
    assert info.value.reason == "hardware_error"
    assert "index_mcp (id 1): overload" in str(info.value)
    problems = hand.safe_stop("open")
    assert problems == []
    assert not any(emu.servo(j.servo_id).torque_on for j in hand.joints)
    # the healthy joints were driven to the open posture before torque off
    sent = np.array([emu.servo(j.servo_id).goal_history[-1] for j in hand.joints])
    open_counts = cal.to_counts(np.array([j.open_rad for j in hand.joints]))
    healthy = [k for k, j in enumerate(hand.joints) if j.servo_id != 1]
    np.testing.assert_array_equal(sent[healthy], open_counts[healthy])
    # recovery: reboot, reconfigure, hold, torque on
    emu.block_joint(1, None)
    hand.recover()
    hand.check_health(force=True)
    assert all(emu.servo(j.servo_id).torque_on for j in hand.joints)
    assert emu.servo(1).get((ct.ADDR_OPERATING_MODE, 1)) == ct.MODE_CURRENT_BASED_POSITION


def test_torque_off_after_an_exception(emu: DynamixelChainEmulator) -> None:
    with pytest.raises(RuntimeError, match="controller bug"):
        with DynamixelHand(leap(on_fault="open"), emu.port, handle_signals=False) as h:
            h.write_goals(np.array([j.pregrasp_rad for j in h.joints]))
            assert all(emu.servo(j.servo_id).torque_on for j in h.joints)
            raise RuntimeError("controller bug")
    assert not any(emu.servo(j.servo_id).torque_on for j in leap().joints)


def test_hold_keeps_torque_and_the_present_pose(emu: DynamixelChainEmulator) -> None:
    with DynamixelHand(leap(on_fault="hold"), emu.port, handle_signals=False) as h:
        q = h.read().q
    assert all(emu.servo(j.servo_id).torque_on for j in leap().joints)
    cal = Calibration.from_joints(leap().joints)
    expected = cal.to_counts(q)
    last_sent = lambda: np.array([emu.servo(j.servo_id).goal_history[-1] for j in leap().joints])  # noqa: E731
    assert wait_until(lambda: np.all(np.abs(last_sent() - expected) <= 1))


def test_health_polling_follows_the_alert_bit(emu: DynamixelChainEmulator) -> None:
    from grasp_ctrl.emulators import dxl_protocol as p

    class FrozenClock:
        t = 0.0

        def now(self) -> float:
            return self.t

    clock = FrozenClock()
    with DynamixelHand(leap(), emu.port, clock=clock, handle_signals=False, health_poll_s=1.0) as h:
        h.check_health()  # first call polls
        polls = emu.instructions[p.INST_FAST_SYNC_READ]
        for _ in range(5):
            h.read()
            h.check_health()  # no alert, interval not over: no extra bus traffic
        assert emu.instructions[p.INST_FAST_SYNC_READ] == polls + 5
        emu.inject_hardware_error(7, 0x04)
        h.read()  # the alert bit rides on this reply ...
        with pytest.raises(HardwareError, match=r"middle_dip \(id 7\): overheating"):
            h.check_health()  # ... so the register is polled at once
        clock.t = 2.0
        with pytest.raises(HardwareError):
            h.check_health()  # and on the interval


def test_gains_from_the_hand_file_are_written(emu: DynamixelChainEmulator, hand: DynamixelHand) -> None:
    for j in hand.joints:
        s = emu.servo(j.servo_id)
        # the LEAP API's gains, 0.75x on the abduction joints (gain_scale)
        expected = (450, 0, 150) if j.servo_id in (0, 4, 8) else (600, 0, 200)
        assert (s.get((84, 2)), s.get((82, 2)), s.get((80, 2))) == expected, j.name
