"""A whole controller trial through the Dynamixel backend, the SDK and the emulator."""

from __future__ import annotations

import numpy as np

import grasp_ctrl.trials.episode.runner as runner
from grasp_ctrl.emulators.world_hand import EmulatedDynamixelHand
from grasp_ctrl.hardware.dynamixel.calibration import Calibration
from grasp_ctrl.sim.mock.world import MockWorld
from grasp_ctrl.sim.world_backends import WorldSensors


def test_oracle_trial_on_the_dynamixel_backend(hand, objects) -> None:
    made: list[EmulatedDynamixelHand] = []

    def backends(world, hand_cfg):
        """The mock world's sensors, the hand through the Dynamixel backend and its emulator."""
        made.append(EmulatedDynamixelHand(world, hand_cfg))
        return made[-1], WorldSensors(world)

    r = runner.run_sim_trial(
        hand,
        objects["chips_can"],
        runner.estimator_factory("oracle", hand),
        3,
        "oracle",
        make_world=MockWorld,
        make_backends=backends,
        backend="mock",
    )
    assert r.success, (r.reason, r.transitions)
    states = [b for _, _, b in r.transitions]
    assert states[-1] == "done" and "lift" in states
    emu = made[0].emu
    assert emu.sync_write_count > 100
    # every goal the servos received stayed within the joint limits
    lo, hi = Calibration.from_joints(hand.joints).limit_counts()
    for k, j in enumerate(hand.joints):
        g = np.array(emu.servo(j.servo_id).goal_history)
        assert np.all((g >= lo[k]) & (g <= hi[k])), j.name
    assert not any(s.torque_on for s in emu.servos.values())
