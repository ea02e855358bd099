"""Fault injection on the Allegro's CAN backend, one test per class of fault: stale position frames,
an error frame (bus errors, bus-off), an over-temperature reply, Ctrl-C (SIGINT), SIGTERM, and the
program's exit without a ``close``. Each must reach the safe state within one control period
(10 ms) of the fault (for stale positions: of ``position_stale_s`` running out, which is what
defines the fault), name the fault, and send no torque frame after it but zero torque.

Two levels:

- the backend on the wall clock (its 333 Hz PD thread against the emulator's 3 ms stream on
  python-can's virtual bus): the host's frames are recorded with their send times, so the time
  from the fault to the last finger's zero-torque frame is measured, and every torque frame
  after that is checked to be zero;
- a trial (the emulated hand in lockstep on the MuJoCo world): the fault injected mid-trial ends
  the trial with ``hardware_error`` and the record's ``fault_detail`` naming it.
"""

from __future__ import annotations

import itertools
import json
import os
import re
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
from grasp_ctrl.hardware.allegro import protocol as pr
from grasp_ctrl.hardware.allegro.protocol import CanFrame, JointMap

can = pytest.importorskip("can")

from grasp_ctrl.emulators.allegro_can import AllegroCANEmulator, virtual_link  # noqa: E402
from grasp_ctrl.hardware.allegro import AllegroCANHand  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
ALLEGRO = ROOT / "hand_configs" / "allegro_hand.toml"
_channels = itertools.count()


@pytest.fixture(scope="module")
def allegro():
    return load_hand(ALLEGRO)


class SendLog:
    """A CanLink that notes every frame the host sends, with its send time (perf_counter)."""

    def __init__(self, inner) -> None:
        self.inner = inner
        self.sent: list[tuple[float, CanFrame]] = []

    def send(self, frame: CanFrame) -> None:
        self.inner.send(frame)
        self.sent.append((time.perf_counter(), frame))

    def recv(self, timeout_s: float):
        return self.inner.recv(timeout_s)

    def close(self) -> None:
        self.inner.close()

    def torques(self) -> list[tuple[float, int, tuple[int, int, int, int]]]:
        out = []
        for t, f in list(self.sent):
            if pr.CMD_SET_TORQUE <= f.command < pr.CMD_SET_TORQUE + pr.N_FINGERS:
                finger, pwm = pr.decode_torque(f)
                out.append((t, finger, pwm))
        return out


def _rig(hand, **kw):
    ch = f"test-allegro-faults-{os.getpid()}-{next(_channels)}"
    q0 = np.array([j.pregrasp_rad for j in hand.joints])
    emu = AllegroCANEmulator(virtual_link(ch), JointMap.from_hand(hand), q0, stream=True)
    emu.start()
    link = SendLog(virtual_link(ch))
    h = AllegroCANHand(hand, link=link, handle_signals=False, connect_timeout_s=2.0, **kw)
    return h, emu, link, q0


def _wait(cond, timeout_s=1.0) -> bool:
    end = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > end:
            return False
        time.sleep(0.0005)
    return True


def _trip_times(h) -> list[float]:
    """Note when the loop latches its fault (perf_counter)."""
    times: list[float] = []
    loop = h.loop
    trip = loop.trip

    def noted(reason: str) -> None:
        if loop.fault is None:
            times.append(time.perf_counter())
        trip(reason)

    loop.trip = noted
    return times


# ---- the link's faults on the wall clock ----------------------------------------------------------
@pytest.mark.parametrize("fault", ["stale", "error_frame", "over_temperature"])
def test_a_link_fault_reaches_zero_torque_within_one_control_period(allegro, fault):
    h, emu, link, q0 = _rig(allegro)
    try:
        h.connect()
        trips = _trip_times(h)
        h.write_goals(q0 + 0.04)  # a torque on every finger
        assert _wait(lambda: emu.pwm.any())
        time.sleep(0.02)
        if fault == "stale":
            emu.silent = True  # the hand stops reporting: the fault is position_stale_s later
            match = "no full set of joint positions for 0.02 s"
        elif fault == "error_frame":
            emu.send_error_frame()
            match = "error frame"
        else:
            emu.set_temperature(1, 85)
            h.request_health()  # what check_health asks every 0.1 s
            match = r"over-temperature: .*85 degC \(limit 70 degC"
        end = time.monotonic() + 1.0
        while not trips and time.monotonic() < end:  # the trial loop goes on writing goals
            h.write_goals(q0 + 0.04)
            time.sleep(0.002)
        assert trips, "no fault latched"
        time.sleep(0.02)  # (the loop's next periods)
        t_safe = zero_torque_after(link.torques(), trips[0])
        assert t_safe - trips[0] <= CONTROL_PERIOD_S, f"zero torque {1e3 * (t_safe - trips[0]):.1f} ms after the fault"
        with pytest.raises(HardwareError, match=match) as exc:
            h.check_health()
        assert exc.value.reason == "hardware_error"
        time.sleep(0.02)  # goals written after the fault still give zero torque only
        h.write_goals(q0 + 0.05)
        time.sleep(0.01)
        zero_torque_after(link.torques(), trips[0])
    finally:
        h.close()
    assert _wait(lambda: not emu.system_on and not emu.pwm.any())
    zero_torque_after(link.torques(), trips[0])
    emu.close()


# ---- Ctrl-C and SIGTERM in the control loop's thread --------------------------------------------------
def test_ctrl_c_reaches_zero_torque_within_one_control_period(allegro, sigint_raises):
    hand = replace(allegro, safety=replace(allegro.safety, on_fault="torque_off"))
    h, emu, link, q0 = _rig(hand)
    t_sig = control_loop_until_signal(h, q0, signal.SIGINT)
    t_safe = zero_torque_after(link.torques(), t_sig)
    assert t_safe - t_sig <= CONTROL_PERIOD_S, f"zero torque {1e3 * (t_safe - t_sig):.1f} ms after Ctrl-C"
    assert _wait(lambda: not emu.system_on and not emu.pwm.any() and emu.period_ms == (0, 0, 0))
    assert link.sent[-2][1].command == pr.CMD_SYSTEM_OFF  # then the reports stopped
    emu.close()


def test_sigterm_opens_the_hand_then_ends_in_zero_torque(allegro):
    if signal.getsignal(signal.SIGTERM) not in (signal.SIG_DFL, None):
        pytest.skip("SIGTERM already handled in this process")
    h, emu, link, q0 = _rig(allegro)  # on_fault = "open", the hand file's
    h.handle_signals = True
    goals: list[tuple[float, np.ndarray, bool]] = []
    real_connect = h.connect

    def connect() -> None:
        real_connect()
        set_goal = h.loop.set_goal

        def noted(q, active=True):
            goals.append((time.perf_counter(), np.array(q), bool(active)))
            set_goal(q, active)

        h.loop.set_goal = noted

    h.connect = connect
    t_sig = control_loop_until_signal(h, q0, signal.SIGTERM)
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # the hook is gone with the hand
    # the open ramp's first goal within one control period of the signal, each a step toward open
    regular = np.clip(q0 + 0.04, h.lower, h.upper)  # (the loop's own goal, until the signal lands)
    after = [(t, q, a) for t, q, a in goals if t >= t_sig and not (a and np.allclose(q, regular))]
    assert after and after[0][0] - t_sig <= CONTROL_PERIOD_S
    q_open = np.clip(h.q_open, h.lower, h.upper)
    ramp = [q for _, q, a in after if a]
    assert ramp and np.allclose(ramp[-1], q_open)  # it reached the open posture
    dist = [np.max(np.abs(q - q_open)) for q in ramp]
    assert all(b <= a + 1e-12 for a, b in zip(dist, dist[1:]))
    assert not after[-1][2]  # then torque off
    t_off = after[-1][0]
    zero_torque_after(link.torques(), t_off)
    assert _wait(lambda: not emu.system_on and not emu.pwm.any())
    emu.close()


# ---- the program's exit without close: atexit ----------------------------------------------------------
CHILD = r"""
import atexit, json, sys, time
import numpy as np
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.emulators.allegro_can import AllegroCANEmulator, virtual_link
from grasp_ctrl.hardware.allegro import AllegroCANHand
from grasp_ctrl.hardware.allegro.protocol import JointMap

hand = load_hand(sys.argv[1])
q0 = np.array([j.pregrasp_rad for j in hand.joints])
emu = AllegroCANEmulator(virtual_link("exit-test"), JointMap.from_hand(hand), q0, stream=True)
emu.keep_log = True
emu.start()
marks = {}

def report():  # registered first: runs last, after the hand's own exit hook
    time.sleep(0.05)
    log = emu.torque_log
    first_zero = None
    zeroed = set()
    for i, (finger, pwm) in enumerate(log):
        if emu.torque_times[i] < marks["exit"]:
            continue
        if pwm == (0, 0, 0, 0):
            zeroed.add(finger)
            if len(zeroed) == 4:
                first_zero = i
                break
        else:
            zeroed.discard(finger)
    print(json.dumps({
        "system_on": emu.system_on, "pwm_any": bool(emu.pwm.any()), "period_ms": list(emu.period_ms),
        "torque_before_exit": sum(1 for t in emu.torque_times if t < marks["exit"]),
        "zero_after_ms": None if first_zero is None else 1e3 * (emu.torque_times[first_zero] - marks["exit"]),
        "nonzero_after_safe": None if first_zero is None else sum(1 for _, p in log[first_zero:] if any(p)),
    }), flush=True)

atexit.register(report)
h = AllegroCANHand(hand, link=virtual_link("exit-test"), connect_timeout_s=5.0)
h.connect()
for _ in range(20):
    h.write_goals(q0 + 0.04)
    time.sleep(0.01)
marks["exit"] = time.perf_counter()
sys.exit(0)  # no close: the hand's atexit hook must leave it limp
"""


def test_exit_without_close_ends_in_zero_torque(tmp_path):
    torque_off = tmp_path / "allegro_torque_off.toml"
    torque_off.write_text(ALLEGRO.read_text().replace('on_fault = "open"', 'on_fault = "torque_off"', 1))
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run(
        [sys.executable, "-c", CHILD, str(torque_off)], capture_output=True, text=True, env=env, cwd=ROOT, timeout=60
    )
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert report["torque_before_exit"] > 0
    assert not report["system_on"] and not report["pwm_any"] and report["period_ms"] == [0, 0, 0]
    assert report["zero_after_ms"] is not None and report["zero_after_ms"] <= 1e3 * CONTROL_PERIOD_S, report
    assert report["nonzero_after_safe"] == 0


# ---- a trial: the record names the fault ----------------------------------------------------------------
@pytest.mark.parametrize(
    ("fault", "named"),
    [
        ("stale", "no full set of joint positions for 0.02 s"),
        ("error_frame", "error frame"),
        ("over_temperature", "over-temperature: .*90 degC"),
    ],
)
def test_a_fault_mid_trial_ends_it_with_a_record_naming_it(allegro, objects_allegro, fault, named):
    pytest.importorskip("mujoco")
    from grasp_ctrl.emulators.allegro_can_world import EmulatedAllegroHand, allegro_emulated_backends
    from grasp_ctrl.hardware.allegro.hand import HEALTH_POLL_S
    from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial, trial_seed

    hands: list[EmulatedAllegroHand] = []
    links: list[SendLog] = []
    latched: list[int] = []

    def backends(world, hand):
        h, sensors = allegro_emulated_backends(world, hand)
        real_connect = h.connect

        def connect() -> None:
            real_connect()
            loop = h.can.loop
            link = SendLog(loop.link)
            loop.link = h.can._link = link
            links.append(link)
            trip = loop.trip

            def noted(reason: str) -> None:  # what had been sent when the fault latched
                if loop.fault is None:
                    latched.append(len(link.sent))
                trip(reason)

            loop.trip = noted

        h.connect = connect
        hands.append(h)
        return h, sensors

    injected: dict[str, float] = {}
    T_FAULT = 1.0  # s of the trial: reaching

    def inject(world, ctrl) -> None:
        if world.t < T_FAULT or injected:
            return
        emu = hands[0].emu
        injected["t"] = world.t
        injected["sent"] = len(links[0].sent)
        if fault == "stale":
            emu.silent = True
        elif fault == "error_frame":
            emu.send_error_frame()
        else:
            emu.set_temperature(2, 90)

    obj = objects_allegro["lego"]
    r = run_sim_trial(
        allegro,
        obj,
        estimator_factory("oracle", allegro),
        trial_seed(0, obj.name, 0),
        "oracle",
        make_backends=backends,
        backend="allegro_can-emulated",
        on_tick=inject,
        world_params=None,
    )
    assert injected
    assert r.reason == "hardware_error" and r.final_state == "fault"
    assert re.search(named, r.fault_detail or ""), r.fault_detail
    t_fault = next(t for t, _src, dst in r.transitions if dst == "fault")
    # when the fault exists: at once (an error frame), after the next health request's reply
    # (temperature), after position_stale_s without positions (stale); the loop latches it at
    # its next period and the controller sees it at its next tick
    delay = {"stale": allegro.torque_pd.position_stale_s, "error_frame": 0.0, "over_temperature": HEALTH_POLL_S}
    assert t_fault - injected["t"] <= delay[fault] + 2 * CONTROL_PERIOD_S + 1e-6
    loop = hands[0].can.loop
    assert loop.fault is not None and re.search(named, loop.fault)
    # from the moment the loop latched it: zero torque frames only (each tick of the settle,
    # then the close's), and the world's hand limp
    assert latched and latched[0] >= injected["sent"]
    sent = links[0].sent[latched[0] :]
    torques = [pr.decode_torque(f) for _, f in sent if pr.CMD_SET_TORQUE <= f.command < pr.CMD_SET_TORQUE + 4]
    assert len(torques) >= 4 * 40 and all(pwm == (0, 0, 0, 0) for _, pwm in torques)
    assert not hands[0].world.torque_on


@pytest.fixture(scope="module")
def objects_allegro(allegro):
    from grasp_ctrl.config.objects import load_objects

    return load_objects(ROOT / "hand_configs" / "objects.toml", allegro.name)
