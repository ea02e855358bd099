"""A Dynamixel-driven arm or lift that moves the palm along a straight vertical line.

The arm is a serial chain from ``[arm]`` in the hand file (base pose in the
world frame, ``[[arm.joints]]`` like finger joints, ``tool_xyz/rpy`` from the
last link to the palm). ``command(p_world)`` is called every control tick; the
palm's set point moves along the vertical line through ``line_xy`` toward the
commanded height at ``max_speed_m_s`` and each intermediate point is solved with
position IK from the previous goal, so the palm follows the straight line
(x, y of commands are ignored: this axis only lifts and lowers).
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.base import Clock
from grasp_ctrl.hardware.dynamixel import control_table as ct
from grasp_ctrl.hardware.dynamixel.bus import DynamixelBus
from grasp_ctrl.hardware.dynamixel.calibration import Calibration
from grasp_ctrl.hardware.dynamixel.hand import MonotonicClock
from grasp_ctrl.hardware.dynamixel.setup import configure_servos
from grasp_ctrl.kinematics.chain import FingerChain
from grasp_ctrl.kinematics.ik import solve_position_ik
from grasp_ctrl.numeric.limits import clamped_palm_target


def arm_chain(hand: HandConfig) -> FingerChain:
    """The arm as a kinematic chain from the world frame to the palm."""
    a = hand.arm
    return FingerChain.from_joints("arm", a.base_xyz, a.base_rpy, a.joints, a.tool_xyz, a.tool_rpy)


class DynamixelArm:
    """ArmBackend for ``[arm] kind = "dynamixel"``."""

    def __init__(self, hand: HandConfig, port: str | None = None, clock: Clock | None = None) -> None:
        if not hand.arm.joints:
            raise HardwareError(f"{hand.path}: [arm] has no joints for a Dynamixel arm")
        self.hand = hand
        self.cfg = hand.arm
        self.clock = clock or MonotonicClock()
        self.joints = hand.arm.joints
        self.ids = [j.servo_id for j in self.joints]
        self.chain = arm_chain(hand)
        self.cal = Calibration.from_joints(self.joints)
        self.model = self.cfg.servo  # config/servos.py, or the hand file's [servo_models.NAME]
        self.bus = DynamixelBus(
            port or self.cfg.port,
            self.cfg.baud,
            {j.servo_id: j.name for j in self.joints},
            packet_timeout_ms=hand.dynamixel.packet_timeout_ms,
            retries=hand.dynamixel.retries,
            fast_sync_read=hand.dynamixel.fast_sync_read,
        )
        self.max_joint_step = hand.safety.max_joint_step_rad
        self.q_goal: np.ndarray | None = None
        self.line_xy: np.ndarray | None = None
        self.z_set = 0.0  # current set point on the line
        self.unreachable_z: float | None = None
        self.connected = False

    def connect(self) -> None:
        self.bus.open()
        self.connected = True
        try:
            missing = [f"{self.bus.label(i)}" for i in self.ids if self.bus.ping(i)[0] is None]
            if missing:
                raise HardwareError(f"arm bus {self.bus.port_name}: no reply from " + ", ".join(missing))
            configure_servos(self.bus, self.joints, self.model)
            q = self._read_q()
            p = self.chain.fk_rp(q)[1]
            self.line_xy = np.array(self.cfg.line_xy if self.cfg.line_xy is not None else p[:2], dtype=float)
            if np.linalg.norm(p[:2] - self.line_xy) > self.cfg.tolerance_m:
                raise HardwareError(
                    f"arm: palm at x,y = {p[0]:.3f}, {p[1]:.3f} m is off its vertical line "
                    f"({self.line_xy[0]:.3f}, {self.line_xy[1]:.3f}); move it there first"
                )
            self.z_set = float(p[2])
            self.q_goal = np.clip(q, self.chain.lower, self.chain.upper)
            self._send(self.q_goal)
            for i in self.ids:
                self.bus.write(i, ct.ADDR_TORQUE_ENABLE, 1, 1)
        except BaseException:
            self.bus.close()
            self.connected = False
            raise

    def _read_q(self) -> np.ndarray:
        res = self.bus.sync_read(self.ids, ct.ADDR_PRESENT_POSITION, 4)
        counts = np.array([int.from_bytes(res.data[i], "little", signed=True) for i in self.ids])
        return self.cal.to_rad(counts)

    def _send(self, q: np.ndarray) -> None:
        counts = self.cal.to_counts(q)
        self.bus.sync_write(ct.ADDR_GOAL_POSITION, 4, {i: int(c) for i, c in zip(self.ids, counts)})

    def command(self, p_world: np.ndarray) -> None:
        assert self.q_goal is not None and self.line_xy is not None, "connect() first"
        z_target = float(clamped_palm_target(p_world, self.cfg.z_min_m, self.cfg.z_max_m)[2])
        step = self.cfg.max_speed_m_s * self.hand.dt
        z_next = self.z_set + float(np.clip(z_target - self.z_set, -step, step))
        if z_next == self.z_set:
            return
        target = np.array([self.line_xy[0], self.line_xy[1], z_next])
        res = solve_position_ik(self.chain, self.q_goal, target, tol_m=self.cfg.tolerance_m * 0.1, max_iters=20)
        if res.error_m > self.cfg.tolerance_m:
            self.unreachable_z = z_next  # stay at the last reachable point of the line
            return
        q = self.q_goal + np.clip(res.q - self.q_goal, -self.max_joint_step, self.max_joint_step)
        q = np.clip(q, self.chain.lower, self.chain.upper)
        self._send(q)
        self.q_goal = q
        self.z_set = z_next

    def position(self) -> np.ndarray:
        return self.chain.fk_rp(self._read_q())[1]

    def stop(self) -> None:
        """Hold where the arm is now."""
        if not self.connected:
            return
        q = np.clip(self._read_q(), self.chain.lower, self.chain.upper)
        self._send(q)
        self.q_goal = q
        self.z_set = float(self.chain.fk_rp(q)[1][2])

    def close(self) -> None:
        """Hold, then torque off: an arm must not sag, so the torque-off step is
        left to the user's configuration (``safety.on_fault = torque_off``)."""
        if not self.connected:
            return
        self.bus.unjam()
        try:
            self.stop()
            if self.hand.safety.on_fault == "torque_off":
                for i in self.ids:
                    self.bus.write(i, ct.ADDR_TORQUE_ENABLE, 1, 0)
        except HardwareError:
            pass
        finally:
            self.bus.close()
            self.connected = False
