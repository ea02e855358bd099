"""Error metrics of the paper (eqs. 14-15), per sample, and their summaries."""

from __future__ import annotations

import numpy as np

METRICS = ("direction_error_pct", "magnitude_error_pct", "magnitude_error_n", "angle_deg")
UNITS = {"direction_error_pct": "%", "magnitude_error_pct": "%", "magnitude_error_n": "N", "angle_deg": "deg"}


def per_sample(f_true: np.ndarray, f_pred: np.ndarray) -> dict[str, np.ndarray]:
    """Direction error % = 100 acos(f_hat_3d . f_hat_p) / pi; magnitude error % (symmetric);
    magnitude error in N = | ||f_3d|| - ||f_p|| |; the angle in degrees."""
    f_true = np.asarray(f_true, dtype=float)
    f_pred = np.asarray(f_pred, dtype=float)
    nt = np.linalg.norm(f_true, axis=1)
    npred = np.linalg.norm(f_pred, axis=1)
    cos = np.einsum("ij,ij->i", f_true, f_pred) / np.maximum(nt * npred, 1e-12)
    angle = np.arccos(np.clip(cos, -1.0, 1.0))
    angle = np.where(npred > 0, angle, np.pi / 2)  # a zero prediction has no direction: call it 90 deg
    return {
        "direction_error_pct": 100.0 * angle / np.pi,
        "magnitude_error_pct": 100.0 * np.abs(nt - npred) / np.maximum(nt + npred, 1e-12),
        "magnitude_error_n": np.abs(nt - npred),
        "angle_deg": np.degrees(angle),
    }


def summarize(values: dict[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """Median and quartiles (the paper's box plots) per metric."""
    out = {}
    for name, v in values.items():
        q1, med, q3 = np.percentile(v, [25, 50, 75]) if len(v) else (np.nan,) * 3
        out[name] = {"median": float(med), "q1": float(q1), "q3": float(q3), "n": int(len(v))}
    return out


def by_source(f_true: np.ndarray, f_pred: np.ndarray, source: np.ndarray) -> dict[str, dict[str, dict[str, float]]]:
    """Summaries per source and for all samples together ("mixed")."""
    values = per_sample(f_true, f_pred)
    out = {}
    for s in sorted(set(source.tolist())):
        m = source == s
        out[s] = summarize({k: v[m] for k, v in values.items()})
    out["mixed"] = summarize(values)
    return out
