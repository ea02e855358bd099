"""The mock world's hand and arm backends: the generic world backends (sim/world_backends.py)
with the mock's one-pass compiled reads and writes (the mock world steps in tens of
microseconds, so the backends' Python would otherwise dominate a tick)."""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.base import JointState
from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.jit import njit
from grasp_ctrl.sim.mock.world import MockWorld
from grasp_ctrl.sim.world_backends import WorldArm, WorldHand, WorldSensors

_FLOAT64 = np.dtype(np.float64)

__all__ = ["MockArm", "MockHand", "WorldSensors", "joint_state_kernel", "mock_backends"]


@njit
def joint_state_kernel(
    q: np.ndarray,
    q_prev: np.ndarray,
    q_servo: np.ndarray,
    dt: float,
    stiffness: float,
    torque_per_amp: float,
    q_out: np.ndarray,
    dq_out: np.ndarray,
    current_out: np.ndarray,
) -> None:
    """``WorldHand.read``'s arithmetic on the mock world in one pass (the same operations per
    element as its numpy code and the world's ``joint_current_a``, so the same bits);
    ``q_prev`` becomes ``q``."""
    for j in range(q.shape[0]):
        dq_out[j] = (q[j] - q_prev[j]) / dt
        q_out[j] = q[j]
        q_prev[j] = q[j]
        current_out[j] = stiffness * (q_servo[j] - q[j]) / torque_per_amp


class MockHand(WorldHand):
    """``WorldHand`` on the mock world, its read and goal write each one compiled pass."""

    world: MockWorld

    def __init__(self, world: MockWorld, hand: HandConfig) -> None:
        super().__init__(world, hand)
        p = world.params
        self._stiffness = p.servo_stiffness_nm_per_rad
        self._torque_per_amp = world.torque_per_amp_nm
        self._write_limited = world.write_limited_goal if jit.JIT else None

    def read(self) -> JointState:
        if not jit.JIT:
            return super().read()
        w, n = self.world, self._n_joints
        q, dq, current = np.empty(n), np.empty(n), np.empty(n)
        joint_state_kernel(w.q, self._q_prev, w.q_servo, w.dt, self._stiffness, self._torque_per_amp, q, dq, current)
        return JointState(q, dq, current, w.t)

    def write_goals(self, q_goal: np.ndarray) -> None:
        q_goal = np.asarray(q_goal, dtype=float)
        if self._write_limited is not None and q_goal.shape == self.lower.shape:
            if self._write_limited(q_goal, self.max_step, self.lower, self.upper):
                return
            raise HardwareError(f"bad goal vector of shape {q_goal.shape}")
        super().write_goals(q_goal)


class MockArm(WorldArm):
    """``WorldArm`` on the mock world, its command one compiled pass."""

    world: MockWorld

    def __init__(self, world: MockWorld, hand: HandConfig) -> None:
        super().__init__(world, hand)
        self._set_clamped = world.set_clamped_palm_target if jit.JIT else None

    def command(self, p_world: np.ndarray) -> None:
        if (
            self._set_clamped is not None
            and type(p_world) is np.ndarray
            and p_world.dtype is _FLOAT64
            and p_world.shape == (3,)
            and self._set_clamped(p_world, self._z_min, self._z_max)
        ):
            return
        super().command(p_world)


def mock_backends(world: MockWorld, hand: HandConfig) -> tuple[MockHand, WorldSensors]:
    """The hand and sensor backends of a trial on the mock world (the builder adds the arm)."""
    return MockHand(world, hand), WorldSensors(world)
