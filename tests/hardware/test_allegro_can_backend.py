"""The Allegro's CAN backend (hardware/allegro/) against its emulator on python-can's virtual bus:
the PD law, the safe stops, and a bus that drops, corrupts, delays and reorders frames."""

from __future__ import annotations

import itertools
import os
import random
import signal
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.errors import HardwareError, UsageError
from grasp_ctrl.hardware.allegro import protocol as pr
from grasp_ctrl.hardware.allegro.protocol import CanFrame, JointMap
from grasp_ctrl.rigs.registry import backend, from_flags

ROOT = Path(__file__).resolve().parents[2]
ALLEGRO = ROOT / "hand_configs" / "allegro_hand.toml"
_channels = itertools.count()


@pytest.fixture(scope="module")
def allegro():
    return load_hand(ALLEGRO)


# ---- the registry (no python-can needed) ------------------------------------------------------------
def test_the_registry_names_the_can_backends(allegro):
    assert from_flags("allegro_can").kind == "real"
    emulated = from_flags("allegro_can", emulate=True)
    assert emulated.kind == "emulated" and emulated.truth and not emulated.parallel
    leap = load_hand(ROOT / "hand_configs" / "leap_hand.toml")
    with pytest.raises(UsageError, match=r"--backend allegro_can --emulate drives actuator = 'torque_pd' hands.*"):
        emulated.check_hand(leap)
    with pytest.raises(UsageError, match=r"--backend dynamixel drives .*\(--backend allegro_can\)"):
        backend("dynamixel").check_hand(allegro)
    from grasp_ctrl.emulators.allegro_can_world import allegro_emulated_backends, allegro_realtime_backends

    assert emulated.make_backends() is allegro_emulated_backends
    assert emulated.make_backends(realtime=True) is allegro_realtime_backends


def test_without_python_can_the_backend_is_one_line_naming_the_extra(allegro, monkeypatch):
    monkeypatch.setitem(sys.modules, "can", None)  # import can -> ImportError
    with pytest.raises(UsageError) as exc:
        from_flags("allegro_can", emulate=True).check_hand(allegro)
    assert "pip install -e '.[can]'" in str(exc.value) and "\n" not in str(exc.value)


# ---- on the virtual bus ----------------------------------------------------------------------------------
can = pytest.importorskip("can")

from grasp_ctrl.emulators.allegro_can import AllegroCANEmulator, virtual_link
from grasp_ctrl.hardware.allegro import AllegroCANHand


class FaultyLink:
    """A CanLink that records what is sent and drops, corrupts, delays and reorders what comes in."""

    def __init__(self, inner, seed=0, drop=0.0, corrupt=0.0, delay=0.0, reorder=0.0):
        self.inner = inner
        self.rng = random.Random(seed)
        self.drop, self.corrupt, self.delay, self.reorder = drop, corrupt, delay, reorder
        self.sent: list[CanFrame] = []
        self.held: list[tuple[float, CanFrame]] = []

    def send(self, frame):
        self.sent.append(frame)
        self.inner.send(frame)

    def _mangle(self, f: CanFrame) -> CanFrame:
        kind = self.rng.randrange(4)
        if kind == 0:  # a byte flipped
            data = bytearray(f.data or b"\0")
            data[self.rng.randrange(len(data))] ^= 0xFF
            return CanFrame(f.arbitration_id, bytes(data))
        if kind == 1:  # truncated
            return CanFrame(f.arbitration_id, f.data[: self.rng.randrange(8)])
        if kind == 2:  # another id
            return CanFrame(self.rng.randrange(0x800), f.data)
        return CanFrame(f.arbitration_id, b"", is_remote=True)

    def recv(self, timeout_s):
        now = time.monotonic()
        for i, (t, f) in enumerate(self.held):
            if t <= now:
                del self.held[i]
                return f
        f = self.inner.recv(timeout_s)
        if f is None:
            return None
        r = self.rng.random
        if r() < self.drop:
            return None
        if r() < self.corrupt:
            f = self._mangle(f)
        if r() < self.delay:
            self.held.append((now + self.rng.uniform(0.0, 0.01), f))
            return None
        if r() < self.reorder:  # behind the next frame
            self.held.append((now, f))
            return None
        return f

    def close(self):
        self.inner.close()

    def torque_frames(self, since: int = 0) -> list[tuple[int, tuple[int, int, int, int]]]:
        out = []
        for f in self.sent[since:]:
            if pr.CMD_SET_TORQUE <= f.command < pr.CMD_SET_TORQUE + 4:
                out.append(pr.decode_torque(f))
        return out


def _rig(hand, stream=True, threaded=True, **faults):
    ch = f"test-allegro-{os.getpid()}-{next(_channels)}"
    joints = JointMap.from_hand(hand)
    q0 = np.array([j.pregrasp_rad for j in hand.joints])
    emu = AllegroCANEmulator(virtual_link(ch), joints, q0, stream=stream)
    emu.keep_log = True
    emu.start()
    link = FaultyLink(virtual_link(ch), **faults)
    h = AllegroCANHand(hand, link=link, handle_signals=False, threaded=threaded, connect_timeout_s=2.0)
    return h, emu, link, q0


def _wait(cond, timeout_s=1.0):
    end = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > end:
            return False
        time.sleep(0.001)
    return True


def _within_limits(hand, frames) -> bool:
    limit = JointMap.from_hand(hand).torque_limit_nm.reshape(4, 4) * 1200.0
    return all(all(abs(v) <= limit[f, k] + 1e-9 for k, v in enumerate(pwm)) for f, pwm in frames)


def test_connect_holds_the_pose_drives_goals_and_closes_limp(allegro):
    h, emu, link, q0 = _rig(allegro)
    try:
        h.connect()
        # the start-up of SimLab's driver: system off, info, serial, period (3 ms at 333 Hz), system on
        cmds = [f.command for f in link.sent[:5]]
        assert cmds == [pr.CMD_SYSTEM_OFF, pr.RTR_HAND_INFO, pr.RTR_SERIAL, pr.CMD_SET_PERIOD, pr.CMD_SYSTEM_ON]
        assert emu.period_ms == (3, 0, 0) and emu.system_on
        s = h.read()
        assert np.allclose(s.q, q0, atol=pr.RAD_PER_COUNT) and np.all(np.isnan(s.current_a))
        goal = q0.copy()
        goal[1] += 0.04  # ffj1: within the step limit
        h.write_goals(goal)
        assert _wait(lambda: emu.pwm[0, 1] > 100)
        expected = 3.333333 * 0.04 * 1200  # kp x error, the joint at rest
        assert emu.pwm[0, 1] == pytest.approx(expected, abs=3)
        assert _wait(lambda: h.stats().get("period_p50_ms", 0) > 0)
        stats = h.stats()
        assert 2.0 < stats["period_p50_ms"] < 6.0 and stats["period_budget_ms"] == pytest.approx(3.003)
        assert stats["torque_frames"] > 0 and "missed_periods" in stats
    finally:
        h.close()
    assert _wait(lambda: not emu.system_on and not emu.pwm.any() and emu.period_ms == (0, 0, 0))
    emu.close()


def test_the_pd_law_one_period_at_a_time(allegro):
    h, emu, link, q0 = _rig(allegro, stream=False, threaded=False)
    try:
        h.connect()
        loop = h.loop
        goal = np.clip(q0 + 0.05, h.lower, h.upper)
        h.write_goals(goal)
        loop.cycle()
        assert _wait(lambda: emu.torque_frames >= 4)
        st = loop.state
        expected = JointMap.from_hand(allegro).pwm(h.kp * (h.last_goal - st.q) - h.kd * st.dq)
        assert np.array_equal(emu.pwm, expected)
        # no new positions: no new torque (as the driver, which writes only on a full set)
        n = len(link.torque_frames())
        loop.cycle()
        assert len(link.torque_frames()) == n and loop.counters.no_data_cycles >= 1
        # torque off: zero torque frames
        h.set_torque(False)
        emu.send_positions()
        loop.poll(0.05)
        loop.cycle()
        assert all(pwm == (0, 0, 0, 0) for _, pwm in link.torque_frames(len(link.sent) - 4))
    finally:
        h.close()
        emu.close()


def test_a_stale_hand_ends_in_zero_torque_only(allegro):
    h, emu, link, q0 = _rig(allegro)
    try:
        h.connect()
        h.write_goals(q0 + 0.03)
        assert _wait(lambda: emu.pwm.any())
        emu.silent = True  # the hand went away
        assert _wait(lambda: h.loop.fault is not None, 0.5)
        with pytest.raises(HardwareError, match="no full set of joint positions for 0.02 s") as exc:
            h.check_health()
        assert exc.value.reason == "hardware_error"
        mark = len(link.sent)
        h.write_goals(q0 + 0.05)  # accepted, but the loop sends zeros
        time.sleep(0.03)
        after = link.torque_frames(mark)
        assert after and all(pwm == (0, 0, 0, 0) for _, pwm in after)
        with pytest.raises(HardwareError, match="refused after a fault"):
            h.set_torque(True)
        assert h.safe_stop("open")[0].startswith("open: not possible after a fault")
    finally:
        h.close()
        emu.close()


@pytest.mark.parametrize("fault", ["error_frame", "temperature", "status"])
def test_bus_errors_and_a_hot_or_faulted_hand_stop_the_torque(allegro, fault):
    h, emu, link, q0 = _rig(allegro)
    try:
        h.connect()
        if fault == "error_frame":
            emu.send_error_frame()
            match = "error frame"
        elif fault == "temperature":
            emu.set_temperature(2, 91)
            match = "over-temperature: .*91 degC"
        else:
            emu.status = pr.STATUS_INTERNAL_COMM_FAULT
            match = "internal communication fault"
        h.check_health()  # asks for the hand's information and temperatures
        assert _wait(lambda: h.loop.fault is not None, 0.5)
        with pytest.raises(HardwareError, match=match):
            h.check_health()
        mark = len(link.sent)
        time.sleep(0.02)
        assert all(pwm == (0, 0, 0, 0) for _, pwm in link.torque_frames(mark))
    finally:
        h.close()
        emu.close()


def test_a_lossy_corrupting_reordering_bus_never_carries_a_torque_outside_the_limits(allegro):
    h, emu, link, q0 = _rig(allegro, seed=7, drop=0.1, corrupt=0.1, delay=0.1, reorder=0.1)
    allegro_stale = allegro
    try:
        h.connect()
        rng = np.random.default_rng(3)
        end = time.monotonic() + 0.3
        while time.monotonic() < end:
            h.write_goals(q0 + rng.normal(0.0, 2.0, q0.size))  # far beyond the limits
            time.sleep(0.005)
        frames = link.torque_frames()
        assert len(frames) > 20
        assert _within_limits(allegro_stale, frames)
        assert h.loop.counters.bad_frames + h.loop.counters.foreign_frames > 0
    finally:
        h.close()
        emu.close()
    assert _within_limits(allegro, link.torque_frames())


def test_a_bus_that_drops_everything_is_a_stale_fault(allegro):
    h, emu, link, q0 = _rig(allegro)
    try:
        h.connect()
        link.drop = 1.0
        assert _wait(lambda: h.loop.fault is not None, 0.5)
        assert "no full set of joint positions" in h.loop.fault
    finally:
        h.close()
    assert _wait(lambda: not emu.pwm.any())
    emu.close()


def test_an_exception_in_the_with_block_ends_limp(allegro):
    h, emu, link, q0 = _rig(allegro)
    with pytest.raises(RuntimeError):
        with h:
            h.write_goals(q0 + 0.04)
            assert _wait(lambda: emu.pwm.any())
            raise RuntimeError("boom")
    assert _wait(lambda: not emu.system_on and not emu.pwm.any())
    torques = link.torque_frames()
    assert torques[-4:] == [(f, (0, 0, 0, 0)) for f in range(4)]
    emu.close()


def test_sigterm_becomes_system_exit_and_the_hook_is_removed(allegro):
    if signal.getsignal(signal.SIGTERM) not in (signal.SIG_DFL, None):
        pytest.skip("SIGTERM already handled in this process")
    h, emu, link, q0 = _rig(allegro)
    h.handle_signals = True
    try:
        h.connect()
        assert signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
        with pytest.raises(SystemExit):
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1.0)
    finally:
        h.close()
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    assert _wait(lambda: not emu.system_on)
    emu.close()


def test_no_positions_at_connect_is_one_line(allegro):
    h, emu, link, q0 = _rig(allegro)
    emu.silent = True
    h.connect_timeout_s = 0.1
    with pytest.raises(HardwareError, match=r"no joint positions from the hand within 0.1 s"):
        h.connect()
    assert not h.connected
    emu.close()


def test_the_emulated_hand_moves_the_mujoco_world_by_its_torques(allegro):
    pytest.importorskip("mujoco")
    from grasp_ctrl.config.objects import load_objects
    from grasp_ctrl.emulators.allegro_can_world import EmulatedAllegroHand

    objects = load_objects(ROOT / "hand_configs" / "objects.toml", allegro.name)
    entry = from_flags("allegro_can", emulate=True)
    world = entry.make_world()(allegro, objects["lego"], 0, None)
    hand = EmulatedAllegroHand(world, allegro)
    try:
        hand.connect()
        q_start = hand.read().q
        goal = np.array([j.pregrasp_rad for j in allegro.joints])
        for _ in range(60):
            world.step()
            hand.check_health()
            hand.read()
            hand.write_goals(goal)
        s = hand.read()
        assert np.max(np.abs(s.q - goal)) < 0.06, np.abs(s.q - goal)
        assert np.max(np.abs(q_start - goal)) > 0.1  # it did move
        assert hand.can.loop.counters.torque_frames >= 4 * 60
    finally:
        hand.close()
        world.close()
    assert not world.torque_on


def _virtual_hand_file(tmp_path, channel: str) -> Path:
    path = tmp_path / "allegro_virtual.toml"
    text = ALLEGRO.read_text().replace('interface = "socketcan"', 'interface = "virtual"')
    path.write_text(text.replace('channel = "can0"', f'channel = "{channel}"'))
    return path


def test_hand_check_asks_the_hand_and_names_problems(allegro, tmp_path, capsys):
    from grasp_ctrl.cli import main

    ch = f"test-allegro-check-{os.getpid()}-{next(_channels)}"
    path = _virtual_hand_file(tmp_path, ch)
    q0 = np.array([j.open_rad for j in allegro.joints])
    emu = AllegroCANEmulator(virtual_link(ch), JointMap.from_hand(allegro), q0, stream=False)
    emu.start()
    try:
        assert main(["hand-check", "--hand", str(path)]) == 0
        out = capsys.readouterr().out
        assert "hardware version 4" in out and "serial number: EMU00001" in out and "hand-check: OK" in out
        assert out.count("  ok\n") == 16 and not emu.system_on and emu.torque_frames == 0  # read-only
        emu.set_temperature(3, 88)
        emu.status = pr.STATUS_HIGH_TEMPERATURE
        assert main(["hand-check", "--hand", str(path)]) == 1
        err = capsys.readouterr().err
        assert "high-temperature fault" in err and "temperature sensor 3: 88 degC" in err
        assert len(err.strip().splitlines()) == 1
    finally:
        emu.close()
    assert main(["hand-check", "--hand", str(path), "--recover"]) == 2
    assert "power-cycle" in capsys.readouterr().err


def test_both_real_hands_limit_goals_with_the_one_rule() -> None:
    """The Dynamixel and the CAN hand limit a goal as every simulated hand does (``limit_goal``):
    within the step it passes unchanged, bit for bit; beyond it, ``prev`` +- the step; then the
    joint limits."""
    import numpy as np

    from grasp_ctrl.numeric.limits import limit_goal, limited_goal

    rng = np.random.default_rng(3)
    lower, upper = np.full(16, -0.5), np.full(16, 1.5)
    prev = rng.uniform(-0.4, 1.4, 16)
    goal = prev + rng.uniform(-0.02, 0.02, 16) * np.array([1.0, 10.0] * 8)
    out = np.empty(16)
    limit_goal(goal, prev, 0.05, lower, upper, out)
    got = limited_goal(goal, prev, 0.05, lower, upper)
    assert np.array_equal(got, out)
    within = np.abs(goal - prev) <= 0.05
    assert within.any() and (~within).any()
    assert np.array_equal(got[within], np.clip(goal, lower, upper)[within])  # unchanged, not prev + (goal - prev)
    assert np.allclose(np.abs(got - prev)[~within], 0.05)
    assert np.array_equal(limited_goal(np.full(16, 9.0), None, 0.05, lower, upper), upper)
