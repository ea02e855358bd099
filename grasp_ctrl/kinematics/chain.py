"""Kinematic chains of the fingers, built from a HandConfig.

Every finger is a serial chain of revolute joints from the palm (hand frame)
to the fingertip sensor frame. Joint vectors are ordered as in the hand file.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from grasp_ctrl.config.hand import FingerConfig, HandConfig, JointConfig
from grasp_ctrl.kinematics.transforms import rpy_matrix, transform


@dataclass
class FingerChain:
    name: str
    T_hand_base: np.ndarray  # (4, 4)
    T_origins: list[np.ndarray]  # per joint, parent link -> joint frame (4, 4)
    axes: np.ndarray  # (n, 3) joint axes in the joint frames
    T_tip: np.ndarray  # last link -> sensor frame (4, 4)
    lower: np.ndarray
    upper: np.ndarray

    def __post_init__(self) -> None:
        # Precomputed pieces: FK runs many times per control tick (controller and mock world).
        self._R_base = self.T_hand_base[:3, :3].copy()
        self._p_base = self.T_hand_base[:3, 3].copy()
        self._R_org = np.array([T[:3, :3] for T in self.T_origins])
        self._p_org = np.array([T[:3, 3] for T in self.T_origins])
        K = np.zeros((self.n, 3, 3))
        for i, (x, y, z) in enumerate(self.axes):
            K[i] = [[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]]
        self._K = K
        self._K2 = K @ K
        self._R_tip = self.T_tip[:3, :3].copy()
        self._p_tip = self.T_tip[:3, 3].copy()

    @classmethod
    def from_joints(
        cls,
        name: str,
        base_xyz: Sequence[float],
        base_rpy: Sequence[float],
        joints: Sequence[JointConfig],
        tip_xyz: Sequence[float],
        tip_rpy: Sequence[float],
    ) -> FingerChain:
        """A chain from its base pose, joint configs and end (tip or tool) pose."""
        return cls(
            name=name,
            T_hand_base=transform(base_xyz, rpy_matrix(base_rpy)),
            T_origins=[transform(j.origin_xyz, rpy_matrix(j.origin_rpy)) for j in joints],
            axes=np.array([j.axis for j in joints], dtype=float),
            T_tip=transform(tip_xyz, rpy_matrix(tip_rpy)),
            lower=np.array([j.lower_rad for j in joints]),
            upper=np.array([j.upper_rad for j in joints]),
        )

    @classmethod
    def from_config(cls, f: FingerConfig) -> FingerChain:
        return cls.from_joints(f.name, f.base_xyz, f.base_rpy, f.joints, f.tip_xyz, f.tip_rpy)

    @property
    def n(self) -> int:
        return len(self.T_origins)

    def _frames(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Joint frames (after each joint origin, before its rotation) as rotations
        (n, 3, 3) and origins (n, 3), then the sensor frame's rotation and origin."""
        R = self._R_base
        p = self._p_base
        Rs = np.empty((self.n, 3, 3))
        ps = np.empty((self.n, 3))
        eye = np.eye(3)
        for i in range(self.n):
            p = p + R @ self._p_org[i]
            R = R @ self._R_org[i]
            Rs[i] = R
            ps[i] = p
            qi = float(q[i])
            R = R @ (eye + math.sin(qi) * self._K[i] + (1.0 - math.cos(qi)) * self._K2[i])
        return Rs, ps, R @ self._R_tip, p + R @ self._p_tip

    def joint_axes_and_origins(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each joint's axis (n, 3, unit) and origin (n, 3) in the hand frame at angles q."""
        Rs, ps, _, _ = self._frames(np.asarray(q, dtype=float))
        return np.einsum("nij,nj->ni", Rs, self.axes), ps

    def fk_rp(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sensor frame in the hand frame as (rotation (3, 3), origin (3,))."""
        _, _, R, p = self._frames(q)
        return R, p

    def fk(self, q: np.ndarray) -> np.ndarray:
        """T_hand_sensor (4, 4) for joint angles q (rad)."""
        R, p = self.fk_rp(q)
        return transform(p, R)

    def point_and_jacobian(self, q: np.ndarray, p_sensor: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """A sensor-frame point in the hand frame and its position Jacobian (3, n)."""
        Rs, ps, R_s, p_s = self._frames(q)
        p_hand = p_s if p_sensor is None else R_s @ np.asarray(p_sensor, dtype=float) + p_s
        a = np.einsum("nij,nj->ni", Rs, self.axes)
        b = p_hand - ps
        J = np.array(
            [
                a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
                a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
            ]
        )
        return p_hand, J

    def jacobian(self, q: np.ndarray, p_sensor: np.ndarray | None = None) -> np.ndarray:
        """Position Jacobian (3, n) in the hand frame of a point fixed in the sensor frame."""
        return self.point_and_jacobian(q, p_sensor)[1]

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
        return self.dls_step(q, self.jacobian(q, p_sensor), dp_hand, damping)

    def dls_step(self, q: np.ndarray, J: np.ndarray, dp_hand: np.ndarray, damping: float = 0.01) -> np.ndarray:
        """The step of ``ik_step`` for a Jacobian the caller already has."""
        step = self.dls_delta(q, J, dp_hand, damping)
        if step is None:
            return np.clip(q, self.lower, self.upper)
        return np.clip(q + step[0], self.lower, self.upper)

    def dls_delta(
        self, q: np.ndarray, J: np.ndarray, dp_hand: np.ndarray, damping: float = 0.01
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """The joint change of ``dls_step`` (unclamped) and the joints that carry it;
        None when every joint is blocked at a limit."""
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
                return None
        return dq, active


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
