"""Joint angle <-> servo count conversion with per-joint offset and sign.

Servo angle theta = (counts - 2048) * 2 pi / 4096 (0 at the servo's centre).
Joint angle q = sign * (theta - offset_rad): ``offset_rad`` is the servo angle,
measured from the centre in the servo's own direction, at which the joint is
at its zero; ``sign`` = -1 when the servo turns against the joint axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasp_ctrl.config.hand import JointConfig
from grasp_ctrl.hardware.dynamixel.control_table import CENTER_COUNTS, RAD_PER_COUNT, RAD_S_PER_VELOCITY_UNIT


@dataclass(frozen=True)
class Calibration:
    offset_rad: np.ndarray
    sign: np.ndarray
    lower_rad: np.ndarray
    upper_rad: np.ndarray

    @classmethod
    def from_joints(cls, joints: tuple[JointConfig, ...] | list[JointConfig]) -> Calibration:
        return cls(
            offset_rad=np.array([j.offset_rad for j in joints], dtype=float),
            sign=np.array([j.sign for j in joints], dtype=float),
            lower_rad=np.array([j.lower_rad for j in joints], dtype=float),
            upper_rad=np.array([j.upper_rad for j in joints], dtype=float),
        )

    def to_rad(self, counts: np.ndarray) -> np.ndarray:
        theta = (np.asarray(counts, dtype=float) - CENTER_COUNTS) * RAD_PER_COUNT
        return self.sign * (theta - self.offset_rad)

    def to_counts_float(self, q_rad: np.ndarray) -> np.ndarray:
        theta = self.sign * np.asarray(q_rad, dtype=float) + self.offset_rad
        return CENTER_COUNTS + theta / RAD_PER_COUNT

    def velocity_to_rad_s(self, units: np.ndarray) -> np.ndarray:
        return self.sign * np.asarray(units, dtype=float) * RAD_S_PER_VELOCITY_UNIT

    def limit_counts(self) -> tuple[np.ndarray, np.ndarray]:
        """Integer (min, max) position-limit registers: inside the joint limits after rounding."""
        a = self.to_counts_float(self.lower_rad)
        b = self.to_counts_float(self.upper_rad)
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        return np.ceil(lo - 1e-9).astype(np.int64), np.floor(hi + 1e-9).astype(np.int64)

    def to_counts(self, q_rad: np.ndarray) -> np.ndarray:
        """Goal counts, rounded and clamped to the position-limit registers."""
        lo, hi = self.limit_counts()
        c = np.rint(self.to_counts_float(q_rad)).astype(np.int64)
        return np.clip(c, lo, hi)
