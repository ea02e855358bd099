"""Vertical stick-slip of a grasped object (quasi-static).

Each fingertip in contact holds the object through a vertical spring of
stiffness ``kt`` anchored where it touched; the spring force is capped by
Coulomb friction on the contact's own normal (``friction_limits``: on a wall
``mu * N`` either way, on a sloped surface such as a cap less upward than
downward), and a slipping contact drags its anchor. The object's height is the
equilibrium of the finger forces, its weight and the table (which can only push up).

Loops over the few contacts of one hand, compiled with the world step
(grasp_ctrl/numeric/jit.py).
"""

from __future__ import annotations

import math

import numpy as np

from grasp_ctrl.numeric.jit import njit

# A surface facing down steeply enough wedges the fingertip (no friction limit
# upward); the finger's own limits then bound the force, so cap the factor.
_MIN_CONE_DENOMINATOR = 0.05


@njit
def friction_limits(normal_n: float, n_z: float, mu: float) -> tuple[float, float]:
    """Largest upward and downward vertical force a contact can pass by friction.

    The finger presses the object with ``normal_n`` along -n (n: the object's outward
    surface normal, ``n_z`` its vertical part) and pulls it up with t. Coulomb on the
    contact's own normal: the tangential part |t| sqrt(1 - n_z^2) must stay within
    mu times the compressive part N - t n_z. On a vertical wall (n_z = 0) both limits
    are mu N; on a cap facing up, lifting unloads the contact and the upward limit
    shrinks.
    """
    if normal_n <= 0.0:
        return 0.0, 0.0
    s = math.sqrt(max(1.0 - n_z * n_z, 0.0))
    up = mu * normal_n / max(s + mu * n_z, _MIN_CONE_DENOMINATOR)
    down = mu * normal_n / max(s - mu * n_z, _MIN_CONE_DENOMINATOR)
    return up, down


@njit
def _clip(f: float, up: float, down: float) -> float:
    return up if f > up else (-down if f < -down else f)


@njit
def _net_up(anchors: np.ndarray, cap_up: np.ndarray, cap_down: np.ndarray, kt: float, load_n: float, z: float) -> float:
    total = -load_n
    for i in range(anchors.shape[0]):
        total += _clip(kt * (anchors[i] - z), cap_up[i], cap_down[i])
    return total


@njit
def solve_object_height(
    anchors: np.ndarray, cap_up: np.ndarray, cap_down: np.ndarray, kt: float, load_n: float
) -> tuple[float, float]:
    """Equilibrium height z >= 0 of the object base and the table's normal force.

    ``anchors``: per contact, the object height at which that contact's spring is
    relaxed (finger height minus its stick offset); ``cap_up``/``cap_down``: the
    friction limits per contact (``friction_limits``; 0 for no contact); ``load_n``:
    what the fingers' friction must carry (the weight, plus any downward push of the
    contacts' normal forces). Finger i pushes the object up with
    clip(kt*(anchor_i - z), -cap_down_i, cap_up_i).
    """
    g0 = _net_up(anchors, cap_up, cap_down, kt, load_n, 0.0)
    if g0 <= 0.0:
        return 0.0, -g0
    # net_up is piecewise linear and decreasing in z, with kinks where a contact
    # starts or stops slipping: walk the kinks upward and interpolate exactly.
    kinks = np.empty(2 * anchors.shape[0])
    count = 0
    for i in range(anchors.shape[0]):
        if cap_up[i] > 0.0 or cap_down[i] > 0.0:
            for k in (anchors[i] - cap_up[i] / kt, anchors[i] + cap_down[i] / kt):
                if k > 0.0:
                    kinks[count] = k
                    count += 1
    kinks = np.sort(kinks[:count])
    z_lo, g_lo = 0.0, g0
    for z in kinks:
        g = _net_up(anchors, cap_up, cap_down, kt, load_n, z)
        if g <= 0.0:
            return z_lo + (z - z_lo) * g_lo / (g_lo - g), 0.0
        z_lo, g_lo = z, g
    return z_lo, 0.0  # still pushing up past every kink: cannot happen with a positive load


@njit
def tangential_forces(
    anchors: np.ndarray, cap_up: np.ndarray, cap_down: np.ndarray, kt: float, z: float
) -> tuple[np.ndarray, np.ndarray]:
    """Upward force of each finger on the object at height z, and the slip flags."""
    n = anchors.shape[0]
    forces = np.empty(n)
    slipping = np.empty(n, dtype=np.bool_)
    for i in range(n):
        f = kt * (anchors[i] - z)
        forces[i] = _clip(f, cap_up[i], cap_down[i])
        slipping[i] = f > cap_up[i] + 1e-12 or f < -cap_down[i] - 1e-12
    return forces, slipping
