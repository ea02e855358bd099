"""Hand, arm and sensor backends over any simulated world (the ``World`` protocol), with the
real backends' interfaces.

The hand reads what the servos report (``q_measured``, ``joint_current_a``) and writes goals
in their calibrated angles (``command_goal``), clamped as the real backend clamps them: a
per-tick step from the goal the servos hold, then the hand file's joint limits. The arm moves
the wrist target; the sensors deliver the world's latest frames. The mock world's backends
(sim/mock/backends.py) add one-pass compiled writes; the MuJoCo world's
(sim/mujoco/backends.py) read the joint velocities MuJoCo integrates.
"""

from __future__ import annotations

import math

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.base import JointState, TactileFrame
from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.finite import all_finite
from grasp_ctrl.numeric.jit import njit
from grasp_ctrl.numeric.limits import clamped_palm_target, limit_goal, limited_goal
from grasp_ctrl.sim.world_api import World

_FLOAT64 = np.dtype(np.float64)


@njit
def checked_limit_goal(
    goal: np.ndarray, prev: np.ndarray, max_step: float, lower: np.ndarray, upper: np.ndarray, out: np.ndarray
) -> bool:
    """``limits.limit_goal`` into ``out`` when every goal is finite; False (``out``
    unset) when one is not."""
    for j in range(goal.shape[0]):
        if not math.isfinite(goal[j]):
            return False
    limit_goal(goal, prev, max_step, lower, upper, out)
    return True


class WorldHand:
    """Clamps goals to the joint limits and a per-tick step limit, like the real backend; the
    joint velocity is the difference of the angles read (the servos report no velocity here)."""

    def __init__(self, world: World, hand: HandConfig) -> None:
        self.world = world
        self.lower = np.array([j.lower_rad for j in hand.joints])
        self.upper = np.array([j.upper_rad for j in hand.joints])
        self.max_step = hand.safety.max_joint_step_rad
        self.connected = False
        self.fault: str | None = None  # tests inject e.g. "overload"
        self._n_joints = len(self.lower)
        self._q_prev = np.array(world.q_measured, dtype=float)  # for the velocity estimate of read()

    def connect(self) -> None:
        self.connected = True

    def read(self) -> JointState:
        w = self.world
        q = np.array(w.q_measured, dtype=float)
        dq = (q - self._q_prev) / w.dt
        self._q_prev = q.copy()
        return JointState(q=q, dq=dq, current_a=np.array(w.joint_current_a, dtype=float), t=w.t)

    def write_goals(self, q_goal: np.ndarray) -> None:
        q_goal = np.asarray(q_goal, dtype=float)
        if jit.JIT and q_goal.shape == self.lower.shape:
            q = np.empty(self._n_joints)
            if checked_limit_goal(q_goal, self.world.q_goal_measured, self.max_step, self.lower, self.upper, q):
                self.world.command_goal(q)
                return
        if q_goal.shape != self.lower.shape or not all_finite(q_goal):
            raise HardwareError(f"bad goal vector of shape {q_goal.shape}")
        self.world.command_goal(limited_goal(q_goal, self.world.q_goal_measured, self.max_step, self.lower, self.upper))

    def set_torque(self, enabled: bool) -> None:
        self.world.torque_on = enabled

    def check_health(self) -> None:
        if self.fault:
            raise HardwareError(f"simulated hand: hardware error status: {self.fault}")

    def close(self) -> None:
        self.connected = False


class WorldArm:
    """Moves the wrist target, its height clamped to the hand file's arm range."""

    def __init__(self, world: World, hand: HandConfig) -> None:
        self.world = world
        self.z_min = hand.arm.z_min_m
        self.z_max = hand.arm.z_max_m
        self._z_min, self._z_max = float(self.z_min), float(self.z_max)

    def connect(self) -> None:
        pass

    def command(self, p_world: np.ndarray) -> None:
        self.world.palm_target = clamped_palm_target(p_world, self._z_min, self._z_max)

    def position(self) -> np.ndarray:
        return self.world.palm_world.copy()

    def stop(self) -> None:
        self.world.palm_target = self.world.palm_world.copy()

    def close(self) -> None:
        self.stop()


class WorldSensors:
    """Delivers the world's latest simulated frame per fingertip; ``pause`` lets tests starve
    one fingertip to exercise the stale-sensor fault. Closing them ends the world's trial
    (e.g. writes its video)."""

    def __init__(self, world: World) -> None:
        self.world = world
        self.paused: set[int] = set()
        self._latest: dict[int, TactileFrame] = {}
        # The world's frames last delivered to every sensor at once by latest_matrix,
        # (raw, seq, t): turned into _latest's TactileFrames only when they are asked for.
        self._delivered: tuple[np.ndarray, int, float] | None = None

    def start(self) -> None:
        self._refresh()

    def latest_matrix(self, sensor_ids: list[int]) -> tuple[np.ndarray, float] | None:
        """The newest frames of ``sensor_ids`` as one (n, 44) float matrix in that order,
        and the time they were received: what ``read_latest`` would deliver, without a
        TactileFrame each. Only when the ids are the world's own, in its order, and no
        sensor is paused; otherwise None (then ``read_latest``)."""
        w = self.world
        if self.paused or sensor_ids != w.sensor_ids:
            return None
        raw = w.raw
        self._delivered = (raw, w.seq, w.t)
        return raw.astype(float), w.t

    def _refresh(self) -> None:
        w = self.world
        raw, seq, t, paused, latest = w.raw, w.seq, w.t, self.paused, self._latest
        if self._delivered is not None:  # what latest_matrix delivered, before this refresh
            last_raw, last_seq, last_t = self._delivered
            for sid, values in zip(w.sensor_ids, last_raw):
                latest[sid] = TactileFrame(sensor_id=sid, seq=last_seq, t_recv=last_t, values=values)
            self._delivered = None
        for sid, values in zip(w.sensor_ids, raw):
            if not paused or sid not in paused:
                latest[sid] = TactileFrame(sensor_id=sid, seq=seq, t_recv=t, values=values)

    def read_latest(self) -> dict[int, TactileFrame]:
        self._refresh()
        return dict(self._latest)

    def stats(self) -> dict[str, int]:
        return {"frames": self.world.seq, "crc_errors": 0, "seq_gaps": 0, "resyncs": 0}

    def close(self) -> None:
        self.world.close()
