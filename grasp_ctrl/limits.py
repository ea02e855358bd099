"""Joint-goal limiting as compiled loops (grasp_ctrl/jit.py): the per-tick step and
range limits of the controller's goals and of the mock hand.

Each computes exactly what ``np.minimum(np.maximum(x, low), high)`` computes per
element (NaN stays NaN, ties keep ``x``), in one pass instead of four to six
numpy calls on a 16-joint vector.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.jit import njit


@njit
def clamp(x: float, low: float, high: float) -> float:
    """``np.minimum(np.maximum(x, low), high)`` for one value."""
    if x != x:
        return x
    return low if x < low else (high if x > high else x)


@njit
def step_toward(goal: np.ndarray, sent: np.ndarray, max_step: float, lower: np.ndarray, upper: np.ndarray) -> None:
    """``sent`` (in place) moved toward ``goal`` by at most ``max_step`` per joint, then
    clamped to [lower, upper]."""
    for j in range(sent.shape[0]):
        sent[j] = clamp(sent[j] + clamp(goal[j] - sent[j], -max_step, max_step), lower[j], upper[j])


@njit
def limit_goal(goal: np.ndarray, prev: np.ndarray, max_step: float, lower: np.ndarray, upper: np.ndarray,
               out: np.ndarray) -> None:
    """``out`` = ``goal`` within ``max_step`` of ``prev`` per joint, then within [lower, upper]."""
    for j in range(goal.shape[0]):
        out[j] = clamp(clamp(goal[j], prev[j] - max_step, prev[j] + max_step), lower[j], upper[j])
