"""Kinematic chains of the fingers, built from a HandConfig.

Every finger is a serial chain of revolute joints from the palm (hand frame)
to the fingertip sensor frame. Joint vectors are ordered as in the hand file.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasp_ctrl.config.hand import FingerConfig, HandConfig
from grasp_ctrl.kinematics.transforms import axis_angle, rpy_matrix, transform


@dataclass
class FingerChain:
    name: str
    T_hand_base: np.ndarray          # (4, 4)
    T_origins: list[np.ndarray]      # per joint, parent link -> joint frame (4, 4)
    axes: np.ndarray                 # (n, 3) joint axes in the joint frames
    T_tip: np.ndarray                # last link -> sensor frame (4, 4)
    lower: np.ndarray
    upper: np.ndarray

    @classmethod
    def from_config(cls, f: FingerConfig) -> "FingerChain":
        return cls(
            name=f.name,
            T_hand_base=transform(f.base_xyz, rpy_matrix(f.base_rpy)),
            T_origins=[transform(j.origin_xyz, rpy_matrix(j.origin_rpy)) for j in f.joints],
            axes=np.array([j.axis for j in f.joints], dtype=float),
            T_tip=transform(f.tip_xyz, rpy_matrix(f.tip_rpy)),
            lower=np.array([j.lower_rad for j in f.joints]),
            upper=np.array([j.upper_rad for j in f.joints]),
        )

    @property
    def n(self) -> int:
        return len(self.T_origins)

    def _frames(self, q: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
        """Joint frames (after the joint origin, before its rotation) and the sensor frame."""
        T = self.T_hand_base.copy()
        joint_frames = []
        for T_o, axis, qi in zip(self.T_origins, self.axes, q):
            T = T @ T_o
            joint_frames.append(T.copy())
            T = T @ transform((0.0, 0.0, 0.0), axis_angle(axis, qi))
        return joint_frames, T @ self.T_tip

    def fk(self, q: np.ndarray) -> np.ndarray:
        """T_hand_sensor (4, 4) for joint angles q (rad)."""
        return self._frames(np.asarray(q, dtype=float))[1]

    def jacobian(self, q: np.ndarray, p_sensor: np.ndarray | None = None) -> np.ndarray:
        """Position Jacobian (3, n) in the hand frame of a point fixed in the sensor frame."""
        joint_frames, T_s = self._frames(np.asarray(q, dtype=float))
        p_local = np.zeros(3) if p_sensor is None else np.asarray(p_sensor, dtype=float)
        p_hand = T_s[:3, :3] @ p_local + T_s[:3, 3]
        J = np.empty((3, self.n))
        for i, (T_j, axis) in enumerate(zip(joint_frames, self.axes)):
            a_hand = T_j[:3, :3] @ axis
            J[:, i] = np.cross(a_hand, p_hand - T_j[:3, 3])
        return J

    def ik_step(
        self,
        q: np.ndarray,
        dp_hand: np.ndarray,
        p_sensor: np.ndarray | None = None,
        damping: float = 0.01,
    ) -> np.ndarray:
        """Damped least-squares joint step for a small Cartesian displacement of a
        sensor-frame point, clamped to the joint limits. Returns the new joint angles."""
        q = np.asarray(q, dtype=float)
        J = self.jacobian(q, p_sensor)
        # Joints at a limit that the step would push further are frozen, so the
        # remaining joints carry the motion instead of it being clipped away.
        active = np.ones(self.n, dtype=bool)
        for _ in range(2):
            Ja = J[:, active]
            dq_a = Ja.T @ np.linalg.solve(Ja @ Ja.T + damping**2 * np.eye(3), dp_hand)
            dq = np.zeros(self.n)
            dq[active] = dq_a
            blocked = ((q + dq < self.lower) & (dq < 0)) | ((q + dq > self.upper) & (dq > 0))
            if not blocked.any():
                break
            active &= ~blocked
            if not active.any():
                return np.clip(q, self.lower, self.upper)
        return np.clip(q + dq, self.lower, self.upper)


class HandKinematics:
    """All finger chains of one hand; joint vectors span all fingers in file order."""

    def __init__(self, hand: HandConfig) -> None:
        self.hand = hand
        self.chains = {f.name: FingerChain.from_config(f) for f in hand.fingers}
        self.slices = {f.name: hand.joint_slice(f.name) for f in hand.fingers}

    def fk(self, finger: str, q_all: np.ndarray) -> np.ndarray:
        return self.chains[finger].fk(q_all[self.slices[finger]])

    def sensor_poses(self, q_all: np.ndarray) -> dict[str, np.ndarray]:
        return {name: self.fk(name, q_all) for name in self.chains}
