"""Torque goes off when the controlling process is interrupted (SIGINT) or terminated (SIGTERM)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from conftest import sigint_as_at_a_terminal

from grasp_ctrl.emulators.dxl_chain import DynamixelChainEmulator
from tests.dxl_helpers import REPO, leap, leap_file

CHILD = r"""
import sys, time
import numpy as np
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.hardware.dynamixel import DynamixelHand
hand = load_hand(sys.argv[2])
with DynamixelHand(hand, sys.argv[1]) as h:
    q = np.array([j.pregrasp_rad for j in hand.joints])
    print("ready", flush=True)
    while True:
        h.read()
        h.write_goals(q)
        time.sleep(0.01)
"""


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_torque_off_after_signal(sig: signal.Signals, tmp_path) -> None:
    hand = leap()
    hand_file = leap_file(tmp_path)
    with DynamixelChainEmulator.for_hand(hand) as emu:
        env = dict(os.environ, PYTHONPATH=str(REPO))
        child = subprocess.Popen(
            [sys.executable, "-c", CHILD, emu.port, str(hand_file)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
            cwd=REPO,
            preexec_fn=sigint_as_at_a_terminal,
        )
        try:
            assert child.stdout is not None
            assert child.stdout.readline().strip() == "ready"
            time.sleep(0.2)
            assert all(emu.servo(j.servo_id).torque_on for j in hand.joints)
            child.send_signal(sig)
            child.wait(timeout=60)  # generous: a loaded CI host, first imports
        finally:
            if child.poll() is None:
                child.kill()
        assert child.returncode != 0
        assert not any(emu.servo(j.servo_id).torque_on for j in hand.joints)
        # on_fault = open: the joints were brought to the open posture first
        opened = [emu.servo(j.servo_id).goal_history[-1] for j in hand.joints]
        import numpy as np

        from grasp_ctrl.hardware.dynamixel.calibration import Calibration

        expected = Calibration.from_joints(hand.joints).to_counts(np.array([j.open_rad for j in hand.joints]))
        assert list(expected) == opened
