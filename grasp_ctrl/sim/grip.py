"""Vertical stick-slip of a grasped object (quasi-static).

Each fingertip in contact holds the object through a tangential spring of
stiffness ``kt`` anchored where it touched; the spring force is capped by
Coulomb friction ``mu * N``, and a slipping contact drags its anchor. The
object's height is the equilibrium of the finger forces, its weight and the
table (which can only push up).
"""

from __future__ import annotations

import numpy as np


def solve_object_height(
    anchors: np.ndarray, capacity: np.ndarray, kt: float, weight_n: float
) -> tuple[float, float]:
    """Equilibrium height z >= 0 of the object base and the table's normal force.

    ``anchors``: per contact, the object height at which that contact's spring is
    relaxed (finger height minus its stick offset); ``capacity``: mu*N per
    contact (0 for no contact). Finger i pushes the object up with
    clip(kt*(anchor_i - z), -capacity_i, capacity_i).
    """
    def net_up(z: float) -> float:
        return float(np.sum(np.clip(kt * (anchors - z), -capacity, capacity))) - weight_n

    g0 = net_up(0.0)
    if g0 <= 0.0:
        return 0.0, -g0
    # net_up decreases in z; bracket then bisect (piecewise linear: converges fast).
    hi = float(np.max(anchors)) + float(np.max(capacity)) / kt + 1e-3
    if net_up(hi) > 0.0:  # cannot happen with positive weight; guard against bad input
        return hi, 0.0
    lo = 0.0
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if net_up(mid) > 0.0:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-9:
            break
    return 0.5 * (lo + hi), 0.0


def tangential_forces(
    anchors: np.ndarray, capacity: np.ndarray, kt: float, z: float
) -> tuple[np.ndarray, np.ndarray]:
    """Upward force of each finger on the object at height z, and the slip flags."""
    raw = kt * (anchors - z)
    t = np.clip(raw, -capacity, capacity)
    slipping = np.abs(raw) > capacity + 1e-12
    return t, slipping
