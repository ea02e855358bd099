"""Joint-goal limiting as compiled loops (grasp_ctrl/numeric/jit.py): the per-tick step and
range limits of the controller's goals and of every hand backend's (``limit_goal``, and
``limited_goal`` for the real hands' drivers); and the arm's palm height kept within its range
(``clamp_palm_height``, ``clamped_palm_target``) for every arm backend.

Each computes exactly what ``np.minimum(np.maximum(x, low), high)`` computes per
element (NaN in, NaN out; signed zeros as numpy orders them), in one pass instead of four to six
numpy calls on a 16-joint vector.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.numeric.jit import njit


@njit
def _maximum(a: float, b: float) -> float:
    """``np.maximum`` of two values: NaN if either is NaN; of equal values (0.0 and -0.0), ``b``."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a > b else b


@njit
def _minimum(a: float, b: float) -> float:
    """``np.minimum`` of two values (the same rules)."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a < b else b


@njit
def clamp(x: float, low: float, high: float) -> float:
    """``np.minimum(np.maximum(x, low), high)`` for one value."""
    return _minimum(_maximum(x, low), high)


@njit
def clamp_palm_height(p: np.ndarray, z_min: float, z_max: float, out: np.ndarray) -> None:
    """``out`` = the palm target ``p`` with its height within the arm's [z_min, z_max], as
    Python's ``min(max(z, z_min), z_max)`` (NaN stays NaN)."""
    z = p[2]
    if z_min > z:
        z = z_min
    if z_max < z:
        z = z_max
    out[0], out[1], out[2] = p[0], p[1], z


_FLOAT64 = np.dtype(np.float64)


def clamped_palm_target(p_world: np.ndarray, z_min: float, z_max: float) -> np.ndarray:
    """A new float64 array: the palm target ``p_world`` (x, y, z) with its height within
    [z_min, z_max], as every arm backend clamps it."""
    p = p_world if type(p_world) is np.ndarray and p_world.dtype is _FLOAT64 else np.array(p_world, dtype=float)
    if p.shape != (3,):
        raise ValueError(f"a palm target is (x, y, z) (got shape {p.shape})")
    out = np.empty(3)
    clamp_palm_height(p, float(z_min), float(z_max), out)
    return out


@njit
def step_toward(goal: np.ndarray, sent: np.ndarray, max_step: float, lower: np.ndarray, upper: np.ndarray) -> None:
    """``sent`` (in place) moved toward ``goal`` by at most ``max_step`` per joint, then
    clamped to [lower, upper]."""
    for j in range(sent.shape[0]):
        sent[j] = clamp(sent[j] + clamp(goal[j] - sent[j], -max_step, max_step), lower[j], upper[j])


@njit
def limit_goal(
    goal: np.ndarray, prev: np.ndarray, max_step: float, lower: np.ndarray, upper: np.ndarray, out: np.ndarray
) -> None:
    """``out`` = ``goal`` within ``max_step`` of ``prev`` per joint, then within [lower, upper]."""
    for j in range(goal.shape[0]):
        out[j] = clamp(clamp(goal[j], prev[j] - max_step, prev[j] + max_step), lower[j], upper[j])


@njit
def offset_clamp(q: np.ndarray, offset: np.ndarray, lower: np.ndarray, upper: np.ndarray, out: np.ndarray) -> None:
    """``out`` = ``np.clip(q + offset, lower, upper)`` per joint (``clamp``: np.clip's values)."""
    for j in range(q.shape[0]):
        out[j] = clamp(q[j] + offset[j], lower[j], upper[j])


@njit
def clipped_equals(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """Whether ``q`` clamped to [lower, upper] (``clamp``, np.clip's values) equals both ``a``
    and ``b`` element by element, as ``np.array_equal`` compares (==: NaN never equal,
    0.0 equal to -0.0); the arrays have one shape."""
    for j in range(q.shape[0]):
        c = clamp(q[j], lower[j], upper[j])
        if not (c == a[j] and c == b[j]):
            return False
    return True


def limited_goal(
    goal: np.ndarray, prev: np.ndarray | None, max_step: float, lower: np.ndarray, upper: np.ndarray
) -> np.ndarray:
    """A new array: ``goal`` within ``max_step`` of ``prev`` per joint (no step limit without a
    ``prev``), then within [lower, upper]: ``limit_goal``'s rule and values, the one rule every hand
    backend applies to the goals it is sent (a goal within the step passes unchanged, bit for bit).
    In numpy, not compiled: a real hand's driver calls it beside a thread of its own (the CAN
    hand's PD loop), and a first compile for new argument types would hold the interpreter lock."""
    q = np.asarray(goal, dtype=np.float64)
    if prev is not None:
        p = np.asarray(prev, dtype=np.float64)
        q = np.minimum(np.maximum(q, p - max_step), p + max_step)
    return np.minimum(np.maximum(q, lower), upper)
