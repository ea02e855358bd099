"""A linear regression baseline: f_sensor = W e + b over the 19 tared electrodes.

Unlike the analytic model (one gain per axis on fixed electrode normals), every
electrode gets its own weight per axis, so shear patterns can be picked up.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from grasp_ctrl.config.sensor_layout import ELECTRODES
from grasp_ctrl.estimators.base import Estimate
from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.jit import njit

_FLOAT64 = np.dtype(np.float64)


@njit
def add_bias(f: np.ndarray, b: np.ndarray) -> None:
    """``f += b`` (rows (n, m) plus (m,)), one IEEE addition per element as numpy's
    broadcast makes it (the same bits), without the ufunc's broadcasting set-up, which
    costs several microseconds per call inside a trial's loop."""
    for i in range(f.shape[0]):
        for k in range(f.shape[1]):
            f[i, k] = f[i, k] + b[k]


def fit_linear(tared: np.ndarray, f_sensor: np.ndarray, ridge: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """Ridge least squares; returns W (3, 19) in N/count and b (3,) in N."""
    e = np.asarray(tared, dtype=float)[:, ELECTRODES]
    X = np.hstack([e, np.ones((len(e), 1))])
    scale = np.r_[np.full(19, np.std(e) or 1.0), 1.0]
    Xs = X / scale
    A = Xs.T @ Xs + ridge * len(Xs) * np.diag(np.r_[np.ones(19), 0.0])
    coef = np.linalg.solve(A, Xs.T @ np.asarray(f_sensor, dtype=float)) / scale[:, None]
    return coef[:19].T, coef[19]


class LinearEstimator:
    has_variance = False

    def __init__(self, weights: npt.ArrayLike, bias: npt.ArrayLike, name: str = "linear") -> None:
        W = np.asarray(weights, dtype=float)
        b = np.asarray(bias, dtype=float)
        if W.shape != (3, 19) or b.shape != (3,) or not (np.all(np.isfinite(W)) and np.all(np.isfinite(b))):
            raise ValueError("linear policy needs weights of shape (3, 19) and bias of shape (3,), all finite")
        self.W = W
        self.b = b
        self.name = name
        self._W_T = W.T  # the transpose the product uses, made once

    def estimate(self, tared: np.ndarray, fingers: Sequence[str]) -> Estimate:
        if type(tared) is not np.ndarray or tared.dtype is not _FLOAT64:
            tared = np.asarray(tared, dtype=float)
        # ndarray.dot: the BLAS call that ``@`` makes (gemv for one row, gemm for more; the
        # same bits, tests/numeric/test_kernel_parity.py) at less than half of its call overhead
        f_sensor = tared[:, ELECTRODES].dot(self._W_T)
        if jit.JIT and f_sensor.ndim == 2:
            add_bias(f_sensor, self.b)
        else:
            f_sensor += self.b  # = (... @ W.T) + b, without a second array
        return Estimate(f_sensor)
