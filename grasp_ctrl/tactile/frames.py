"""Validation of raw BioTac frames (44 counts each, docs/design.md 5.3 order).

A frame that is the wrong length, holds NaN/inf, or leaves the 12-bit range
0..4095 is rejected with a :class:`FrameError` naming the fingertip, the
channel and the offending value, so a corrupted serial stream never reaches
the estimators as a plausible-looking force.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from grasp_ctrl.config.sensor_layout import CHANNEL_NAMES, COUNT_MAX, COUNT_MIN, FRAME_LEN
from grasp_ctrl.errors import FrameError


def _who(row: int, fingers: Sequence[str] | None) -> str:
    if fingers is not None and row < len(fingers):
        return f"fingertip {fingers[row]!r}"
    return f"frame {row}"


def validate_frames(raw: object, fingers: Sequence[str] | None = None) -> np.ndarray:
    """Check raw frames and return them as a float (n, 44) array.

    ``raw``: one frame (44,) or a batch (n, 44), one row per fingertip.
    ``fingers``: optional row names used in error messages.
    """
    try:
        arr = np.asarray(raw, dtype=float)
    except (TypeError, ValueError) as exc:
        raise FrameError(f"tactile frame: not a numeric array ({exc})") from None
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != FRAME_LEN:
        got = arr.shape[-1] if arr.ndim >= 1 else 0
        raise FrameError(
            f"tactile frame: expected {FRAME_LEN} values per fingertip "
            f"(e1..e19, pdc, pac1..pac22, tdc, tac), got shape {arr.shape} ({got} values)"
        )
    # The common case in two reductions (NaN fails both comparisons); the details below
    # only when something is wrong.
    lowest, highest = arr.min(), arr.max()
    if lowest >= COUNT_MIN and highest <= COUNT_MAX:
        return arr
    finite = np.isfinite(arr)
    if not finite.all():
        row, col = np.argwhere(~finite)[0]
        raise FrameError(
            f"tactile frame: {_who(row, fingers)} channel {CHANNEL_NAMES[col]} is {arr[row, col]} "
            f"(values must be finite counts)"
        )
    bad = (arr < COUNT_MIN) | (arr > COUNT_MAX)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise FrameError(
            f"tactile frame: {_who(row, fingers)} channel {CHANNEL_NAMES[col]} = {arr[row, col]:g} "
            f"is outside the 12-bit range {COUNT_MIN}..{COUNT_MAX}"
        )
    return arr
