"""The ICRA 2019 force network as plain numpy: weights from the authors' .npz.

Layer mapping (official_icra19 README, checked against the weight shapes):
Conv (electrode grid) and Conv_1 (contact grid), 1 -> 64 channels, kernel =
stride = 2, each followed by LayerNorm + ReLU; concat -> Conv_2 (128 -> 64) ->
Conv_3 (64 -> 64) -> drop the z axis -> Conv_4 2D (64 -> 128) -> flatten ->
fully_connected (128 -> 64) -> fully_connected_1 (64 -> 32) -> fully_connected_2
(32 -> 3), LayerNorm + ReLU after every layer but the last. LayerNorm is TF1
contrib's: statistics over all non-batch axes, per-channel gamma/beta, eps 1e-12.

The dropout variant shares everything up to ``fully_connected`` + LayerNorm_5;
then 10 heads, each ``dropout -> fcn32 -> LayerNorm_{6+k} -> ReLU -> fcn3``
(fcn32/fcn3 shared, one LayerNorm per head). Its output is the mean and the
population variance over the heads.

This module is the reference the ONNX export is checked against. Grids are
channels-last (n, 16, 16, 8) like the authors' input (x, y, z cells).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

LN_EPS = 1e-12
N_DROPOUT_HEADS = 10
KEEP_PROB = 0.7


@dataclass(frozen=True)
class Icra19Weights:
    arrays: dict[str, np.ndarray]
    dropout: bool  # the multi-head dropout variant

    def __getitem__(self, key: str) -> np.ndarray:
        return self.arrays[key]


def load_weights(npz_path: str | Path) -> Icra19Weights:
    try:
        with np.load(npz_path, allow_pickle=False) as z:
            arrays = {k: np.asarray(z[k], dtype=np.float64) for k in z.files}
    except (ValueError, OSError, AttributeError) as exc:
        raise ValueError(f"{npz_path}: not a .npz weight file ({type(exc).__name__})") from None
    dropout = "fcn32/weights" in arrays
    needed = [
        "Conv/weights",
        "Conv_1/weights",
        "Conv_2/weights",
        "Conv_3/weights",
        "Conv_4/weights",
        "fully_connected/weights",
    ]
    needed += (
        ["fcn32/weights", "fcn3/weights"] if dropout else ["fully_connected_1/weights", "fully_connected_2/weights"]
    )
    missing = [k for k in needed if k not in arrays]
    if missing:
        raise ValueError(f"{npz_path}: not an ICRA 2019 weight file (missing {', '.join(missing)})")
    return Icra19Weights(arrays, dropout)


def _conv_k2s2(x: np.ndarray, w: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Channels-last conv, kernel 2, stride 2 (non-overlapping patches)."""
    spatial = x.shape[1:-1]
    n, c = x.shape[0], x.shape[-1]
    shape = [n]
    for s in spatial:
        shape += [s // 2, 2]
    x = x.reshape(*shape, c)
    if len(spatial) == 3:
        y = np.einsum("niajbkcq,abcqo->nijko", x, w)
    else:
        y = np.einsum("niajbq,abqo->nijo", x, w)
    return y + b


def _layer_norm_relu(x: np.ndarray, gamma: np.ndarray, beta: np.ndarray) -> np.ndarray:
    axes = tuple(range(1, x.ndim))
    mean = x.mean(axis=axes, keepdims=True)
    var = x.var(axis=axes, keepdims=True)
    y = (x - mean) / np.sqrt(var + LN_EPS) * gamma + beta
    return np.maximum(y, 0.0)


def trunk(
    w: Icra19Weights,
    electrode_grids: np.ndarray,
    contact_grids: np.ndarray,
    swap_branches: bool = False,
    dtype: npt.DTypeLike = np.float64,
) -> np.ndarray:
    """Grids (n, 16, 16, 8) -> (n, 64) features after fully_connected + LayerNorm_5."""
    el = np.asarray(electrode_grids, dtype=dtype)[..., None]
    cp = np.asarray(contact_grids, dtype=dtype)[..., None]
    if swap_branches:  # only for checking which branch is which
        el, cp = cp, el
    a = _layer_norm_relu(_conv_k2s2(el, w["Conv/weights"], w["Conv/biases"]), w["LayerNorm/gamma"], w["LayerNorm/beta"])
    b = _layer_norm_relu(
        _conv_k2s2(cp, w["Conv_1/weights"], w["Conv_1/biases"]), w["LayerNorm_1/gamma"], w["LayerNorm_1/beta"]
    )
    x = np.concatenate([a, b], axis=-1)
    x = _layer_norm_relu(
        _conv_k2s2(x, w["Conv_2/weights"], w["Conv_2/biases"]), w["LayerNorm_2/gamma"], w["LayerNorm_2/beta"]
    )
    x = _layer_norm_relu(
        _conv_k2s2(x, w["Conv_3/weights"], w["Conv_3/biases"]), w["LayerNorm_3/gamma"], w["LayerNorm_3/beta"]
    )
    x = x[:, :, :, 0, :]  # drop the z axis (size 1)
    x = _layer_norm_relu(
        _conv_k2s2(x, w["Conv_4/weights"], w["Conv_4/biases"]), w["LayerNorm_4/gamma"], w["LayerNorm_4/beta"]
    )
    x = x.reshape(x.shape[0], -1)
    x = x @ w["fully_connected/weights"] + w["fully_connected/biases"]
    return _layer_norm_relu(x, w["LayerNorm_5/gamma"], w["LayerNorm_5/beta"])


def dropout_masks(
    seed: int, n_heads: int = N_DROPOUT_HEADS, width: int = 64, keep_prob: float = KEEP_PROB
) -> np.ndarray:
    """Fixed inverted-dropout masks (n_heads, width): kept units scaled by 1/keep_prob."""
    rng = np.random.default_rng(seed)
    keep = rng.random((n_heads, width)) < keep_prob
    return keep.astype(np.float64) / keep_prob


def forward(
    w: Icra19Weights,
    electrode_grids: np.ndarray,
    contact_grids: np.ndarray,
    masks: np.ndarray | None = None,
    swap_branches: bool = False,
    dtype: npt.DTypeLike = np.float64,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Network output (force the finger applies, BioTac frame, N) and variance.

    icra19: returns ((n, 3), None). Dropout variant: ((n, 3) mean over heads,
    (n, 3) variance over heads); ``masks`` (heads, 64) are the fixed dropout
    masks, ``None`` means the expectation (no dropout).
    """
    if dtype != np.float64:
        w = Icra19Weights({k: v.astype(dtype) for k, v in w.arrays.items()}, w.dropout)
    x = trunk(w, electrode_grids, contact_grids, swap_branches, dtype)
    if not w.dropout:
        x = _layer_norm_relu(
            x @ w["fully_connected_1/weights"] + w["fully_connected_1/biases"],
            w["LayerNorm_6/gamma"],
            w["LayerNorm_6/beta"],
        )
        return x @ w["fully_connected_2/weights"] + w["fully_connected_2/biases"], None
    heads = []
    for k in range(N_DROPOUT_HEADS):
        h = x if masks is None else x * masks[k]
        h = _layer_norm_relu(
            h @ w["fcn32/weights"] + w["fcn32/biases"], w[f"LayerNorm_{6 + k}/gamma"], w[f"LayerNorm_{6 + k}/beta"]
        )
        heads.append(h @ w["fcn3/weights"] + w["fcn3/biases"])
    stack = np.stack(heads, axis=1)
    return stack.mean(axis=1), stack.var(axis=1)
