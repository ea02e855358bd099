"""Vertical stick-slip of a grasped object (quasi-static).

Each fingertip in contact holds the object through a tangential spring of
stiffness ``kt`` anchored where it touched; the spring force is capped by
Coulomb friction ``mu * N``, and a slipping contact drags its anchor. The
object's height is the equilibrium of the finger forces, its weight and the
table (which can only push up).

Loops over the few contacts of one hand, compiled with the world step
(grasp_ctrl/jit.py).
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.jit import njit


@njit
def _net_up(anchors: np.ndarray, capacity: np.ndarray, kt: float, load_n: float, z: float) -> float:
    total = -load_n
    for i in range(anchors.shape[0]):
        f = kt * (anchors[i] - z)
        c = capacity[i]
        total += c if f > c else (-c if f < -c else f)
    return total


@njit
def solve_object_height(anchors: np.ndarray, capacity: np.ndarray, kt: float, load_n: float) -> tuple[float, float]:
    """Equilibrium height z >= 0 of the object base and the table's normal force.

    ``anchors``: per contact, the object height at which that contact's spring is
    relaxed (finger height minus its stick offset); ``capacity``: mu*N per
    contact (0 for no contact); ``load_n``: what the fingers' friction must carry
    (the weight, plus any downward push of the contacts' normal forces). Finger i
    pushes the object up with clip(kt*(anchor_i - z), -capacity_i, capacity_i).
    """
    g0 = _net_up(anchors, capacity, kt, load_n, 0.0)
    if g0 <= 0.0:
        return 0.0, -g0
    # net_up is piecewise linear and decreasing in z, with kinks where a contact
    # starts or stops slipping: walk the kinks upward and interpolate exactly.
    kinks = np.empty(2 * anchors.shape[0])
    count = 0
    for i in range(anchors.shape[0]):
        if capacity[i] > 0.0:
            for k in (anchors[i] - capacity[i] / kt, anchors[i] + capacity[i] / kt):
                if k > 0.0:
                    kinks[count] = k
                    count += 1
    kinks = np.sort(kinks[:count])
    z_lo, g_lo = 0.0, g0
    for z in kinks:
        g = _net_up(anchors, capacity, kt, load_n, z)
        if g <= 0.0:
            return z_lo + (z - z_lo) * g_lo / (g_lo - g), 0.0
        z_lo, g_lo = z, g
    return z_lo, 0.0   # still pushing up past every kink: cannot happen with a positive load


@njit
def tangential_forces(anchors: np.ndarray, capacity: np.ndarray, kt: float, z: float) -> tuple[np.ndarray, np.ndarray]:
    """Upward force of each finger on the object at height z, and the slip flags."""
    n = anchors.shape[0]
    forces = np.empty(n)
    slipping = np.empty(n, dtype=np.bool_)
    for i in range(n):
        f = kt * (anchors[i] - z)
        c = capacity[i]
        forces[i] = c if f > c else (-c if f < -c else f)
        slipping[i] = abs(f) > c + 1e-12
    return forces, slipping
