"""Compiled sensor-frame rotations: each finger's sensor frame in the hand frame
(``sensor_rotations_kernel``) and sensor-frame forces turned into the hand frame with
their grip (``sensor_forces_kernel``), as the sensing pipeline uses every tick
(loop/sensing.py, loop/loop_kernels.py). ``PadIK.sensor_rotations`` and
``PadIK.sensor_forces`` hold the numpy forms.
"""

from __future__ import annotations

import math

import numpy as np

from grasp_ctrl.kinematics.chain_packing import _unpack
from grasp_ctrl.kinematics.pad_ik_kernels import _chain_frames, _frames_scratch
from grasp_ctrl.numeric.jit import njit


@njit
def _sensor_rotations(q, starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, out):
    """Every finger's sensor-frame rotation (hand frame) into ``out`` (F, 3, 3)."""
    nmax = 0
    for f in range(len(starts)):
        nmax = max(nmax, counts[f])
    R, p, Rs, ps, tmp, rot = _frames_scratch(nmax)
    for f in range(len(starts)):
        _chain_frames(q, f, starts[f], counts[f], R_base, p_base, R_org, p_org, K, K2, R, p, Rs, ps, tmp, rot)
        for r in range(3):
            for c in range(3):
                out[f, r, c] = R[r, 0] * R_tip[f, 0, c] + R[r, 1] * R_tip[f, 1, c] + R[r, 2] * R_tip[f, 2, c]


@njit
def _sensor_forces(q, starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, f_sensor, f_hand, grip):
    """Sensor-frame forces (F, 3) into the hand frame (``f_hand``, F x 3) and their part
    across the hand's z axis (``grip``, F). Each product sums its terms in the order
    ``np.einsum("nij,nj->ni", ...)`` does ((0 + a0 b0 + a2 b2) + a1 b1), so the result,
    signed zeros included, is bit-identical to the numpy path."""
    R = np.empty((len(starts), 3, 3))
    _sensor_rotations(q, starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, R)
    for f in range(len(starts)):
        for r in range(3):
            f_hand[f, r] = ((0.0 + R[f, r, 0] * f_sensor[f, 0]) + R[f, r, 2] * f_sensor[f, 2]) + R[f, r, 1] * f_sensor[
                f, 1
            ]
        grip[f] = math.sqrt(f_hand[f, 0] * f_hand[f, 0] + f_hand[f, 1] * f_hand[f, 1])


@njit
def sensor_rotations_kernel(q, geometry, layout, out):
    """Every finger's sensor-frame rotation (hand frame) into ``out`` (F, 3, 3)."""
    starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, _p, _n, _l, _u = _unpack(geometry, layout)
    _sensor_rotations(q, starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, out)


@njit
def sensor_forces_kernel(q, geometry, layout, f_sensor, f_hand, grip):
    """``_sensor_forces``: forces (F, 3) from the sensor frames into the hand frame, and their grip."""
    starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, _p, _n, _l, _u = _unpack(geometry, layout)
    _sensor_forces(q, starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, f_sensor, f_hand, grip)
