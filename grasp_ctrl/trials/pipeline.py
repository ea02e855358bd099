"""One control tick's sensing: raw frames -> (tactile pipeline: validate, tare,
contact gate, estimator) -> forces in sensor, hand and world frames -> Snapshot
(DESIGN.md 3)."""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.controller.snapshot import Snapshot
from grasp_ctrl.errors import SensorStaleError
from grasp_ctrl.estimators.base import ForceEstimator
from grasp_ctrl.hardware.base import JointState, TactileFrame
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.pad_ik import PadIK
from grasp_ctrl.tactile.layout import FRAME_LEN
from grasp_ctrl.tactile.pipeline import TactilePipeline


class SensingPipeline:
    def __init__(self, hand: HandConfig, kin: HandKinematics, estimator: ForceEstimator) -> None:
        self.hand = hand
        self.kin = kin
        self.fast_kin = PadIK(kin)   # sensor rotations, compiled with the sim extra
        self.estimator = estimator
        self.names = [f.name for f in hand.fingers]
        self.sensor_ids = [f.sensor_id for f in hand.fingers]
        n = len(self.names)
        self.tactile = TactilePipeline.from_hand(hand, estimator)
        self._tare_window: list[np.ndarray] = []
        self.raw = np.zeros((n, FRAME_LEN))
        self.tared = np.zeros((n, FRAME_LEN))

    def frames_matrix(self, frames: dict[int, TactileFrame], now: float) -> np.ndarray:
        """(n_tips, 44) raw counts in finger order; a missing or old frame is a fault."""
        stale_after = self.hand.tactile.stale_after_s
        raw = np.empty((len(self.names), FRAME_LEN))
        for i, sid in enumerate(self.sensor_ids):
            frame = frames.get(sid)
            if frame is None:
                raise SensorStaleError(f"fingertip {self.names[i]!r} (sensor {sid}): no frame received")
            age = now - frame.t_recv
            if age > stale_after:
                raise SensorStaleError(
                    f"fingertip {self.names[i]!r} (sensor {sid}): last frame {age * 1000:.0f} ms old "
                    f"(stale after {stale_after * 1000:.0f} ms)"
                )
            raw[i] = frame.values
        return raw

    def collect_tare(self, raw: np.ndarray) -> bool:
        """Add one free-space frame to the tare window; True once the baseline is set."""
        if self.tactile.tare.ready:
            return True
        self._tare_window.append(raw.copy())
        if len(self._tare_window) >= self.hand.tactile.tare_frames:
            self.tactile.set_baseline(np.stack(self._tare_window))
            self._tare_window.clear()
        return self.tactile.tare.ready

    def snapshot(
        self,
        raw: np.ndarray,
        joints: JointState,
        p_palm_world: np.ndarray,
        collecting_tare: bool,
        fault: str | None = None,
    ) -> Snapshot:
        n = len(self.names)
        self.raw = raw
        tare_ready = self.collect_tare(raw) if collecting_tare else self.tactile.tare.ready
        if tare_ready:
            tips = self.tactile.step(raw)
            tared, in_contact, f_sensor, variance = tips.tared, tips.in_contact, tips.f_sensor, tips.variance
        else:
            tared = np.zeros_like(raw)
            in_contact = np.zeros(n, dtype=bool)
            f_sensor = np.zeros((n, 3))
            variance = None
        self.tared = tared
        R = self.fast_kin.sensor_rotations(joints.q)
        f_hand = np.einsum("nij,nj->ni", R, f_sensor)
        f_world = f_hand  # the arm translates the hand: hand axes = world axes
        # Grip = the squeeze: the force across the lift direction (world z). Along z
        # the fingertips also carry the object's weight, which must not count as grip.
        grip = np.sqrt(f_world[:, 0] ** 2 + f_world[:, 1] ** 2)
        return Snapshot(
            t=joints.t,
            q=joints.q,
            p_palm_world=p_palm_world,
            tare_ready=tare_ready,
            in_contact=in_contact,
            f_sensor=f_sensor,
            f_hand=f_hand,
            f_world=f_world,
            grip_n=grip,
            variance=variance,
            fault=fault,
        )
