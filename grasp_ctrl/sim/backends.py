"""Mock hand, arm and sensor backends over a MockWorld (same interfaces as the real ones)."""

from __future__ import annotations

import numpy as np

from grasp_ctrl import jit
from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.finite import all_finite
from grasp_ctrl.hardware.base import JointState, TactileFrame
from grasp_ctrl.limits import limit_goal
from grasp_ctrl.sim.world import MockWorld


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
        self.fault: str | None = None   # tests inject e.g. "overload"
        self._q_prev = world.q.copy()   # for the velocity estimate of read()

    def connect(self) -> None:
        self.connected = True

    def read(self) -> JointState:
        w = self.world
        dq = (w.q - self._q_prev) / w.dt
        self._q_prev = w.q.copy()
        p = w.params
        current = p.servo_stiffness_nm_per_rad * (w.q_servo - w.q) / p.torque_per_amp_nm
        return JointState(q=w.q.copy(), dq=dq, current_a=current, t=w.t)

    def write_goals(self, q_goal: np.ndarray) -> None:
        q_goal = np.asarray(q_goal, dtype=float)
        if q_goal.shape != self.lower.shape or not all_finite(q_goal):
            raise HardwareError(f"bad goal vector of shape {q_goal.shape}")
        prev = self.world.q_goal
        if jit.JIT:
            q = np.empty_like(self.lower)
            limit_goal(q_goal, prev, self.max_step, self.lower, self.upper, q)
            self.world.q_goal = q
            return
        q = np.minimum(np.maximum(q_goal, prev - self.max_step), prev + self.max_step)   # = np.clip, cheaper
        self.world.q_goal = np.minimum(np.maximum(q, self.lower), self.upper)

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

    def connect(self) -> None:
        pass

    def command(self, p_world: np.ndarray) -> None:
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

    def start(self) -> None:
        self._refresh()

    def _refresh(self) -> None:
        w = self.world
        raw, seq, t, paused, latest = w.raw, w.seq, w.t, self.paused, self._latest
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
