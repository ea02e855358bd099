"""End to end on the real serial backend: a stale or unplugged fingertip stops the controller safely.

A 100 Hz real-time loop (the shape of the trial runner's tick) reads the emulated
bridge through ``SerialSensors``, builds snapshots with the sensing pipeline and
ticks the state machine; the fault from ``check_stale`` must put it into ``fault``
with the right reason, stop the arm where it is and open the hand (``on_fault = open``).
"""

from __future__ import annotations

import sys
import time

import numpy as np
import pytest

from grasp_ctrl.config import load_hand, load_objects
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.emulators.tactile_bridge import TactileBridgeEmulator
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.estimators.analytic import AnalyticEstimator
from grasp_ctrl.files.paths import default_hand_file, default_objects_file
from grasp_ctrl.hardware.base import JointState
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.loop.sensing import SensingPipeline
from grasp_ctrl.tactile_link.serial_sensors import SerialSensors

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="the emulator needs POSIX pseudo-terminals")


# an unplugged tactile port ends the trial as sensor_stale (it was hardware_error)
@pytest.mark.parametrize("event, reason", [("pause", "sensor_stale"), ("disconnect", "sensor_stale")])
def test_serial_fault_stops_the_controller_safely(event: str, reason: str) -> None:
    hand = load_hand(default_hand_file())
    assert hand.safety.on_fault == "open"
    obj = next(iter(load_objects(default_objects_file()).values()))
    kin = HandKinematics(hand)
    pipeline = SensingPipeline(hand, kin, AnalyticEstimator([0.01, 0.01, 0.01]))
    reach = np.array([0.0, 0.0, 0.2])
    ctrl = GraspController(hand, obj, reach, kin=kin)
    q = np.array([j.pregrasp_rad for j in hand.joints])
    zeros = np.zeros_like(q)
    palm = reach + np.array([0.0, 0.0, 0.05])

    emu = TactileBridgeEmulator([f.sensor_id for f in hand.fingers], seed=7)
    sensors = SerialSensors.from_hand(hand, port=emu.port)
    t_event = t_fault = None
    palm_at_fault = None
    try:
        sensors.start()
        emu.start()
        sensors.wait_for_frames(timeout_s=2.0)
        next_tick = time.monotonic()
        for tick in range(200):
            now = sensors.now()
            fault = None
            try:
                sensors.check_stale(now)
                raw = pipeline.frames_matrix(sensors.read_latest(), now)
            except HardwareError as exc:
                fault = exc.reason
                raw = pipeline.raw
            snap = pipeline.snapshot(raw, JointState(q, zeros, zeros, now), palm, ctrl.state == "tare", fault)
            was_faulted = ctrl.state == "fault"
            cmd = ctrl.tick(snap)
            if ctrl.state == "fault" and not was_faulted:
                t_fault, palm_at_fault = now, palm.copy()
            palm = cmd.p_palm_world.copy()  # an ideal arm
            q = q + np.clip(cmd.q_goal - q, -0.05, 0.05)  # servos track the goals
            if tick == 70:  # after taring (50 frames), while reaching
                t_event = now
                emu.pause(0.2, [2]) if event == "pause" else emu.disconnect()
            if t_fault is not None and now - t_fault > 0.3:
                break
            next_tick += hand.dt
            time.sleep(max(0.0, next_tick - time.monotonic()))
    finally:
        sensors.close()
        emu.close()

    assert t_event is not None and t_fault is not None, f"no fault (state {ctrl.state})"
    assert t_fault >= t_event  # no false alarm before the event
    assert t_fault - t_event < 0.05 + 0.1  # within the stale limit plus a few ticks
    assert ctrl.state == "fault" and ctrl.failure_reason == reason
    np.testing.assert_allclose(palm, palm_at_fault)  # the arm stopped where it was
    q_open = np.array([j.open_rad for j in hand.joints])
    assert np.max(np.abs(q - q_open)) < 1e-6  # the hand opened (on_fault = open)
