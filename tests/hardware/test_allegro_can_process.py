"""The Allegro's PD loop in its own process (hardware/allegro/pd_process.py): the emulated hand on
the other end of a socket pair notes every torque frame with its arrival time, so what reaches
the hand is checked whichever process sent it.

- torques within the hand file's limits whatever goal arrives, the process reaped at the end;
- each fault class (stale positions, an error frame, over-temperature, Ctrl-C, SIGTERM, the
  program's exit, the PD process killed) ends in zero torque on every finger within one control
  period (10 ms) and only zero torque after it, with the fault named;
- the control process killed outright, or stopped (no heartbeat): the PD process applies
  ``on_fault`` itself, and ends once the control process has gone;
- ``run --backend allegro_can --emulate`` (lockstep and ``--realtime``) interrupted by Ctrl-C or
  SIGTERM to its process group: the trial's record names the interrupt, nothing is left running.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from allegro_torques import CONTROL_PERIOD_S, control_loop_until_signal, zero_torque_after

from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.allegro.child import SocketLink, socket_pair
from grasp_ctrl.hardware.allegro.protocol import JointMap

can = pytest.importorskip("can")

from grasp_ctrl.emulators.allegro_can import AllegroCANEmulator  # noqa: E402
from grasp_ctrl.hardware.allegro import AllegroCANHand  # noqa: E402
from grasp_ctrl.hardware.allegro.pd_process import HEARTBEAT_S, HEARTBEAT_STALE_S  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
ALLEGRO = ROOT / "hand_configs" / "allegro_hand.toml"
pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="child processes, /proc (Linux)")


@pytest.fixture(scope="module")
def allegro():
    return load_hand(ALLEGRO)


def _torque_off(hand):
    return replace(hand, safety=replace(hand.safety, on_fault="torque_off"))


class _HandEnd(SocketLink):
    """The hand's end: it goes on reporting, to nobody, once the host's end has closed."""

    def send(self, frame) -> None:
        try:
            super().send(frame)
        except HardwareError:
            pass

    def recv(self, timeout_s: float):
        try:
            return super().recv(timeout_s)
        except HardwareError:  # (once)
            return None


class Hand:
    """The emulated hand (a thread here) on one end of a socket pair, its torque frames logged."""

    def __init__(self, hand) -> None:
        self.hand_end, self.host_end = socket_pair()
        self.q0 = np.array([j.pregrasp_rad for j in hand.joints])
        self.map = JointMap.from_hand(hand)
        self.emu = AllegroCANEmulator(_HandEnd(self.hand_end, "emulated"), self.map, self.q0, stream=True)
        self.emu.keep_log = True
        self.emu.start()

    def torques(self) -> list[tuple[float, int, tuple[int, int, int, int]]]:
        """(arrival time on time.monotonic, finger, PWM values)."""
        offset = time.monotonic() - time.perf_counter()
        with self.emu._lock:
            return [(t + offset, f, p) for t, (f, p) in zip(self.emu.torque_times, self.emu.torque_log)]

    def close(self) -> None:
        self.emu.close()


def _wait(cond, timeout_s=2.0) -> bool:
    end = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > end:
            return False
        time.sleep(0.0005)
    return True


def _gone(pid: int, timeout_s: float = 2.0) -> bool:
    """No process ``pid`` any more (reaped, not a zombie)."""
    return _wait(lambda: not Path(f"/proc/{pid}").exists(), timeout_s)


def _rig(hand):
    rig = Hand(hand)
    h = AllegroCANHand(hand, link=SocketLink(rig.host_end, "host"), handle_signals=False, connect_timeout_s=2.0)
    assert h.pd_process
    return h, rig


# ---- torques, reaping -----------------------------------------------------------------------------------
def test_the_pd_process_clamps_every_torque_and_is_reaped(allegro):
    h, rig = _rig(_torque_off(allegro))
    try:
        h.connect()
        pid = h.loop.child.proc.pid
        for _ in range(30):  # goals far away: the step limit, then the joint limits
            h.write_goals(rig.q0 + 2.0)
            h.check_health()
            time.sleep(CONTROL_PERIOD_S)
        # a goal beyond the joint limits written past the backend's own clamps
        h.loop.block.write_seq("goal_seq", {"goal_q": rig.q0 + 50.0, "goal_active": 1.0})
        time.sleep(0.1)
        figures = h.loop.period_figures()
        assert figures["periods"] > 30 and figures["period_ms"]["p50"] == pytest.approx(3.0, abs=0.5)
        assert h.read().q.shape == rig.q0.shape
    finally:
        h.close()
    assert _gone(pid), "the PD process is still there after close"
    log = rig.torques()
    assert sum(1 for _, _, p in log if any(p)) > 100
    limit = np.zeros((4, 4))
    m = JointMap.from_hand(allegro)
    limit[m.finger, m.slot] = m.torque_limit_nm * m.pwm_per_nm
    for _, finger, pwm in log:
        assert np.all(np.abs(pwm) <= limit[finger] + 1e-9), (finger, pwm)
    assert not rig.emu.system_on and rig.emu.period_ms == (0, 0, 0) and not rig.emu.pwm.any()
    rig.close()


# ---- the link's faults --------------------------------------------------------------------------------
@pytest.mark.parametrize("fault", ["stale", "error_frame", "over_temperature"])
def test_a_link_fault_reaches_zero_torque_within_one_control_period(allegro, fault):
    h, rig = _rig(allegro)
    try:
        h.connect()
        h.write_goals(rig.q0 + 0.04)
        assert _wait(lambda: rig.emu.pwm.any())
        time.sleep(0.05)
        if fault == "stale":
            rig.emu.silent = True
            match = "no full set of joint positions for 0.02 s"
        elif fault == "error_frame":
            rig.emu.send_error_frame()
            match = "error frame"
        else:
            rig.emu.set_temperature(1, 85)  # the PD process asks every 0.1 s
            match = r"over-temperature: .*85 degC \(limit 70 degC"
        assert _wait(lambda: h.loop.fault is not None)
        t_fault = h.loop.fault_time
        time.sleep(0.03)
        t_safe = zero_torque_after(rig.torques(), t_fault)
        assert t_safe - t_fault <= CONTROL_PERIOD_S, f"zero torque {1e3 * (t_safe - t_fault):.1f} ms after the fault"
        with pytest.raises(HardwareError, match=match) as exc:
            h.check_health()
        assert exc.value.reason == "hardware_error"
        h.write_goals(rig.q0 + 0.05)  # goals after the fault: still zero torque only
        time.sleep(0.02)
    finally:
        h.close()
    assert _wait(lambda: not rig.emu.system_on and not rig.emu.pwm.any())
    zero_torque_after(rig.torques(), t_fault)
    rig.close()


def test_the_pd_process_killed_is_a_fault_and_the_last_frames_come_from_here(allegro):
    h, rig = _rig(allegro)
    try:
        h.connect()
        h.write_goals(rig.q0 + 0.04)
        assert _wait(lambda: rig.emu.pwm.any())
        os.kill(h.loop.child.proc.pid, signal.SIGKILL)
        assert _wait(lambda: not h.loop.running)
        with pytest.raises(HardwareError, match="the PD loop's process stopped"):
            h.check_health()
        t_close = time.monotonic()
    finally:
        h.close()
    assert _wait(lambda: not rig.emu.system_on and rig.emu.period_ms == (0, 0, 0))
    zero_torque_after(rig.torques(), t_close)
    rig.close()


# ---- Ctrl-C and SIGTERM in the control loop ---------------------------------------------------------
def _control_loop_until_signal(h, q0, sig) -> float:
    """``control_loop_until_signal``, the signal also to the PD process (as a terminal sends it to
    the whole group; the PD process ignores it); when it was sent on ``time.monotonic``."""
    return control_loop_until_signal(h, q0, sig, time.monotonic, lambda: os.kill(h.loop.child.proc.pid, sig))


def test_ctrl_c_reaches_zero_torque_within_one_control_period(allegro, sigint_raises):
    h, rig = _rig(_torque_off(allegro))
    t_sig = _control_loop_until_signal(h, rig.q0, signal.SIGINT)
    t_safe = zero_torque_after(rig.torques(), t_sig)
    assert t_safe - t_sig <= CONTROL_PERIOD_S, f"zero torque {1e3 * (t_safe - t_sig):.1f} ms after Ctrl-C"
    assert _wait(lambda: not rig.emu.system_on and rig.emu.period_ms == (0, 0, 0))
    rig.close()


def test_sigterm_opens_the_hand_then_ends_in_zero_torque(allegro):
    if signal.getsignal(signal.SIGTERM) not in (signal.SIG_DFL, None):
        pytest.skip("SIGTERM already handled in this process")
    h, rig = _rig(allegro)  # on_fault = "open"
    h.handle_signals = True
    t_sig = _control_loop_until_signal(h, rig.q0, signal.SIGTERM)
    after = [x for x in rig.torques() if x[0] >= t_sig]
    assert any(any(p) for _, _, p in after), "no open ramp after the signal"
    t_safe = zero_torque_after(after, t_sig)
    assert t_safe > t_sig
    assert _wait(lambda: not rig.emu.system_on and not rig.emu.pwm.any())
    rig.close()


# ---- the control process gone or stopped -------------------------------------------------------------------
CONTROL = r"""
import sys, time
import numpy as np
from dataclasses import replace
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.allegro import AllegroCANHand
from grasp_ctrl.hardware.allegro.child import SocketLink

hand = load_hand(sys.argv[1])
hand = replace(hand, safety=replace(hand.safety, on_fault=sys.argv[3]))
h = AllegroCANHand(hand, link=SocketLink.from_fd(int(sys.argv[2]), "host"), connect_timeout_s=5.0)
h.connect()
print(h.loop.child.proc.pid, flush=True)
q0 = np.array([j.pregrasp_rad for j in hand.joints])
try:
    while True:
        h.check_health()
        h.write_goals(q0 + 0.04)
        time.sleep(0.01)
except HardwareError as exc:
    print(exc, flush=True)
    h.close()
"""


def _control_process(allegro, rig, on_fault):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    fd = rig.host_end.fileno()
    proc = subprocess.Popen(
        [sys.executable, "-c", CONTROL, str(ALLEGRO), str(fd), on_fault],
        pass_fds=(fd,),
        stdout=subprocess.PIPE,
        text=True,
        env=env,
        cwd=ROOT,
    )
    rig.host_end.close()
    pd_pid = int(proc.stdout.readline())
    assert _wait(lambda: rig.emu.pwm.any(), 5.0)
    time.sleep(0.1)
    return proc, pd_pid


@pytest.mark.parametrize("on_fault", ["torque_off", "open"])
def test_the_control_process_killed_the_pd_process_applies_on_fault_and_ends(allegro, on_fault):
    rig = Hand(allegro)
    proc, pd_pid = _control_process(allegro, rig, on_fault)
    t_kill = time.monotonic()
    proc.kill()
    proc.wait()  # the kernel has handed the PD process to another parent before this returns
    t_dead = time.monotonic()
    assert _gone(pd_pid, 5.0), "the PD process outlived the control process"
    assert _wait(lambda: not rig.emu.system_on and rig.emu.period_ms == (0, 0, 0))
    after = [x for x in rig.torques() if x[0] >= t_kill]
    t_safe = zero_torque_after(after, t_kill)
    if on_fault == "torque_off":  # (the kernel's teardown of the killed process comes first)
        assert t_safe - t_dead <= CONTROL_PERIOD_S, f"zero torque {1e3 * (t_safe - t_dead):.1f} ms after its death"
    else:  # the open ramp first: torques toward the open posture, then zero
        assert any(any(p) for t, _, p in after if t < t_safe)
    rig.close()


def test_a_stopped_control_process_is_taken_over_after_its_heartbeat_goes_stale(allegro):
    rig = Hand(allegro)
    proc, pd_pid = _control_process(allegro, rig, "torque_off")
    t_stop = time.monotonic()
    proc.send_signal(signal.SIGSTOP)
    try:
        time.sleep(HEARTBEAT_STALE_S + 0.1)
        t_safe = zero_torque_after(rig.torques(), t_stop)
        assert HEARTBEAT_STALE_S - HEARTBEAT_S - 0.01 <= t_safe - t_stop <= HEARTBEAT_STALE_S + CONTROL_PERIOD_S
        assert Path(f"/proc/{pd_pid}").exists()  # the control process lives: the PD process waits for it
    finally:
        proc.send_signal(signal.SIGCONT)
    line = proc.stdout.readline()
    assert "the control process gave no heartbeat" in line and "on_fault = 'torque_off'" in line, line
    assert proc.wait(10) == 0
    assert _gone(pd_pid)
    assert _wait(lambda: not rig.emu.system_on and rig.emu.period_ms == (0, 0, 0))
    zero_torque_after(rig.torques(), t_stop)
    rig.close()


# ---- the program's exit without close -----------------------------------------------------------------
EXIT = r"""
import json, sys, time
import numpy as np
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.emulators.allegro_can import AllegroCANEmulator
from grasp_ctrl.hardware.allegro import AllegroCANHand
from grasp_ctrl.hardware.allegro.child import SocketLink, socket_pair
from grasp_ctrl.hardware.allegro.protocol import JointMap
import atexit

hand = load_hand(sys.argv[1])
q0 = np.array([j.pregrasp_rad for j in hand.joints])
a, b = socket_pair()
emu = AllegroCANEmulator(SocketLink(a, "emulated"), JointMap.from_hand(hand), q0, stream=True)
emu.keep_log = True
emu.start()
marks = {}

def report():  # registered first: runs last, after the hand's own exit hook
    time.sleep(0.05)
    # per finger, in the order received (frames sent before the hook ran may arrive after the mark)
    after = [(t, f, p) for t, (f, p) in zip(emu.torque_times, emu.torque_log) if t >= marks["exit"]]
    zero_ms, late = [], 0
    for finger in sorted({f for _, f, _ in after}):
        mine = [(t, p) for t, f, p in after if f == finger]
        first = next((i for i, (_, p) in enumerate(mine) if not any(p)), None)
        zero_ms.append(None if first is None else 1e3 * (mine[first][0] - marks["exit"]))
        late += sum(1 for _, p in mine[first or 0:] if any(p))
    print(json.dumps({"pd": marks["pd"], "system_on": emu.system_on, "period_ms": list(emu.period_ms),
                      "first_zero_ms": None if None in zero_ms or not zero_ms else max(zero_ms),
                      "nonzero_after_zero": late}), flush=True)

atexit.register(report)
h = AllegroCANHand(hand, link=SocketLink(b, "host"), connect_timeout_s=5.0)
h.connect()
marks["pd"] = h.loop.child.proc.pid
for _ in range(20):
    h.write_goals(q0 + 0.04)
    time.sleep(0.01)
marks["exit"] = time.perf_counter()
sys.exit(0)
"""


def test_exit_without_close_ends_in_zero_torque_and_reaps_the_pd_process(tmp_path):
    torque_off = tmp_path / "allegro_torque_off.toml"
    torque_off.write_text(ALLEGRO.read_text().replace('on_fault = "open"', 'on_fault = "torque_off"', 1))
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run(
        [sys.executable, "-c", EXIT, str(torque_off)], capture_output=True, text=True, env=env, cwd=ROOT, timeout=60
    )
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert not report["system_on"] and report["period_ms"] == [0, 0, 0]
    assert report["first_zero_ms"] is not None and report["first_zero_ms"] <= 1e3 * CONTROL_PERIOD_S, report
    assert report["nonzero_after_zero"] == 0  # once zero torque, only zero torque
    assert _gone(report["pd"])


# ---- a run interrupted: the record names it, nothing is left -------------------------------------------------
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupted_realtime_run_records_the_interrupt_and_leaves_no_process(tmp_path, sig):
    pytest.importorskip("mujoco")
    from proc_session import handlers_installed, session, start_command

    out = tmp_path / "run"
    args = ["run", "--hand", str(ALLEGRO), "--backend", "allegro_can"]
    args += ["--emulate", "--realtime", "--objects", "lego", "--trials", "1"]
    args += ["--policy", "oracle", "--yes", "--quiet", "--out", str(out)]
    proc = start_command(args, tmp_path)
    try:
        t0 = time.monotonic()
        # the trial runs once the pre-flight has said its line
        while "pre-flight:" not in (tmp_path / "stderr.txt").read_text():
            assert proc.poll() is None, (tmp_path / "stderr.txt").read_text()
            assert time.monotonic() - t0 < 180, "no pre-flight"
            time.sleep(0.05)
        assert handlers_installed(proc.pid)
        time.sleep(4.0)  # mid-trial (about 15 s of wall clock; its world and backends start first)
        os.killpg(proc.pid, sig)
        code = proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    err = (tmp_path / "stderr.txt").read_text()
    assert code == (130 if sig == signal.SIGINT else 143), err
    t0 = time.monotonic()
    while session(proc.pid) and time.monotonic() - t0 < 0.2:
        time.sleep(0.01)
    assert session(proc.pid) == {}, "processes left behind"
    kept = out / "trials" / "oracle" / "lego" / "trial_000.interrupted.json"
    assert f"(the trial in progress: {kept})" in err, err
    rec = json.loads(kept.read_text())
    named = "operator abort (Ctrl-C)" if sig == signal.SIGINT else "terminated (SIGTERM)"
    assert rec["reason"] == "aborted" and rec["fault_detail"] == named and rec["final_state"] == "fault"
    assert rec["backend"] == "allegro_can-emulated" and rec["policy"] == "oracle" and rec["trial"] == 0
    assert not (out / "trials" / "oracle" / "lego" / "trial_000.json").exists()  # resume runs it again


# ---- a hand's trial interrupted (the real path's runner, the hand's PD in its process) ------------------------
@pytest.mark.parametrize("interrupt", ["ctrl_c", "sigterm"])
def test_an_interrupted_hand_trial_ends_aborted_and_its_record_names_the_interrupt(allegro, monkeypatch, interrupt):
    import grasp_ctrl.trials.episode.hardware as hw
    from grasp_ctrl.config.objects import load_objects
    from grasp_ctrl.controller.registry import settings_for
    from grasp_ctrl.emulators.allegro_can_process import AllegroCANEmulatorProcess
    from grasp_ctrl.emulators.tactile_bridge import TactileBridgeEmulator
    from grasp_ctrl.errors import Terminated
    from grasp_ctrl.hardware.arm_external import ExternalArm
    from grasp_ctrl.hardware.dynamixel.hand import MonotonicClock
    from grasp_ctrl.rigs.hardware_rig import HardwareRig
    from grasp_ctrl.tactile_link.serial_sensors import SerialSensors
    from grasp_ctrl.trials.episode.runner import interrupted_record

    obj = load_objects(ROOT / "hand_configs" / "objects.toml", allegro.name)["lego"]
    hand_end, host_end = socket_pair()
    q0 = np.array([j.pregrasp_rad for j in allegro.joints])
    emu = AllegroCANEmulatorProcess(hand_end, JointMap.from_hand(allegro), q0)  # a process: its own 3 ms stream
    emu.start()
    tactile = TactileBridgeEmulator([f.sensor_id for f in allegro.fingers], seed=3)
    tactile.start()
    hands: list[AllegroCANHand] = []

    def open_rig(h):
        clock = MonotonicClock()
        link = SocketLink(host_end, "host")
        hand_backend = AllegroCANHand(h, link=link, clock=clock, handle_signals=False, connect_timeout_s=2.0)
        hand_backend.connect()
        hands.append(hand_backend)
        arm = ExternalArm(h, ask=lambda prompt: "", start_world=hw.reach_pose_world(h, obj))
        arm.connect()
        sensors = SerialSensors.from_hand(h, port=tactile.port, clock=clock)
        sensors.start()
        return HardwareRig(hand_backend, arm, sensors, clock)

    real_sleep = hw._sleep
    calls = {"n": 0}

    def sleep_then_interrupt(s):
        calls["n"] += 1
        if calls["n"] == 40:
            raise KeyboardInterrupt if interrupt == "ctrl_c" else Terminated
        real_sleep(s)

    monkeypatch.setattr(hw, "_sleep", sleep_then_interrupt)
    fast = settings_for("grip_load", close_timeout_s=0.3, ramp_timeout_s=0.3, reach_timeout_s=2.0)
    trial = hw.hardware_trial_fn(allegro, ["linear_mock"], fast, 1, open_rig_fn=open_rig)
    try:
        with pytest.raises(KeyboardInterrupt) as exc:
            trial("linear_mock", obj, 0, 7, None)
    finally:
        tactile.close()
        emu_pid = emu.child.proc.pid
        emu_ok = _wait(lambda: not emu.system_on and not emu.pwm.any() and emu.period_ms == (0, 0, 0))
        emu.close()
    assert emu_ok and _gone(emu_pid)
    assert isinstance(exc.value, Terminated) == (interrupt == "sigterm")
    assert calls["n"] > 40  # it kept ticking the safe action after the interrupt
    rec = interrupted_record(exc.value)
    named = "operator abort (Ctrl-C)" if interrupt == "ctrl_c" else "terminated (SIGTERM)"
    assert rec is not None and rec["reason"] == "aborted" and rec["fault_detail"] == named
    assert (rec["policy"], rec["object"], rec["trial"], rec["seed"]) == ("linear_mock", "lego", 0, 7)
    assert rec["final_state"] == "fault" and rec["controller"]["detail"] == named
    # the rig closed: the hand open, then limp and off; the PD process reaped
    assert not hands[0].loop.running and hands[0].loop.child is None


def test_a_bus_the_pd_process_cannot_open_is_one_line_and_no_process_stays(allegro):
    import dataclasses

    tp = dataclasses.replace(allegro.torque_pd, interface="socketcan", channel="nosuchcan0")
    h = AllegroCANHand(dataclasses.replace(allegro, torque_pd=tp), handle_signals=False)
    assert h.pd_process
    children_before = set(_children())
    with pytest.raises(HardwareError, match="CAN bus socketcan nosuchcan0: cannot open"):
        h.connect()
    assert set(_children()) <= children_before and not h.connected


def _children() -> list[int]:
    """This process's children, zombies (not reaped) included."""
    me = str(os.getpid())
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if fields[1] == me:
            out.append(int(stat.parent.name))
    return out


@pytest.mark.parametrize("interrupt", ["ctrl_c", "sigterm"])
def test_an_interrupted_lockstep_trial_settles_and_its_record_names_the_interrupt(allegro, interrupt):
    pytest.importorskip("mujoco")
    from grasp_ctrl.config.objects import load_objects
    from grasp_ctrl.errors import Terminated
    from grasp_ctrl.trials.episode.runner import estimator_factory, interrupted_record, run_sim_trial, trial_seed

    obj = load_objects(ROOT / "hand_configs" / "objects.toml", allegro.name)["lego"]
    ticks = {"after": 0}

    def on_tick(world, ctrl) -> None:
        if ctrl.terminal:
            ticks["after"] += 1
        elif world.t >= 1.0:
            raise KeyboardInterrupt if interrupt == "ctrl_c" else Terminated

    with pytest.raises(KeyboardInterrupt) as exc:
        run_sim_trial(
            allegro,
            obj,
            estimator_factory("oracle", allegro),
            trial_seed(0, obj.name, 0),
            "oracle",
            backend="allegro_can-emulated",
            on_tick=on_tick,
        )
    rec = interrupted_record(exc.value)
    named = "operator abort (Ctrl-C)" if interrupt == "ctrl_c" else "terminated (SIGTERM)"
    assert rec is not None and rec["reason"] == "aborted" and rec["fault_detail"] == named
    assert rec["final_state"] == "fault" and rec["backend"] == "allegro_can-emulated"
    assert ticks["after"] >= 40  # the safe action ticked through the settle (0.5 s)
