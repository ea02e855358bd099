"""The analytic linear model of Lin et al. (2013), paper eq. (15):

    f = [S_x sum_i e_i n_xi, S_y sum_i e_i n_yi, S_z sum_i e_i n_zi]

with tared electrode values e_i (counts, negative when pressed) and the
outward electrode normals n_i. Pressed electrodes (e_i < 0) on outward normals
give a sum pointing into the sensor, i.e. along f_sensor (force on the skin),
so fitted gains come out positive.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from grasp_ctrl.config.sensor_layout import ELECTRODES
from grasp_ctrl.estimators.base import Estimate
from grasp_ctrl.tactile.geometry import ELECTRODE_NORMALS_SENSOR


def electrode_normal_sums(tared: np.ndarray) -> np.ndarray:
    """(n, 44) tared frames -> (n, 3) sum_i e_i n_i (counts)."""
    return np.asarray(tared, dtype=float)[:, ELECTRODES] @ ELECTRODE_NORMALS_SENSOR


def fit_gains(tared: np.ndarray, f_sensor: np.ndarray) -> np.ndarray:
    """Per-axis least-squares gains S (N/count) from tared frames and force labels."""
    s = electrode_normal_sums(tared)
    f = np.asarray(f_sensor, dtype=float)
    denom = np.einsum("ij,ij->j", s, s)
    if np.any(denom <= 0):
        raise ValueError("cannot fit gains: an axis has no electrode signal")
    return np.einsum("ij,ij->j", s, f) / denom


class AnalyticEstimator:
    has_variance = False

    def __init__(self, gains: npt.ArrayLike, name: str = "analytic") -> None:
        g = np.asarray(gains, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError("analytic gains must be three finite numbers")
        self.gains = g
        self.name = name

    def estimate(self, tared: np.ndarray, fingers: Sequence[str]) -> Estimate:
        return Estimate(f_sensor=electrode_normal_sums(tared) * self.gains)
