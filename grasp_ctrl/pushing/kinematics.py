"""Velocities and accelerations of the tracked object by Savitzky-Golay filtering."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter


@dataclass(frozen=True)
class PlanarMotion:
    """Smoothed planar motion of the object's centre of mass, world plane."""

    t: np.ndarray  # (s,) s
    theta: np.ndarray  # (s,) rad, unwrapped and smoothed
    v: np.ndarray  # (s, 2) m/s
    a: np.ndarray  # (s, 2) m/s^2
    omega: np.ndarray  # (s,) rad/s
    alpha: np.ndarray  # (s,) rad/s^2


def sample_period(t: np.ndarray, tolerance: float = 0.05) -> float:
    """The common time step; Savitzky-Golay needs (nearly) uniform sampling."""
    dt = np.diff(t)
    if len(dt) == 0 or np.any(dt <= 0):
        raise ValueError("t must be strictly increasing with at least two samples")
    step = float(np.median(dt))
    if np.max(np.abs(dt - step)) > tolerance * step:
        raise ValueError(
            f"t must be uniformly sampled (median step {step:.6g} s, worst deviation {np.max(np.abs(dt - step)):.3g} s)"
        )
    return step


def planar_motion(
    t: np.ndarray, x: np.ndarray, y: np.ndarray, theta: np.ndarray, window_s: float = 0.31, polyorder: int = 3
) -> PlanarMotion:
    """Differentiate tracked poses (paper: Savitzky-Golay) into v, a, omega, alpha."""
    dt = sample_period(t)
    n = len(t)
    window = int(round(window_s / dt)) | 1  # odd number of samples
    window = min(window, n if n % 2 else n - 1)
    if window <= polyorder:
        raise ValueError(f"trajectory too short for a Savitzky-Golay window ({n} samples)")
    th = np.unwrap(theta)

    def d(sig: np.ndarray, order: int) -> np.ndarray:
        return savgol_filter(sig, window, polyorder, deriv=order, delta=dt, mode="interp")

    return PlanarMotion(
        t=np.asarray(t, dtype=float),
        theta=d(th, 0),
        v=np.column_stack([d(x, 1), d(y, 1)]),
        a=np.column_stack([d(x, 2), d(y, 2)]),
        omega=d(th, 1),
        alpha=d(th, 2),
    )
