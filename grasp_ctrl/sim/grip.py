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
    def net_up(z: np.ndarray) -> np.ndarray:
        return np.clip(kt * (anchors[:, None] - z[None, :]), -capacity[:, None], capacity[:, None]).sum(axis=0) - weight_n

    g0 = float(net_up(np.zeros(1))[0])
    if g0 <= 0.0:
        return 0.0, -g0
    # net_up is piecewise linear and decreasing in z, with kinks where a contact
    # starts or stops slipping: evaluate at the kinks and interpolate exactly.
    held = capacity > 0.0
    kinks = np.concatenate([anchors[held] - capacity[held] / kt, anchors[held] + capacity[held] / kt])
    z = np.unique(np.concatenate([[0.0], kinks[kinks > 0.0]]))
    g = net_up(z)
    below = np.flatnonzero(g <= 0.0)
    if below.size == 0:  # still pushing up past every kink: cannot happen with positive weight
        return float(z[-1]), 0.0
    j = int(below[0])
    z0, z1, g_lo, g_hi = z[j - 1], z[j], g[j - 1], g[j]
    return float(z0 + (z1 - z0) * g_lo / (g_lo - g_hi)), 0.0


def tangential_forces(
    anchors: np.ndarray, capacity: np.ndarray, kt: float, z: float
) -> tuple[np.ndarray, np.ndarray]:
    """Upward force of each finger on the object at height z, and the slip flags."""
    raw = kt * (anchors - z)
    t = np.clip(raw, -capacity, capacity)
    slipping = np.abs(raw) > capacity + 1e-12
    return t, slipping
