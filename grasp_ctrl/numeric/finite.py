"""``all_finite``: the per-tick check that an array holds no NaN or inf, cheaply.

``np.isfinite(a).all()`` costs two numpy calls of a few microseconds each, and
the control loop makes several such checks per tick; with the ``sim`` extra a
float64 array is checked by one compiled loop instead (grasp_ctrl/numeric/jit.py).
"""

from __future__ import annotations

import math

import numpy as np

from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.jit import njit

_FLOAT64 = np.dtype(np.float64)  # native float64: a singleton, so an identity test finds it


@njit
def _finite_floats(flat: np.ndarray) -> bool:
    for v in flat:
        if not math.isfinite(v):
            return False
    return True


def all_finite(a: np.ndarray) -> bool:
    """True when every value of ``a`` is finite (the answer of ``np.isfinite(a).all()``)."""
    if jit.JIT and a.dtype is _FLOAT64:
        return bool(_finite_floats(a.ravel()))
    return bool(np.isfinite(a).all())


@njit
def _finite_pair(a: np.ndarray, b: np.ndarray) -> bool:
    return _finite_floats(a) and _finite_floats(b)


def both_finite(a: np.ndarray, b: np.ndarray) -> bool:
    """``all_finite(a) and all_finite(b)`` in one call (two per-tick checks of the same kind)."""
    if jit.JIT and a.dtype is _FLOAT64 and b.dtype is _FLOAT64:
        return bool(_finite_pair(a.ravel(), b.ravel()))
    return all_finite(a) and all_finite(b)
