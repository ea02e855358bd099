"""What every simulated world shares: world events, the wrist target's check and
the read-only views of arrays a world's step updates in place.

Both worlds (sim/mock/world.py, sim/mujoco/world.py) import these; neither imports the other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.finite import all_finite
from grasp_ctrl.numeric.jit import njit

NOISE_BLOCK = 128  # sensor noise is drawn for this many steps at a time
_FLOAT64 = np.dtype(np.float64)


@dataclass
class WorldEvent:
    t: float
    kind: str  # crushed | knocked_over | fell | lifted | contact | released
    detail: str = ""


def in_place_view(name: str, doc: str) -> property:
    """A read-only view of an array the world's step updates in place."""
    return property(lambda self: getattr(self, name), doc=doc)


@njit
def _finite_copy(p: np.ndarray, out: np.ndarray) -> bool:
    """``out[:] = p`` when every value is finite; False (``out`` unset) otherwise."""
    for k in range(p.shape[0]):
        if not math.isfinite(p[k]):
            return False
    for k in range(p.shape[0]):
        out[k] = p[k]
    return True


def checked_palm_target(p: np.ndarray) -> np.ndarray:
    """A wrist target as a (3,) float array (a copy); ValueError unless every coordinate is finite."""
    if jit.JIT and type(p) is np.ndarray and p.dtype is _FLOAT64 and p.shape == (3,):
        target = np.empty(3)
        if _finite_copy(p, target):
            return target
    target = np.array(p, dtype=float).reshape(3)
    if not all_finite(target):
        raise ValueError(f"palm target must be finite, got {target}")
    return target
