"""Compiled per-tick bookkeeping of a trial (grasp_ctrl/numeric/jit.py): the tick log's row,
the running force peaks of the record and the PAC spread the grip-load controller reads.

Each replaces a dozen numpy calls on 3- to 176-element arrays, whose call overhead
was most of their cost; the numbers are the same bit for bit (tests/loop/test_tick_kernels.py,
tests/loop/test_tick_speed_parity.py). Without numba the peaks' and the log's callers keep their
numpy code; ``row_spreads`` runs as Python.
"""

from __future__ import annotations

import math

import numpy as np

from grasp_ctrl.config.sensor_layout import FRAME_LEN, PDC
from grasp_ctrl.kinematics.sensor_frame_kernels import sensor_forces_kernel
from grasp_ctrl.numeric.jit import njit
from grasp_ctrl.numeric.limits import _maximum
from grasp_ctrl.tactile.tare import scatter_rows, tare_and_gate_bits


@njit
def sense_inputs(
    q: np.ndarray,
    palm: np.ndarray,
    raw: np.ndarray,
    baseline: np.ndarray,
    count: np.ndarray,
    threshold: float,
    frames: int,
    tared: np.ndarray,
    contact: np.ndarray,
    touching: np.ndarray,
) -> int:
    """The first half of a snapshot: check the joint angles and the palm position, then
    tare and gate the frames (``tare.tare_and_gate_bits``: the contact bits, or -1 for
    a frame that is not a finite count in range) and copy the tared rows of the
    fingertips in contact, in order, to the first rows of ``touching`` (the policy's
    input). -2 when an angle or coordinate is not finite. Nothing changes unless the
    result is >= 0."""
    for v in q:
        if not math.isfinite(v):
            return -2
    for v in palm:
        if not math.isfinite(v):
            return -2
    bits = tare_and_gate_bits(raw, baseline, count, threshold, frames, tared, contact)
    k = 0
    for i in range(tared.shape[0]):
        if contact[i]:
            for c in range(tared.shape[1]):
                touching[k, c] = tared[i, c]
            k += 1
    return bits


@njit
def sense_forces(
    q: np.ndarray, f_sensor: np.ndarray, geometry: np.ndarray, layout: np.ndarray, f_hand: np.ndarray, grip: np.ndarray
) -> bool:
    """The second half: the estimated forces (F, 3) into the hand frame and their grip
    (``sensor_frame_kernels.sensor_forces_kernel``; ``geometry``, ``layout``: the hand's ``PadIK``), when
    every one is finite; False (nothing written) when one is not."""
    for i in range(f_sensor.shape[0]):
        for k in range(f_sensor.shape[1]):
            if not math.isfinite(f_sensor[i, k]):
                return False
    sensor_forces_kernel(q, geometry, layout, f_sensor, f_hand, grip)
    return True


@njit
def place_forces(
    rows: np.ndarray,
    bits: int,
    q: np.ndarray,
    geometry: np.ndarray,
    layout: np.ndarray,
    f_sensor: np.ndarray,
    f_hand: np.ndarray,
    grip: np.ndarray,
) -> bool:
    """The policy's rows (one per fingertip in contact, ``bits``) into ``f_sensor`` (F, 3),
    zero for the others (``tare.scatter_rows``), then ``sense_forces``: False, f_hand and
    grip unset, when a force is not finite."""
    for i in range(f_sensor.shape[0]):
        for c in range(f_sensor.shape[1]):
            f_sensor[i, c] = 0.0
    scatter_rows(rows, bits, f_sensor)
    return sense_forces(q, f_sensor, geometry, layout, f_hand, grip)


@njit
def track_peaks(
    f_sensor: np.ndarray,
    grip: np.ndarray,
    true_normal: np.ndarray,
    force_sq_peak: np.ndarray,
    grip_peak: np.ndarray,
    true_peak: np.ndarray,
) -> None:
    """Per fingertip, in place: the peak of |f_sensor|^2, of the grip and of the true
    normal force. The same as ``np.maximum(peak, np.add.reduce(f * f, axis=1), out=peak)``
    (which sums a row's squares left to right) and ``np.maximum(peak, x, out=peak)``."""
    for i in range(f_sensor.shape[0]):
        sq = 0.0
        for k in range(f_sensor.shape[1]):
            v = f_sensor[i, k] * f_sensor[i, k]
            sq = v if k == 0 else sq + v
        force_sq_peak[i] = _maximum(force_sq_peak[i], sq)
        grip_peak[i] = _maximum(grip_peak[i], grip[i])
        true_peak[i] = _maximum(true_peak[i], true_normal[i])


@njit
def _put(row: np.ndarray, at: int, values: np.ndarray) -> int:
    flat = values.ravel()
    for k in range(flat.shape[0]):
        row[at + k] = flat[k]
    return at + flat.shape[0]


@njit
def log_row(
    block: np.ndarray,
    i: int,
    t: float,
    palm: np.ndarray,
    palm_target: np.ndarray,
    grip_target: float,
    raw: np.ndarray,
    contact: np.ndarray,
    tared: np.ndarray,
    grip: np.ndarray,
    f_sensor: np.ndarray,
    f_world: np.ndarray,
    q: np.ndarray,
    q_goal: np.ndarray,
    true_f: np.ndarray,
    object_z: float,
    table_force: float,
) -> bool:
    """Row ``i`` of the tick log's block with truth columns (``ticklog.layout`` order):
    what ``TickLog.append`` stores, in one pass (values as numpy's assignment casts
    them). False, with nothing written, when a size does not fit (the caller's numpy
    path then names it)."""
    F, J = grip.size, q.size
    if not (
        palm.size == 3
        and palm_target.size == 3
        and raw.size == F * FRAME_LEN
        and contact.size == F
        and tared.size == F * FRAME_LEN
        and f_sensor.size == 3 * F
        and f_world.size == 3 * F
        and q_goal.size == J
        and true_f.size == 3 * F
        and block.shape[1] == 6 + F * (FRAME_LEN + 12) + 2 * J + 2
        and 0 <= i < block.shape[0]
    ):
        return False
    row = block[i]
    row[0] = t
    at = _put(row, 1, palm)
    row[at] = palm_target.ravel()[2]
    row[at + 1] = grip_target
    at = _put(row, at + 2, raw)
    at = _put(row, at, contact)
    flat = tared.ravel()
    for k in range(F):
        row[at + k] = flat[k * FRAME_LEN + PDC]
    at += F
    at = _put(row, at, grip)
    at = _put(row, at, f_sensor)
    at = _put(row, at, f_world)
    at = _put(row, at, q)
    at = _put(row, at, q_goal)
    at = _put(row, at, true_f)
    row[at] = object_z
    row[at + 1] = table_force
    return True


#: numpy sums at most this many values with its 8 accumulators before it splits them in halves.
PAIRWISE_BLOCK = 128


@njit
def _pairwise_sum(x: np.ndarray, start: int, n: int) -> float:
    """``np.add.reduce`` of ``x[start:start + n]`` (n <= ``PAIRWISE_BLOCK``) in numpy's order:
    fewer than 8 values one by one, else 8 accumulators over the multiples of 8, summed as
    ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7)), then the rest one by one; from +0.0."""
    if n < 8:
        res = -0.0
        for i in range(n):
            res += x[start + i]
        return 0.0 + res
    r0, r1, r2, r3 = x[start], x[start + 1], x[start + 2], x[start + 3]
    r4, r5, r6, r7 = x[start + 4], x[start + 5], x[start + 6], x[start + 7]
    i = 8
    while i < n - n % 8:
        a = start + i
        r0 += x[a]
        r1 += x[a + 1]
        r2 += x[a + 2]
        r3 += x[a + 3]
        r4 += x[a + 4]
        r5 += x[a + 5]
        r6 += x[a + 6]
        r7 += x[a + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += x[start + i]
        i += 1
    return 0.0 + res


@njit
def row_spreads(raw: np.ndarray, start: int, n: int, out: np.ndarray) -> None:
    """``out[i]`` = ``raw[i, start:start + n].std()`` as numpy computes it (n <= ``PAIRWISE_BLOCK``):
    the mean (a pairwise sum over n), the squared deviations' pairwise sum over n, its root."""
    dev = np.empty(n)
    for i in range(raw.shape[0]):
        row = raw[i]
        mean = _pairwise_sum(row, start, n) / n
        for k in range(n):
            d = row[start + k] - mean
            dev[k] = d * d
        out[i] = math.sqrt(_pairwise_sum(dev, 0, n) / n)
