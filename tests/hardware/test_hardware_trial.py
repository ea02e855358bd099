"""A whole trial through the real backends: Dynamixel hand on the servo-chain emulator,
serial sensors on the tactile-bridge emulator, an external arm answered by script."""

from __future__ import annotations

import numpy as np
import pytest

from grasp_ctrl.controller.registry import settings_for
from grasp_ctrl.emulators.dxl_chain import DynamixelChainEmulator
from grasp_ctrl.emulators.tactile_bridge import TactileBridgeEmulator
from grasp_ctrl.hardware.arm_external import ExternalArm
from grasp_ctrl.hardware.dynamixel import DynamixelHand
from grasp_ctrl.hardware.dynamixel.hand import MonotonicClock
from grasp_ctrl.loop.ticklog import read_tick_log
from grasp_ctrl.rigs.hardware_rig import HardwareRig
from grasp_ctrl.tactile_link.serial_sensors import SerialSensors
from grasp_ctrl.trials.episode.hardware import hardware_trial_fn, reach_pose_world

pytestmark = pytest.mark.skipif(not hasattr(__import__("os"), "openpty"), reason="needs POSIX pseudo-terminals")

FAST = settings_for("grip_load", close_timeout_s=0.3, ramp_timeout_s=0.3, reach_timeout_s=2.0)


@pytest.fixture
def emulators(hand):
    from dataclasses import replace

    # The emulator answers slower than a servo on a loaded test machine.
    slow_ok = replace(hand, dynamixel=replace(hand.dynamixel, packet_timeout_ms=40.0, retries=5))
    dxl = DynamixelChainEmulator.for_hand(slow_ok).start()
    tactile = TactileBridgeEmulator([f.sensor_id for f in hand.fingers], seed=3)
    tactile.start()
    yield slow_ok, dxl, tactile
    tactile.close()
    dxl.stop()


def _opener(dxl, tactile, obj, answers):
    def open_rig(h):
        clock = MonotonicClock()
        hand_backend = DynamixelHand(h, dxl.port, clock=clock, handle_signals=False)
        hand_backend.connect()
        arm = ExternalArm(h, ask=lambda prompt: answers.append(prompt) or "", start_world=reach_pose_world(h, obj))
        arm.connect()
        sensors = SerialSensors.from_hand(h, port=tactile.port, clock=clock)
        sensors.start()
        return HardwareRig(hand_backend, arm, sensors, clock)

    return open_rig


def test_trial_runs_through_real_backends_and_stops_safely(emulators, objects, tmp_path):
    hand, dxl, tactile = emulators
    obj = objects["chips_can"]
    prompts: list[str] = []
    trial = hardware_trial_fn(hand, ["linear_mock"], FAST, 1, open_rig_fn=_opener(dxl, tactile, obj, prompts))
    log = tmp_path / "trial_000_ticks.parquet"
    record = trial("linear_mock", obj, 0, 0, log)

    assert record["policy"] == "linear_mock" and record["object"] == "chips_can"
    assert record["controller"]["final_state"] in ("done", "fault")
    states = [b for _, _, b in record["transitions"]]
    assert states[0] == "reach"  # tared first, on real frames
    assert record["judged_by"] == "controller"
    header, cols = read_tick_log(log)
    assert len(cols["t"]) > 50 and header[:2] == ["t", "state"]
    # Every goal the servos received stayed inside the joint limits (LEAP: offset 0, sign +1).
    for j in hand.joints:
        history = dxl.servo(j.servo_id).goal_history
        assert history, j.name
        q = (np.array(history, dtype=float) - 2048.0) * 2.0 * np.pi / 4096.0
        assert np.all(q >= j.lower_rad - 2e-3) and np.all(q <= j.upper_rad + 2e-3), j.name
    # The rig's close stopped the hand as configured (on_fault = open: open, then torque off).
    assert not any(dxl.servo(j.servo_id).torque_on for j in hand.joints)


def test_oracle_is_refused_on_hardware(hand):
    from grasp_ctrl.errors import UsageError

    with pytest.raises(UsageError, match="oracle"):
        hardware_trial_fn(hand, ["oracle"], None, 1, open_rig_fn=lambda h: None)


def test_ctrl_c_mid_trial_aborts_safely(emulators, objects, monkeypatch):
    import grasp_ctrl.trials.episode.hardware as hw

    hand, dxl, tactile = emulators
    obj = objects["chips_can"]
    real_sleep = hw._sleep
    calls = {"n": 0}

    def sleep_then_interrupt(s):
        calls["n"] += 1
        if calls["n"] == 60:  # during the close, after taring
            raise KeyboardInterrupt
        real_sleep(s)

    monkeypatch.setattr(hw, "_sleep", sleep_then_interrupt)
    trial = hardware_trial_fn(hand, ["linear_mock"], FAST, 1, open_rig_fn=_opener(dxl, tactile, obj, []))
    with pytest.raises(KeyboardInterrupt):
        trial("linear_mock", obj, 0, 0, None)
    assert calls["n"] > 60  # it kept ticking the safe action after the interrupt
    assert not any(dxl.servo(j.servo_id).torque_on for j in hand.joints)
