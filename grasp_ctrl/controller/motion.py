"""Task-space fingertip motion: targets along closing vectors -> IK -> joint goals.

The joint goal (not the measured angles) is integrated: under contact the
measured finger lags its goal and the servo's position error is what squeezes.
Every goal is clamped to the joint limits and to the per-tick step limit.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR


IK_DAMPING = 0.002


class FingertipMotion:
    def __init__(self, hand: HandConfig, kin: HandKinematics) -> None:
        self.hand = hand
        self.kin = kin
        self.lower = np.array([j.lower_rad for j in hand.joints])
        self.upper = np.array([j.upper_rad for j in hand.joints])
        self.open_q = np.array([j.open_rad for j in hand.joints])
        self.pregrasp_q = np.array([j.pregrasp_rad for j in hand.joints])
        self.max_step = hand.safety.max_joint_step_rad
        self.task_vectors = {f.name: np.array(f.task_vector_hand) for f in hand.fingers}
        self.q_goal = self.open_q.copy()
        self._q_sent = self.open_q.copy()
        self.targets: dict[str, np.ndarray] = {}
        self._reset_targets()

    def _reset_targets(self) -> None:
        self.targets = {f.name: self.pad_position(f.name, self.q_goal) for f in self.hand.fingers}

    def pad_position(self, finger: str, q_all: np.ndarray) -> np.ndarray:
        R, p = self.kin.chains[finger].fk_rp(q_all[self.kin.slices[finger]])
        return R @ PAD_POINT_SENSOR + p

    def set_posture(self, q: np.ndarray) -> None:
        self.q_goal = np.clip(np.asarray(q, dtype=float), self.lower, self.upper)
        self._reset_targets()

    def raised_posture(self, q: np.ndarray, raises_m: dict[str, float], tolerance_m: float = 5e-4) -> np.ndarray:
        """``q`` with some fingertips' pads moved straight up (hand +z) by the given
        heights, their pads still facing the way they did (e.g. the index fingertip
        on a bottle's cap); the other fingers unchanged. Raises ValueError when a
        pad cannot get there within the joint limits."""
        from scipy.optimize import least_squares

        q = np.clip(np.asarray(q, dtype=float), self.lower, self.upper).copy()
        for finger, dz in raises_m.items():
            sl = self.kin.slices[finger]
            chain = self.kin.chains[finger]
            R0, p0 = chain.fk_rp(q[sl])
            target = R0 @ PAD_POINT_SENSOR + p0 + np.array([0.0, 0.0, dz])
            facing = R0 @ PAD_NORMAL_SENSOR

            def residual(qf: np.ndarray) -> np.ndarray:
                R, p = chain.fk_rp(qf)
                # 1 rad of pad tilt weighs like 2 cm of position error.
                return np.concatenate([R @ PAD_POINT_SENSOR + p - target, 0.02 * (R @ PAD_NORMAL_SENSOR - facing)])

            fit = least_squares(residual, q[sl], bounds=(self.lower[sl], self.upper[sl]))
            miss = float(np.linalg.norm(fit.fun[:3]))
            if miss > tolerance_m:
                raise ValueError(f"{finger}: cannot raise the pad by {dz * 1000:.1f} mm within the joint limits "
                                 f"({miss * 1000:.1f} mm short)")
            q[sl] = fit.x
        return q

    def sync(self, q_measured: np.ndarray) -> None:
        """Start from where the hand is (e.g. at trial start)."""
        self.q_goal = np.clip(q_measured, self.lower, self.upper)
        self._q_sent = self.q_goal.copy()
        self._reset_targets()

    def advance(self, finger: str, distance_m: float) -> None:
        """Move one fingertip's goal along its closing vector (negative = open)."""
        if distance_m == 0.0:
            return
        sl = self.kin.slices[finger]
        chain = self.kin.chains[finger]
        # Track an explicit pad target, so linearisation errors of the small IK steps
        # are corrected every tick instead of accumulating into a drift off the line.
        self.targets[finger] = self.targets[finger] + self.task_vectors[finger] * distance_m
        pad, J = chain.point_and_jacobian(self.q_goal[sl], PAD_POINT_SENSOR)
        self.q_goal[sl] = chain.dls_step(self.q_goal[sl], J, self.targets[finger] - pad, IK_DAMPING)

    def next_goal(self) -> np.ndarray:
        """The goal to send this tick: toward q_goal, at most max_step per joint."""
        step = np.clip(self.q_goal - self._q_sent, -self.max_step, self.max_step)
        self._q_sent = np.clip(self._q_sent + step, self.lower, self.upper)
        return self._q_sent.copy()
