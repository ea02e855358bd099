"""A small multilayer perceptron: f_sensor from chosen tared channels.

The policy file holds everything (``kind = "mlp"``): the input channels (indices into
the 44-channel tared frame), their mean and scale, and the layers, tanh between them
and a linear output in N. No ONNX session: for a net this small, onnxruntime's call
overhead is ten times the arithmetic, and the mock world's default policy runs every
tick of every trial. With numba (grasp_ctrl/numeric/jit.py) the forward pass is one compiled
call (``mlp_forward``, within 1e-9 N of numpy's: its sums and tanh are rounded
differently); without it, numpy's calls.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from grasp_ctrl.config.sensor_layout import FRAME_LEN
from grasp_ctrl.estimators.base import Estimate
from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.jit import njit

_FLOAT64 = np.dtype(np.float64)


#: tanh(x) is 1.0 in float64 for |x| >= 19.1: inputs are clamped to +-20 before exp(2x)
_TANH_CLAMP = 20.0
_INV_LN2 = 1.4426950408889634
_LN2_HI = 6.93147180369123816490e-01  # ln 2 in two parts (Cody and Waite), the first exact
_LN2_LO = 1.90821492927058770002e-10  # in its leading bits so that n * _LN2_HI is exact
_ROUNDER = 6755399441055744.0  # 1.5 * 2**52: y + it rounds y to an integer held in its low bits
_ROUNDER_BITS = 0x4338000000000000  # the float64 bits of _ROUNDER
#: exp's Taylor coefficients 1 / k!, k = 0..13 (the remainder is below 1e-17 for |r| <= ln2 / 2)
_E = tuple(1.0 / math.factorial(k) for k in range(14))


@njit(numpy_division=True)  # its one division vectorised
def tanh_rows(h: np.ndarray, cols: int, scratch: np.ndarray) -> None:
    """``h[:, :cols] = tanh(h[:, :cols])`` to within 4e-16 (absolute) of numpy's tanh, as
    1 - 2 / (exp(2x) + 1), exp(2x) = exp(r) 2**n with |r| <= ln2 / 2 and exp(r) by a degree-13
    Taylor polynomial: branch-free loops the compiler turns into SIMD code (libm's tanh,
    called per element, is not), NaN kept. ``scratch``: as large as ``h``, 2**n's float64 bits built there."""
    bits = scratch.view(np.int64)
    for i in range(h.shape[0]):
        for j in range(cols):
            x = h[i, j]
            x = _TANH_CLAMP if x > _TANH_CLAMP else x  # comparisons that keep a NaN
            x = -_TANH_CLAMP if x < -_TANH_CLAMP else x
            y = 2.0 * x
            t = y * _INV_LN2 + _ROUNDER
            n = t - _ROUNDER
            r = (y - n * _LN2_HI) - n * _LN2_LO
            r2 = r * r  # Estrin's scheme: a short dependency chain
            r4 = r2 * r2
            low = (_E[0] + _E[1] * r + (_E[2] + _E[3] * r) * r2) + (_E[4] + _E[5] * r + (_E[6] + _E[7] * r) * r2) * r4
            high = _E[8] + _E[9] * r + (_E[10] + _E[11] * r) * r2 + (_E[12] + _E[13] * r) * r4
            h[i, j] = low + high * (r4 * r4)
            scratch[i, j] = t
    for i in range(h.shape[0]):
        for j in range(cols):
            bits[i, j] = (bits[i, j] - _ROUNDER_BITS + 1023) << 52  # 2**n
    for i in range(h.shape[0]):
        for j in range(cols):
            h[i, j] = 1.0 - 2.0 / (h[i, j] * scratch[i, j] + 1.0)


@njit
def products(a: np.ndarray, W_T: np.ndarray, dst: np.ndarray, rows: int) -> None:
    """``dst[:rows, :n] = a[:rows, :k] @ W_T`` for W_T (k, n): per output, the products added
    in input order, each row of W_T scaled and added to a row's outputs (a loop the compiler
    vectorises with the same operations per element). Rows go three or two at a time, so
    that each row of W_T is loaded once for them (0.6 of the pass's 4.5 us saved for three
    fingertips)."""
    n_in, n_out = W_T.shape
    for i in range(rows):
        for j in range(n_out):
            dst[i, j] = 0.0
    i = 0
    while rows - i >= 3 and rows - i != 4:  # (four rows: two pairs)
        d0, d1, d2, a0, a1, a2 = dst[i], dst[i + 1], dst[i + 2], a[i], a[i + 1], a[i + 2]
        for m in range(n_in):
            x0, x1, x2, w = a0[m], a1[m], a2[m], W_T[m]
            for j in range(n_out):
                d0[j] += x0 * w[j]
                d1[j] += x1 * w[j]
                d2[j] += x2 * w[j]
        i += 3
    while rows - i >= 2:
        d0, d1, a0, a1 = dst[i], dst[i + 1], a[i], a[i + 1]
        for m in range(n_in):
            x0, x1, w = a0[m], a1[m], W_T[m]
            for j in range(n_out):
                d0[j] += x0 * w[j]
                d1[j] += x1 * w[j]
        i += 2
    if i < rows:
        d0, a0 = dst[i], a[i]
        for m in range(n_in):
            x0, w = a0[m], W_T[m]
            for j in range(n_out):
                d0[j] += x0 * w[j]


@njit(numpy_division=True)
def mlp_forward(tared: np.ndarray, layout: np.ndarray, params: np.ndarray, out: np.ndarray) -> None:
    """The whole forward pass into ``out`` (rows, outputs) in one call. ``params``: the
    inputs' mean and 1 / scale, then per layer its weights transposed (in, out) and bias,
    flat; ``layout``: the number of inputs, their channels, then each layer's (in, out)
    (few arrays: a compiled call costs some 0.1 us per array handed to it). The products
    by ``products``, the bias after them as in numpy's ``x @ W.T + b``, tanh by
    ``tanh_rows``. The sums are rounded in another order than BLAS's: a few ulp apart
    from the numpy pass."""
    rows, n_in = tared.shape[0], layout[0]
    channels = layout[1 : 1 + n_in]
    shapes = layout[1 + n_in :].reshape((-1, 2))
    width = n_in
    for k in range(shapes.shape[0]):
        width = max(width, shapes[k, 1])
    a, z, scratch = np.empty((rows, width)), np.empty((rows, width)), np.empty((rows, width))
    for i in range(rows):
        for j in range(n_in):
            a[i, j] = (tared[i, channels[j]] - params[j]) * params[n_in + j]
    at = 2 * n_in
    last = shapes.shape[0] - 1
    for k in range(last + 1):
        n_rows_w, n_out = shapes[k, 0], shapes[k, 1]
        W_T = params[at : at + n_rows_w * n_out].reshape((n_rows_w, n_out))
        b = params[at + n_rows_w * n_out : at + n_rows_w * n_out + n_out]
        at += n_rows_w * n_out + n_out
        dst = out if k == last else z
        products(a, W_T, dst, rows)
        for i in range(rows):
            for j in range(n_out):
                dst[i, j] += b[j]
        if k < last:
            tanh_rows(z, n_out, scratch)
            a, z = z, a


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
        if (
            not isinstance(channels, list)
            or not channels
            or not all(isinstance(c, int) and not isinstance(c, bool) and 0 <= c < FRAME_LEN for c in channels)
        ):
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
                raise ValueError(
                    f"layers[{k}]: weights of shape (out, {width}) and bias of shape (out,) expected, "
                    f"got {W.shape} and {b.shape}"
                )
            self._layers.append((W.T.copy(), b))  # stored transposed: rows @ W.T
            width = W.shape[0]
        if width != 3:
            raise ValueError(f"layers: the last layer must give 3 outputs (f_sensor), got {width}")
        self._channels = np.array(channels, dtype=np.int64)
        self._mean = mean_a
        self._inv_scale = 1.0 / scale_a
        # the compiled pass's arguments (mlp_forward): every layer's (in, out) and all numbers flat
        self._layout = np.array(
            [len(channels), *channels, *(n for W_T, _ in self._layers for n in W_T.shape)], dtype=np.int64
        )
        self._params = np.concatenate(
            [self._mean, self._inv_scale] + [part.ravel() for W_T, b in self._layers for part in (W_T, b)]
        )
        self.name = name

    def estimate(self, tared: np.ndarray, fingers: Sequence[str]) -> Estimate:
        if not (type(tared) is np.ndarray and tared.dtype is _FLOAT64 and tared.ndim == 2):
            tared = np.asarray(tared, dtype=float)
        if jit.JIT and tared.ndim == 2 and tared.shape[1] == FRAME_LEN:
            # one compiled call (mlp_forward): within 1e-9 N (measured: 5e-15 N) of the numpy
            # pass below (tests/estimators/test_mlp_policy.py), in a third of the time of numpy's calls
            f_sensor = np.empty((tared.shape[0], 3))
            mlp_forward(tared, self._layout, self._params, f_sensor)
            return Estimate(f_sensor)
        x = (tared[:, self._channels] - self._mean) * self._inv_scale
        last = len(self._layers) - 1
        for k, (W_T, b) in enumerate(self._layers):
            x = x @ W_T
            x += b
            if k < last:
                np.tanh(x, out=x)
        return Estimate(x)
