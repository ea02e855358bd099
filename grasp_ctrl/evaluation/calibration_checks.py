"""Is a fitted calibration worth writing? A fit that makes the direction error worse, or
whose matrix collapses an axis (a stretch near zero: every force along it would read as
zero), is named here; ``calibrate`` refuses to write it unless told to (``--allow-worse``)."""

from __future__ import annotations

from typing import Any

import numpy as np

MIN_STRETCH_RATIO = 1e-3  # the smallest singular value of the correction matrix, relative to the largest
WORSE_BY_DEG = 0.5  # a median direction error this much above the base policy's


def fit_problems(matrix: Any, metrics: dict[str, dict[str, dict[str, float]]]) -> list[str]:
    """What is wrong with a fit, in words (empty when nothing is)."""
    out = []
    a = np.asarray(matrix, dtype=float)
    if a.shape != (3, 3) or not np.all(np.isfinite(a)):
        return ["the correction matrix is not a finite 3x3 matrix"]
    s = np.linalg.svd(a, compute_uv=False)
    if not s.max() > 0 or s.min() < MIN_STRETCH_RATIO * s.max():
        out.append(
            f"the correction collapses an axis (stretches {', '.join(f'{v:.3g}' for v in s)}: forces "
            f"along the smallest would read as about zero; at least {MIN_STRETCH_RATIO:g} of the largest needed)"
        )
    for part, m in metrics.items():
        before, after = m.get("before", {}).get("median_deg"), m.get("after", {}).get("median_deg")
        if before is None or after is None:
            continue
        if not np.isfinite(after) or after > before + WORSE_BY_DEG:
            out.append(f"the correction makes the {part} error worse (median {before:.1f} -> {after:.1f} deg)")
    return out
