"""Hand, arm and sensor backends over a MuJoCoWorld (the mock backends' interfaces).

The arm and the sensors are the mock's own (they only move ``palm_target`` and
read ``raw``); the hand reads its current from the actuators' torques, and its
joint angles and goals as the servos know them: the world's calibration offsets
(sim/variation.py) stay inside the world.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.hardware.base import JointState
from grasp_ctrl.sim.mock.backends import MockArm, MockHand, MockSensors
from grasp_ctrl.sim.mujoco.world import MuJoCoWorld

__all__ = ["MuJoCoHand", "MuJoCoSensors", "MockArm", "mujoco_backends"]


class MuJoCoHand(MockHand):
    """Goals clamped like the real backend (MockHand); state read from MuJoCo. Angles and
    goals are the servos' calibrated ones (``q_measured``, ``command_goal``), never the
    world's true joint angles."""

    world: MuJoCoWorld  # type: ignore[assignment]

    def read(self) -> JointState:
        w = self.world
        return JointState(q=w.q_measured, dq=w.dq, current_a=w.joint_current_a, t=w.t)

    # MockHand's clamping (step limit from the servos' last goal, then the hand file's limits),
    # in calibrated angles; the world adds the offsets.
    def _goal_held(self) -> np.ndarray:
        return self.world.q_goal_measured

    def _hold_goal(self, q: np.ndarray) -> None:
        self.world.command_goal(q)


class MuJoCoSensors(MockSensors):
    """The world's simulated frames; closing them ends the world's trial (e.g. writes its video)."""

    def close(self) -> None:
        self.world.close()  # type: ignore[attr-defined]


def mujoco_backends(world: MuJoCoWorld, hand: HandConfig) -> tuple[MuJoCoHand, MuJoCoSensors]:
    """The hand and sensor backends of a trial on a MuJoCo world (the runner adds the arm)."""
    return MuJoCoHand(world, hand), MuJoCoSensors(world)  # type: ignore[arg-type]


def make_world(hand: HandConfig, obj, seed: int, params=None) -> MuJoCoWorld:  # noqa: ANN001
    return MuJoCoWorld(hand, obj, seed, params)


def is_available() -> bool:
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True
