"""Per-fingertip taring and pdc-based contact gating (vectorised over fingertips).

Tared value = raw - baseline (docs/design.md 4): electrodes drop under contact, so a
pressed electrode is negative and pdc is positive. Contact = tared pdc above a
threshold for N consecutive frames (paper: 10 counts, 10 frames).
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config.sensor_layout import COUNT_MAX, COUNT_MIN, FRAME_LEN, PDC
from grasp_ctrl.numeric.jit import njit


class Tare:
    """Baselines for n fingertips, from the mean of a no-contact window."""

    def __init__(self, n_tips: int) -> None:
        self.n_tips = n_tips
        self.baseline = np.zeros((n_tips, FRAME_LEN))
        self.ready = False

    def set_baseline(self, frames: np.ndarray) -> None:
        """``frames``: (k, n_tips, 44) raw frames recorded without contact."""
        frames = np.asarray(frames, dtype=float)
        if frames.ndim != 3 or frames.shape[1:] != (self.n_tips, FRAME_LEN) or frames.shape[0] < 1:
            raise ValueError(f"tare window must have shape (k>=1, {self.n_tips}, {FRAME_LEN}), got {frames.shape}")
        self.baseline = frames.mean(axis=0)
        self.ready = True

    def apply(self, raw: np.ndarray) -> np.ndarray:
        """(n_tips, 44) raw -> tared (float)."""
        return np.asarray(raw, dtype=float) - self.baseline


class ContactGate:
    """Debounced contact flags: tared pdc > threshold for ``frames`` consecutive frames."""

    def __init__(self, n_tips: int, threshold: float = 10.0, frames: int = 10) -> None:
        if frames < 1:
            raise ValueError("frames must be >= 1")
        self.threshold = float(threshold)
        self.frames = int(frames)
        self.count = np.zeros(n_tips, dtype=np.int64)

    def reset(self) -> None:
        self.count[:] = 0

    def update(self, tared: np.ndarray) -> np.ndarray:
        """Feed one tared frame per fingertip; returns the (n_tips,) contact flags."""
        above = np.asarray(tared)[:, PDC] > self.threshold
        self.count = (self.count + 1) * above  # = np.where(above, count + 1, 0), in two cheap calls
        return self.count >= self.frames


@njit
def tare_and_gate(
    raw: np.ndarray,
    baseline: np.ndarray,
    count: np.ndarray,
    threshold: float,
    frames: int,
    tared: np.ndarray,
    contact: np.ndarray,
) -> int:
    """One tick of validation, ``Tare.apply`` and ``ContactGate.update`` over (n, 44)
    float frames in one compiled pass: ``tared`` = raw - baseline, ``count`` and
    ``contact`` updated in place; returns how many fingertips are in contact. -1,
    with nothing changed, when a value is not a finite count in range (the caller
    then names it, tactile/frames.py)."""
    n, m = raw.shape
    for i in range(n):
        for k in range(m):
            v = raw[i, k]
            if not (v >= COUNT_MIN and v <= COUNT_MAX):  # NaN fails both
                return -1
    touching = 0
    for i in range(n):
        for k in range(m):
            tared[i, k] = raw[i, k] - baseline[i, k]
        count[i] = count[i] + 1 if tared[i, PDC] > threshold else 0
        contact[i] = count[i] >= frames
        touching += contact[i]
    return touching


@njit
def tare_and_gate_bits(
    raw: np.ndarray,
    baseline: np.ndarray,
    count: np.ndarray,
    threshold: float,
    frames: int,
    tared: np.ndarray,
    contact: np.ndarray,
) -> int:
    """``tare_and_gate``, returning which fingertips are in contact as bits (bit i:
    fingertip i; at most 62 fingertips) instead of how many; -1 likewise."""
    if tare_and_gate(raw, baseline, count, threshold, frames, tared, contact) < 0:
        return -1
    bits = 0
    for i in range(contact.shape[0]):
        if contact[i]:
            bits |= 1 << i
    return bits


@njit
def scatter_rows(rows: np.ndarray, bits: int, out: np.ndarray) -> None:
    """``out[idx] = rows`` with ``idx`` the set bits of ``bits`` in increasing order
    (the rows of the fingertips in contact back in their places)."""
    k = 0
    for i in range(out.shape[0]):
        if bits >> i & 1:
            for c in range(out.shape[1]):
                out[i, c] = rows[k, c]
            k += 1
