"""Task-space fingertip motion: targets along closing vectors -> IK -> joint goals.

The joint goal (not the measured angles) is integrated: under contact the
measured finger lags its goal and the servo's position error is what squeezes.
Every goal is clamped to the joint limits and to the per-tick step limit.

Closing (free space) and, by default, the squeeze (ramp, lift, hold, lower) move
each pad's target along its closing vector. A pad held by the object does not
move, though: the servos' position error is what pushes, and through each joint's
stiffness a goal moved along the closing vector pushes the pad off it (on the
LEAP fingers about 45 degrees down). With ``stiffness_aware`` the squeeze moves
each pad's goal along the direction whose spring force is along the closing
vector (``PadIK.squeeze_directions`` / ``squeeze_targets``), from the hand file's
servo gains (``controller/joint_stiffness.py``); without gains, along the closing
vector. Measured in docs/mujoco.md.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.controller.joint_stiffness import joint_stiffness
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR
from grasp_ctrl.kinematics.pad_ik import Facing, shared_pad_ik
from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.limits import clipped_equals, step_toward

_FLOAT64 = np.dtype(np.float64)


IK_DAMPING = 0.002


def squeeze_mode(hand: HandConfig, stiffness_aware: bool) -> str:
    """How the squeeze moves the pads' goals for this hand, and why (kept in each trial record)."""
    if not stiffness_aware:
        return "closing vector (ControllerSettings.stiffness_aware_squeeze = false)"  # (the records' words)
    stiffness = joint_stiffness(hand)
    if stiffness.kp_nm_per_rad is None:
        return f"closing vector: the joint stiffness is unknown ({stiffness.reason})"
    return f"stiffness-aware ({stiffness.reason})"


class FingertipMotion:
    def __init__(self, hand: HandConfig, kin: HandKinematics, stiffness_aware: bool = False) -> None:
        self.hand = hand
        self.kin = kin
        self.lower = np.array([j.lower_rad for j in hand.joints])
        self.upper = np.array([j.upper_rad for j in hand.joints])
        self.open_q = np.array([j.open_rad for j in hand.joints])
        self.pregrasp_q = np.array([j.pregrasp_rad for j in hand.joints])
        self.max_step = hand.safety.max_joint_step_rad
        self.names = [f.name for f in hand.fingers]
        self.index = {name: i for i, name in enumerate(self.names)}
        self.task_vectors = np.array([f.task_vector_hand for f in hand.fingers], dtype=float)  # (F, 3)
        self.ik = shared_pad_ik(kin)  # pad points are PAD_POINT_SENSOR
        self.facing: Facing | None = None  # pads kept facing these ways while moving
        # The squeeze's joint compliance (rad per N m; empty: squeeze along the closing vectors).
        self.compliance = joint_stiffness(hand).compliance_rad_per_nm if stiffness_aware else np.zeros(0)
        self.squeeze_mode = squeeze_mode(hand, stiffness_aware)
        # Each pad's measured position along its closing vector at the last squeeze tick
        # (NaN: none since the goals were last set otherwise).
        self._pad_along = np.full(len(self.names), np.nan)
        self.q_goal = self.open_q.copy()
        self.q_sent = self.open_q.copy()  # the goal last sent (next_goal steps it toward q_goal)
        self._posture: np.ndarray | None = None  # the posture the targets were last reset to
        self.targets = np.zeros((len(self.names), 3))  # pad targets, hand frame, finger order
        self._reset_targets()

    def _reset_targets(self) -> None:
        self.targets = self.ik.pad_points(self.q_goal)
        self._pad_along[:] = np.nan

    def pad_position(self, finger: str, q_all: np.ndarray) -> np.ndarray:
        R, p = self.kin.chains[finger].fk_rp(q_all[self.kin.slices[finger]])
        return R @ PAD_POINT_SENSOR + p

    def holds_posture(self, q: np.ndarray) -> bool:
        """Whether ``set_posture(q)`` would change nothing (the posture it set last, and the
        goals still there), by a compiled check of float64 angles; False where that check
        does not apply."""
        posture = self._posture
        return bool(
            jit.JIT
            and posture is not None
            and type(q) is np.ndarray
            and q.dtype is _FLOAT64
            and q.shape == self.lower.shape == posture.shape == self.q_goal.shape
            and clipped_equals(q, self.lower, self.upper, posture, self.q_goal)
        )

    def set_posture(self, q: np.ndarray) -> None:
        # States that hold a posture set it every tick: the targets follow from it alone.
        if self.holds_posture(q):
            return  # (the check below, compiled: the same posture again)
        q_goal = np.clip(np.asarray(q, dtype=float), self.lower, self.upper)
        if self._posture is not None and np.array_equal(q_goal, self._posture) and np.array_equal(q_goal, self.q_goal):
            return
        self.q_goal = q_goal
        self._posture = q_goal.copy()
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
                raise ValueError(
                    f"{finger}: cannot raise the pad by {dz * 1000:.1f} mm within the joint limits "
                    f"({miss * 1000:.1f} mm short)"
                )
            q[sl] = fit.x
        return q

    def sync(self, q_measured: np.ndarray) -> None:
        """Start from where the hand is (e.g. at trial start)."""
        self.q_goal = np.clip(q_measured, self.lower, self.upper)
        self.q_sent = self.q_goal.copy()
        self._posture = None
        self._reset_targets()

    def hold_at(self, q_measured: np.ndarray, joints: list[slice]) -> None:
        """Set the goal of the ``joints`` (slices of the hand's joints) to their measured angles
        (within the joint limits); the goal sent still moves toward it at most ``max_step`` a tick."""
        for sl in joints:
            self.q_goal[sl] = np.clip(q_measured[sl], self.lower[sl], self.upper[sl])
        self._posture = None
        self._reset_targets()

    def rebase_fingers(self, fingers: list[int]) -> None:
        """The goals of ``fingers`` (indices) were set outside the IK: their pad targets follow them
        and their next squeeze starts afresh; the other fingers' targets stay."""
        pads = self.ik.pad_points(self.q_goal)
        for i in fingers:
            self.targets[i] = pads[i]
            self._pad_along[i] = np.nan
        self._posture = None

    def advance(self, finger: str, distance_m: float) -> None:
        """Move one fingertip's goal along its closing vector (negative = open)."""
        distances = np.zeros(len(self.names))
        distances[self.index[finger]] = distance_m
        self.advance_all(distances)

    def advance_all(self, distances_m: np.ndarray) -> None:
        """Move every fingertip's goal along its closing vector by its distance (finger
        order; 0 leaves a finger as it is), one IK step per moving finger."""
        # Track an explicit pad target, so linearisation errors of the small IK steps
        # are corrected every tick instead of accumulating into a drift off the line.
        self._pad_along[:] = np.nan  # a position move: the next squeeze starts afresh
        if self.ik.advance(
            self.q_goal,
            self.targets,
            self.task_vectors,
            np.ascontiguousarray(distances_m, dtype=float),
            IK_DAMPING,
            self.facing,
        ):
            self._posture = None

    def squeeze_all(self, distances_m: np.ndarray, q_measured: np.ndarray, max_cross_m: float) -> None:
        """Move every pad's goal by its distance along its closing vector for a squeeze
        (force control): with the joints' stiffness known, plus the cross part that keeps
        the joint springs' force along the closing vector (``PadIK.squeeze_targets``, from
        the measured angles ``q_measured``; at most ``max_cross_m`` a tick), then one IK
        step; without it, ``advance_all``."""
        distances = np.ascontiguousarray(distances_m, dtype=float)
        if not self.compliance.size:
            self.advance_all(distances)
            return
        if self.ik.squeeze_step(
            self.q_goal,
            q_measured,
            self.targets,
            self.task_vectors,
            distances,
            self.compliance,
            self._pad_along,
            max_cross_m,
            IK_DAMPING,
            self.facing,
        ):
            self._posture = None

    def next_goal(self) -> np.ndarray:
        """The goal to send this tick: toward q_goal, at most max_step per joint."""
        if jit.JIT:
            step_toward(self.q_goal, self.q_sent, self.max_step, self.lower, self.upper)
            return self.q_sent.copy()
        # np.minimum/np.maximum: np.clip's result at a fraction of its call overhead.
        step = np.minimum(np.maximum(self.q_goal - self.q_sent, -self.max_step), self.max_step)
        self.q_sent = np.minimum(np.maximum(self.q_sent + step, self.lower), self.upper)
        return self.q_sent.copy()
