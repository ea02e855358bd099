"""Hand and sensor backends over a MuJoCoWorld: the generic world backends
(sim/world_backends.py), the hand reading the joint velocities MuJoCo integrates.

The hand reads its current from the actuators' torques, and its joint angles and goals as
the servos know them: the world's calibration offsets (sim/variation.py) stay inside it.
"""

from __future__ import annotations

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.hardware.base import JointState
from grasp_ctrl.sim.mujoco.world import MuJoCoParams, MuJoCoWorld
from grasp_ctrl.sim.world_backends import WorldHand, WorldSensors

__all__ = ["MuJoCoHand", "is_available", "make_world", "mujoco_backends"]


class MuJoCoHand(WorldHand):
    """Goals clamped like the real backend; angles, velocities and currents read from MuJoCo.
    Angles and goals are the servos' calibrated ones (``q_measured``, ``command_goal``), never
    the world's true joint angles."""

    world: MuJoCoWorld

    def read(self) -> JointState:
        w = self.world
        return JointState(w.q_measured, w.dq, w.joint_current_a, w.t)  # (positional: cheaper)


def mujoco_backends(world: MuJoCoWorld, hand: HandConfig) -> tuple[MuJoCoHand, WorldSensors]:
    """The hand and sensor backends of a trial on a MuJoCo world (the builder adds the arm)."""
    return MuJoCoHand(world, hand), WorldSensors(world)


def make_world(hand: HandConfig, obj: ObjectProfile, seed: int, params: MuJoCoParams | None = None) -> MuJoCoWorld:
    return MuJoCoWorld(hand, obj, seed, params)


def is_available() -> bool:
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True
