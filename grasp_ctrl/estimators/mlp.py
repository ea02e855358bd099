"""A small multilayer perceptron run in numpy: f_sensor from chosen tared channels.

The policy file holds everything (``kind = "mlp"``): the input channels (indices into
the 44-channel tared frame), their mean and scale, and the layers, tanh between them
and a linear output in N. No ONNX session: for a net this small, onnxruntime's call
overhead is ten times the arithmetic, and the mock world's default policy runs every
tick of every trial.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from grasp_ctrl import jit
from grasp_ctrl.estimators.base import Estimate
from grasp_ctrl.estimators.linear import add_bias
from grasp_ctrl.jit import njit
from grasp_ctrl.tactile.layout import FRAME_LEN

_FLOAT64 = np.dtype(np.float64)


@njit
def scaled_inputs(tared: np.ndarray, channels: np.ndarray, mean: np.ndarray, inv_scale: np.ndarray,
                  out: np.ndarray) -> None:
    """``(tared[:, channels] - mean) * inv_scale`` into ``out`` (rows, channels): the same
    subtraction and product per element as numpy's, without three array calls."""
    for i in range(out.shape[0]):
        for j in range(out.shape[1]):
            out[i, j] = (tared[i, channels[j]] - mean[j]) * inv_scale[j]


def _finite_array(value: Any, field: str, ndim: int) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{field}: numbers expected") from None
    if a.ndim != ndim or a.size == 0:
        raise ValueError(f"{field}: a non-empty {ndim}-d array expected, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{field}: every value must be finite")
    return a


class MlpEstimator:
    has_variance = False

    def __init__(self, channels: Any, mean: Any, scale: Any, layers: Any, name: str = "mlp") -> None:
        if not isinstance(channels, list) or not channels or not all(
                isinstance(c, int) and not isinstance(c, bool) and 0 <= c < FRAME_LEN for c in channels):
            raise ValueError(f"input_channels: a list of channel indices 0..{FRAME_LEN - 1}")
        mean_a = _finite_array(mean, "input_mean", 1)
        scale_a = _finite_array(scale, "input_scale", 1)
        if mean_a.shape != (len(channels),) or scale_a.shape != (len(channels),):
            raise ValueError(f"input_mean/input_scale: one value per input channel ({len(channels)})")
        if np.any(scale_a <= 0.0):
            raise ValueError("input_scale: every value must be positive")
        if not isinstance(layers, list) or not layers:
            raise ValueError("layers: a non-empty list of {weights, bias}")
        self._layers: list[tuple[np.ndarray, np.ndarray]] = []
        width = len(channels)
        for k, layer in enumerate(layers):
            if not isinstance(layer, dict):
                raise ValueError(f"layers[{k}]: a table with weights and bias")
            W = _finite_array(layer.get("weights"), f"layers[{k}].weights", 2)
            b = _finite_array(layer.get("bias"), f"layers[{k}].bias", 1)
            if W.shape[1] != width or b.shape != (W.shape[0],):
                raise ValueError(f"layers[{k}]: weights of shape (out, {width}) and bias of shape (out,) expected, "
                                 f"got {W.shape} and {b.shape}")
            self._layers.append((W.T.copy(), b))   # stored transposed: rows @ W.T
            width = W.shape[0]
        if width != 3:
            raise ValueError(f"layers: the last layer must give 3 outputs (f_sensor), got {width}")
        self._channels = np.array(channels)
        self._mean = mean_a
        self._inv_scale = 1.0 / scale_a
        self.name = name

    def estimate(self, tared: np.ndarray, fingers: Sequence[str]) -> Estimate:
        if not (type(tared) is np.ndarray and tared.dtype is _FLOAT64 and tared.ndim == 2):
            tared = np.asarray(tared, dtype=float)
        if jit.JIT and tared.ndim == 2 and tared.shape[1] == FRAME_LEN:
            # The same arithmetic in fewer calls: the inputs scaled and each layer's bias added
            # by compiled loops (the same IEEE operations), the products by ndarray.dot (the BLAS
            # call that ``@`` makes); tanh stays numpy's (its own vectorised tanh).
            x = np.empty((tared.shape[0], self._channels.size))
            scaled_inputs(tared, self._channels, self._mean, self._inv_scale, x)
            last = len(self._layers) - 1
            for k, (W_T, b) in enumerate(self._layers):
                x = x.dot(W_T)
                add_bias(x, b)
                if k < last:
                    np.tanh(x, out=x)
            return Estimate(x)
        x = (tared[:, self._channels] - self._mean) * self._inv_scale
        last = len(self._layers) - 1
        for k, (W_T, b) in enumerate(self._layers):
            x = x @ W_T
            x += b
            if k < last:
                np.tanh(x, out=x)
        return Estimate(x)
