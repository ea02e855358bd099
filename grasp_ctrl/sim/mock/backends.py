"""Mock hand, arm and sensor backends over a MockWorld (same interfaces as the real ones)."""

from __future__ import annotations

import math

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.base import JointState, TactileFrame
from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.finite import all_finite
from grasp_ctrl.numeric.jit import njit
from grasp_ctrl.numeric.limits import limit_goal
from grasp_ctrl.sim.mock.world import MockWorld

_FLOAT64 = np.dtype(np.float64)


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
    """``MockHand.read``'s arithmetic in one pass (the same operations per element as
    its numpy code, so the same bits); ``q_prev`` becomes ``q``."""
    for j in range(q.shape[0]):
        dq_out[j] = (q[j] - q_prev[j]) / dt
        q_out[j] = q[j]
        q_prev[j] = q[j]
        current_out[j] = stiffness * (q_servo[j] - q[j]) / torque_per_amp


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


@njit
def clamped_arm_target(p: np.ndarray, z_min: float, z_max: float, out: np.ndarray) -> None:
    """``out`` = ``p`` with its height clamped as ``MockArm.command``'s Python
    ``min(max(z, z_min), z_max)`` clamps it (NaN stays NaN)."""
    out[0], out[1] = p[0], p[1]
    z = p[2]
    if z_min > z:
        z = z_min
    if z_max < z:
        z = z_max
    out[2] = z


class SimClock:
    def __init__(self, world: MockWorld) -> None:
        self.world = world

    def now(self) -> float:
        return self.world.t


class MockHand:
    """Clamps goals to the joint limits and a per-tick step limit, like the real backend."""

    def __init__(self, world: MockWorld, hand: HandConfig) -> None:
        self.world = world
        self.lower = np.array([j.lower_rad for j in hand.joints])
        self.upper = np.array([j.upper_rad for j in hand.joints])
        self.max_step = hand.safety.max_joint_step_rad
        self.connected = False
        self.fault: str | None = None  # tests inject e.g. "overload"
        self._q_prev = world.q.copy()  # for the velocity estimate of read()
        # The mock world's servo model (MuJoCoHand, a subclass, reads its state from MuJoCo instead).
        p = world.params
        self._stiffness = getattr(p, "servo_stiffness_nm_per_rad", float("nan"))
        self._torque_per_amp = getattr(p, "torque_per_amp_nm", float("nan"))
        self._n_joints = len(self.lower)
        self._write_limited = getattr(world, "write_limited_goal", None) if jit.JIT else None

    def connect(self) -> None:
        self.connected = True

    def read(self) -> JointState:
        w = self.world
        if jit.JIT:
            n = self._n_joints
            q, dq, current = np.empty(n), np.empty(n), np.empty(n)
            joint_state_kernel(
                w.q, self._q_prev, w.q_servo, w.dt, self._stiffness, self._torque_per_amp, q, dq, current
            )
            return JointState(q, dq, current, w.t)
        dq = (w.q - self._q_prev) / w.dt
        self._q_prev = w.q.copy()
        p = w.params
        current = p.servo_stiffness_nm_per_rad * (w.q_servo - w.q) / p.torque_per_amp_nm
        return JointState(q=w.q.copy(), dq=dq, current_a=current, t=w.t)

    def write_goals(self, q_goal: np.ndarray) -> None:
        q_goal = np.asarray(q_goal, dtype=float)
        if jit.JIT and q_goal.shape == self.lower.shape:
            if self._write_limited is not None:  # the mock world's own one-pass write
                if self._write_limited(q_goal, self.max_step, self.lower, self.upper):
                    return
                raise HardwareError(f"bad goal vector of shape {q_goal.shape}")
            q = np.empty(self._n_joints)
            if checked_limit_goal(q_goal, self._goal_held(), self.max_step, self.lower, self.upper, q):
                self._hold_goal(q)
                return
        if q_goal.shape != self.lower.shape or not all_finite(q_goal):
            raise HardwareError(f"bad goal vector of shape {q_goal.shape}")
        prev = self._goal_held()
        q = np.minimum(np.maximum(q_goal, prev - self.max_step), prev + self.max_step)  # = np.clip, cheaper
        self._hold_goal(np.minimum(np.maximum(q, self.lower), self.upper))

    def _goal_held(self) -> np.ndarray:
        """The goal the servos hold now, in the angles they are commanded in (the step limit's origin)."""
        return self.world.q_goal

    def _hold_goal(self, q: np.ndarray) -> None:
        """Hand the servos a clamped goal (the world's joints follow it)."""
        self.world.q_goal = q

    def set_torque(self, enabled: bool) -> None:
        self.world.torque_on = enabled

    def check_health(self) -> None:
        if self.fault:
            raise HardwareError(f"mock hand: hardware error status: {self.fault}")

    def close(self) -> None:
        self.connected = False


class MockArm:
    def __init__(self, world: MockWorld, hand: HandConfig) -> None:
        self.world = world
        self.z_min = hand.arm.z_min_m
        self.z_max = hand.arm.z_max_m
        self._z_min, self._z_max = float(self.z_min), float(self.z_max)
        self._set_clamped = getattr(world, "set_clamped_palm_target", None) if jit.JIT else None

    def connect(self) -> None:
        pass

    def command(self, p_world: np.ndarray) -> None:
        if jit.JIT and type(p_world) is np.ndarray and p_world.dtype is _FLOAT64 and p_world.shape == (3,):
            if self._set_clamped is not None:  # the mock world's own one-pass command
                if self._set_clamped(p_world, self._z_min, self._z_max):
                    return
            else:
                p = np.empty(3)
                clamped_arm_target(p_world, self._z_min, self._z_max, p)
                self.world.palm_target = p
                return
        p = np.array(p_world, dtype=float)
        p[2] = min(max(float(p[2]), self.z_min), self.z_max)
        self.world.palm_target = p

    def position(self) -> np.ndarray:
        return self.world.palm_world.copy()

    def stop(self) -> None:
        self.world.palm_target = self.world.palm_world.copy()

    def close(self) -> None:
        self.stop()


class MockSensors:
    """Delivers the world's latest simulated frame per fingertip; ``pause`` lets
    tests starve one fingertip to exercise the stale-sensor fault."""

    def __init__(self, world: MockWorld) -> None:
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
        pass
