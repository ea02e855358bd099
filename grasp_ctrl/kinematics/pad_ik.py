"""The controller's per-tick fingertip IK for all fingers in one call.

Every tick the controller moves some fingertips' pad points along their closing
vectors: forward kinematics to the pad, its position Jacobian and one damped
least-squares step per finger (``FingerChain.point_and_jacobian`` and
``FingerChain.dls_step``). With the ``sim`` extra (numba) the same arithmetic
runs compiled for all fingers at once, a few microseconds instead of about a
hundred per finger; without it the per-finger numpy methods run. The kernels
read only the chains' generic pieces (base pose, joint origins, axes, tip pose),
so any serial-chain geometry works.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from grasp_ctrl.kinematics.batched import BatchedKinematics
from grasp_ctrl.kinematics.chain import FingerChain, HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR
from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.jit import njit


@njit
def _chain_frames(q, f, start, n, R_base, p_base, R_org, p_org, K, K2, R, p, Rs, ps, tmp, rot):
    """Forward kinematics of finger ``f`` with its joints ``q[start:start + n]``: each
    joint's frame before its own turn into ``Rs[i]``, ``ps[i]`` (hand frame), the last
    link's frame into ``R``, ``p`` (the sensor frame then follows from the tip pose).
    Plain element loops (no array views or copies: their bookkeeping cost more than
    the arithmetic); joint turns by Rodrigues, I + sin K + (1 - cos) K^2."""
    for r in range(3):
        p[r] = p_base[f, r]
        for c in range(3):
            R[r, c] = R_base[f, r, c]
    for i in range(n):
        for r in range(3):
            p[r] = p[r] + (R[r, 0] * p_org[f, i, 0] + R[r, 1] * p_org[f, i, 1] + R[r, 2] * p_org[f, i, 2])
        for r in range(3):
            for c in range(3):
                tmp[r, c] = R[r, 0] * R_org[f, i, 0, c] + R[r, 1] * R_org[f, i, 1, c] + R[r, 2] * R_org[f, i, 2, c]
        for r in range(3):
            ps[i, r] = p[r]
            for c in range(3):
                R[r, c] = tmp[r, c]
                Rs[i, r, c] = tmp[r, c]
        angle = q[start + i]
        s = math.sin(angle)
        c1 = 1.0 - math.cos(angle)
        for r in range(3):
            for c in range(3):
                rot[r, c] = (1.0 if r == c else 0.0) + s * K[f, i, r, c] + c1 * K2[f, i, r, c]
        for r in range(3):
            for c in range(3):
                tmp[r, c] = R[r, 0] * rot[0, c] + R[r, 1] * rot[1, c] + R[r, 2] * rot[2, c]
        for r in range(3):
            for c in range(3):
                R[r, c] = tmp[r, c]


@njit
def _pad_and_jacobian(
    q,
    f,
    start,
    n,
    R_base,
    p_base,
    R_org,
    p_org,
    K,
    K2,
    axes,
    R_tip,
    p_tip,
    point,
    pad,
    J,
    normal_s,
    nrm,
    Jn,
    R,
    p,
    Rs,
    ps,
    tmp,
    rot,
):
    """Pad point (hand frame) of finger ``f`` into ``pad`` (3,) and its Jacobian into J (3, n);
    the pad normal ``normal_s`` (sensor frame) turned into the hand frame into ``nrm`` (3,)
    and its Jacobian d(normal)/dq = axis x normal into Jn (3, n). ``R`` .. ``tmp``: scratch
    (``_chain_frames``); J and Jn may have more columns than n (only the first n are written)."""
    _chain_frames(q, f, start, n, R_base, p_base, R_org, p_org, K, K2, R, p, Rs, ps, tmp, rot)
    for r in range(3):
        for c in range(3):
            tmp[r, c] = R[r, 0] * R_tip[f, 0, c] + R[r, 1] * R_tip[f, 1, c] + R[r, 2] * R_tip[f, 2, c]
    for r in range(3):
        p_s = p[r] + (R[r, 0] * p_tip[f, 0] + R[r, 1] * p_tip[f, 1] + R[r, 2] * p_tip[f, 2])
        pad[r] = (tmp[r, 0] * point[0] + tmp[r, 1] * point[1] + tmp[r, 2] * point[2]) + p_s
        nrm[r] = ((0.0 + tmp[r, 0] * normal_s[0]) + tmp[r, 1] * normal_s[1]) + tmp[r, 2] * normal_s[2]
    for i in range(n):
        a0 = Rs[i, 0, 0] * axes[f, i, 0] + Rs[i, 0, 1] * axes[f, i, 1] + Rs[i, 0, 2] * axes[f, i, 2]
        a1 = Rs[i, 1, 0] * axes[f, i, 0] + Rs[i, 1, 1] * axes[f, i, 1] + Rs[i, 1, 2] * axes[f, i, 2]
        a2 = Rs[i, 2, 0] * axes[f, i, 0] + Rs[i, 2, 1] * axes[f, i, 1] + Rs[i, 2, 2] * axes[f, i, 2]
        b0, b1, b2 = pad[0] - ps[i, 0], pad[1] - ps[i, 1], pad[2] - ps[i, 2]
        J[0, i] = a1 * b2 - a2 * b1
        J[1, i] = a2 * b0 - a0 * b2
        J[2, i] = a0 * b1 - a1 * b0
        Jn[0, i] = a1 * nrm[2] - a2 * nrm[1]
        Jn[1, i] = a2 * nrm[0] - a0 * nrm[2]
        Jn[2, i] = a0 * nrm[1] - a1 * nrm[0]


@njit
def _frames_scratch(nmax):
    """Scratch arrays of ``_chain_frames`` for chains of up to ``nmax`` joints."""
    return (
        np.empty((3, 3)),
        np.empty(3),
        np.empty((nmax, 3, 3)),
        np.empty((nmax, 3)),
        np.empty((3, 3)),
        np.empty((3, 3)),
    )


#: Largest turn per joint and step that keeping a pad's facing may add (rad): the
#: turn is a slow correction, not a jump, so the position task stays accurate.
MAX_TURN_RAD = 0.01


@njit
def _damped_gram_into(J, active, n, damping, A):
    """J J^T + damping^2 I over the active joints' columns of J (3, n), into A (3, 3)."""
    for r in range(3):
        for c in range(3):
            A[r, c] = 0.0
    for r in range(3):
        A[r, r] = damping * damping
    for i in range(n):
        if active[i]:
            for r in range(3):
                for c in range(3):
                    A[r, c] += J[r, i] * J[c, i]


@njit
def _facing_scratch(nmax):
    """Scratch arrays of ``_facing_step`` for chains of up to ``nmax`` joints."""
    return (
        np.empty((3, 3)),
        np.empty((3, 3)),
        np.empty(3),
        np.empty((3, 3)),
        np.empty(3),
        np.empty((nmax, nmax)),
        np.empty((nmax, 3)),
        np.empty((3, 3)),
        np.empty(3),
        np.empty(3),
    )


@njit
def _facing_step(J, Jn, dn, active, n, damping, orient_damping, dq1, dq, A, Ainv, unit, M, x, N, W, C, e, y):
    """``dq`` <- dq1 plus the step in the position task's null space that turns the
    pad normal by ``dn`` (minus what dq1 already turns it) as far as the spare joints
    allow: N Jn^T (Jn N Jn^T + mu^2 I)^-1 (dn - Jn dq1), N = I - J^T (J J^T + l^2 I)^-1 J,
    inactive joints (columns of J and Jn) left out. ``A`` to ``y``: scratch
    (``_facing_scratch``, made once per IK call rather than per finger)."""
    _damped_gram_into(J, active, n, damping, A)
    for c in range(3):  # Ainv = A^-1, by columns
        for r in range(3):
            unit[r] = 0.0
        unit[c] = 1.0
        _solve3_into(A, unit, M, x)
        for r in range(3):
            Ainv[r, c] = x[r]
    for i in range(n):
        for k in range(n):
            acc = 0.0
            if active[i] and active[k]:
                for r in range(3):
                    for c in range(3):
                        acc += J[r, i] * Ainv[r, c] * J[c, k]
            N[i, k] = (1.0 if i == k else 0.0) - acc
    for i in range(n):  # W = N Jn^T, active columns only
        for r in range(3):
            acc = 0.0
            for k in range(n):
                if active[k]:
                    acc += N[i, k] * Jn[r, k]
            W[i, r] = acc if active[i] else 0.0
    for r in range(3):
        for c in range(3):
            C[r, c] = 0.0
    for r in range(3):
        C[r, r] = orient_damping * orient_damping
        for c in range(3):
            acc = 0.0
            for i in range(n):
                if active[i]:
                    acc += Jn[r, i] * W[i, c]
            C[r, c] += acc
    for r in range(3):
        acc = dn[r]
        for i in range(n):
            if active[i]:
                acc -= Jn[r, i] * dq1[i]
        e[r] = acc
    _solve3_into(C, e, M, y)
    for i in range(n):
        dq[i] = dq1[i] + (W[i, 0] * y[0] + W[i, 1] * y[1] + W[i, 2] * y[2])


@njit
def _solve3_into(A, b, M, x):
    """x (3,) with A x = b for a 3x3 A (Gaussian elimination, partial pivoting); M (3, 3) is scratch."""
    for r in range(3):
        x[r] = b[r]
        for c in range(3):
            M[r, c] = A[r, c]
    for k in range(3):
        piv = k
        for r in range(k + 1, 3):
            if abs(M[r, k]) > abs(M[piv, k]):
                piv = r
        if piv != k:
            for c in range(3):
                M[k, c], M[piv, c] = M[piv, c], M[k, c]
            x[k], x[piv] = x[piv], x[k]
        for r in range(k + 1, 3):
            m = M[r, k] / M[k, k]
            for c in range(k, 3):
                M[r, c] -= m * M[k, c]
            x[r] -= m * x[k]
    for k in range(2, -1, -1):
        acc = x[k]
        for c in range(k + 1, 3):
            acc -= M[k, c] * x[c]
        x[k] = acc / M[k, k]


@njit
def _step_pads(
    q,
    targets,
    move,
    starts,
    counts,
    R_base,
    p_base,
    R_org,
    p_org,
    K,
    K2,
    axes,
    R_tip,
    p_tip,
    point,
    damping,
    lower,
    upper,
    normal_s,
    normal_targets,
    facing,
    orient_damping,
):
    """One damped least-squares step per finger with ``move[f]`` toward its pad target
    (the arithmetic of FingerChain.point_and_jacobian + dls_step); updates ``q`` in place.
    Fingers with ``facing[f]`` also turn their pad normal toward ``normal_targets[f]``
    with the joints the position task leaves spare (``_facing_step``). Scratch arrays
    are made once per call, sized for the longest finger."""
    nmax = 0
    for f in range(len(move)):
        nmax = max(nmax, counts[f])
    R, p, Rs, ps, tmp, rot = _frames_scratch(nmax)
    pad, nrm, dp, dn = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    J, Jn = np.empty((3, nmax)), np.empty((3, nmax))
    dq1, dq = np.empty(nmax), np.empty(nmax)
    active = np.empty(nmax, dtype=np.bool_)
    A, M, x = np.empty((3, 3)), np.empty((3, 3)), np.empty(3)
    fA, fAinv, funit, fM, fx, fN, fW, fC, fe, fy = _facing_scratch(nmax)
    for f in range(len(move)):
        if not move[f]:
            continue
        s = starts[f]
        n = counts[f]
        _pad_and_jacobian(
            q,
            f,
            s,
            n,
            R_base,
            p_base,
            R_org,
            p_org,
            K,
            K2,
            axes,
            R_tip,
            p_tip,
            point,
            pad,
            J,
            normal_s,
            nrm,
            Jn,
            R,
            p,
            Rs,
            ps,
            tmp,
            rot,
        )
        for r in range(3):
            dp[r] = targets[f, r] - pad[r]
            dn[r] = normal_targets[f, r] - nrm[r]
        for i in range(n):
            active[i] = True
            dq[i] = 0.0
        any_active = n > 0
        for _ in range(2):
            _damped_gram_into(J, active, n, damping, A)
            _solve3_into(A, dp, M, x)
            any_blocked = False
            for i in range(n):
                dq[i] = (J[0, i] * x[0] + J[1, i] * x[1] + J[2, i] * x[2]) if active[i] else 0.0
            for i in range(n):
                qi = q[s + i] + dq[i]
                if (qi < lower[s + i] and dq[i] < 0.0) or (qi > upper[s + i] and dq[i] > 0.0):
                    active[i] = False
                    any_blocked = True
            if not any_blocked:
                break
            any_active = False
            for i in range(n):
                any_active = any_active or active[i]
            if not any_active:
                for i in range(n):
                    dq[i] = 0.0
                break
        if facing[f] and any_active:
            for i in range(n):
                dq1[i] = dq[i]
            _facing_step(
                J, Jn, dn, active, n, damping, orient_damping, dq1, dq, fA, fAinv, funit, fM, fx, fN, fW, fC, fe, fy
            )
            _keep_within(q, s, n, dq1, dq, lower, upper)
        for i in range(n):
            q[s + i] = min(max(q[s + i] + dq[i], lower[s + i]), upper[s + i])


@njit
def _keep_within(q, s, n, dq1, dq, lower, upper):
    """Shrink the secondary part of ``dq`` (dq - dq1) so that it is at most
    MAX_TURN_RAD per joint and takes no joint past a limit that dq1 alone keeps."""
    scale = 1.0
    for i in range(n):
        extra = dq[i] - dq1[i]
        if abs(extra) > MAX_TURN_RAD:
            scale = min(scale, MAX_TURN_RAD / abs(extra))
        qi = q[s + i] + dq1[i]
        if extra > 0.0 and qi + extra > upper[s + i]:
            scale = min(scale, max(upper[s + i] - qi, 0.0) / extra)
        elif extra < 0.0 and qi + extra < lower[s + i]:
            scale = min(scale, max(lower[s + i] - qi, 0.0) / extra)
    for i in range(n):
        dq[i] = dq1[i] + scale * (dq[i] - dq1[i])


@njit
def _pad_points(q, starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, point, out):
    """Every finger's pad point (hand frame) into ``out`` (F, 3)."""
    nmax = 0
    for f in range(len(starts)):
        nmax = max(nmax, counts[f])
    R, p, Rs, ps, tmp, rot = _frames_scratch(nmax)
    pad = np.empty(3)
    no_normal, nrm = np.zeros(3), np.empty(3)
    J, Jn = np.empty((3, nmax)), np.empty((3, nmax))
    for f in range(len(starts)):
        _pad_and_jacobian(
            q,
            f,
            starts[f],
            counts[f],
            R_base,
            p_base,
            R_org,
            p_org,
            K,
            K2,
            axes,
            R_tip,
            p_tip,
            point,
            pad,
            J,
            no_normal,
            nrm,
            Jn,
            R,
            p,
            Rs,
            ps,
            tmp,
            rot,
        )
        for r in range(3):
            out[f, r] = pad[r]


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
def _advance_pads(
    q,
    targets,
    task_vectors,
    distances,
    starts,
    counts,
    R_base,
    p_base,
    R_org,
    p_org,
    K,
    K2,
    axes,
    R_tip,
    p_tip,
    point,
    damping,
    lower,
    upper,
    normal_s,
    normal_targets,
    facing,
    orient_damping,
):
    """Move each finger's pad target along its task vector by its distance (0: stays)
    and take one IK step for the fingers that moved (``_step_pads``); ``q`` and
    ``targets`` in place. False when no finger moves (nothing changed)."""
    F = len(distances)
    move = np.empty(F, dtype=np.bool_)
    moved = False
    for f in range(F):
        move[f] = distances[f] != 0.0
        moved = moved or move[f]
    if not moved:
        return False
    for f in range(F):
        for r in range(3):
            targets[f, r] = targets[f, r] + task_vectors[f, r] * distances[f]
    _step_pads(
        q,
        targets,
        move,
        starts,
        counts,
        R_base,
        p_base,
        R_org,
        p_org,
        K,
        K2,
        axes,
        R_tip,
        p_tip,
        point,
        damping,
        lower,
        upper,
        normal_s,
        normal_targets,
        facing,
        orient_damping,
    )
    return True


#: A stiffness-aware squeeze direction may point at most this far off the closing vector
#: (|u| with v . u = 1, i.e. 1/cos of the angle: 4 = 75.5 degrees); beyond that (only a
#: joint that barely moves the pad along v is left to push) the finger squeezes along v.
MAX_SQUEEZE_STRETCH = 4.0


@njit
def _squeeze_directions(
    q,
    task_vectors,
    distances,
    compliance,
    starts,
    counts,
    R_base,
    p_base,
    R_org,
    p_org,
    K,
    K2,
    axes,
    R_tip,
    p_tip,
    point,
    lower,
    upper,
    out,
):
    """Per finger with a distance: where to move its pad goal so that the joints' position
    springs push the pad along its closing vector v (``out`` (F, 3)).

    With the pad held by the object, a goal change dq gives the force F with
    K (dq - dq_pad) = J^T F and J dq_pad = 0, so F = (J C_q J^T)^-1 J dq (C_q = K^-1, the
    joints' compliance); F is along v when J dq is along u = J C_q J^T v. The goal moves
    along u, scaled so that v . u = 1 (its component along v is the squeeze's distance).
    A joint at a limit that the step would push past is left out of C_q (it cannot add
    torque that way). Fingers without a distance, or whose u would stretch more than
    ``MAX_SQUEEZE_STRETCH``, get v."""
    F = distances.shape[0]
    nmax = 0
    for f in range(F):
        nmax = max(nmax, counts[f])
    R, p, Rs, ps, tmp, rot = _frames_scratch(nmax)
    pad, no_normal, nrm = np.empty(3), np.zeros(3), np.empty(3)
    J, Jn = np.empty((3, nmax)), np.empty((3, nmax))
    for f in range(F):
        for r in range(3):
            out[f, r] = task_vectors[f, r]
        d = distances[f]
        if d == 0.0:
            continue
        s, n = starts[f], counts[f]
        _pad_and_jacobian(
            q,
            f,
            s,
            n,
            R_base,
            p_base,
            R_org,
            p_org,
            K,
            K2,
            axes,
            R_tip,
            p_tip,
            point,
            pad,
            J,
            no_normal,
            nrm,
            Jn,
            R,
            p,
            Rs,
            ps,
            tmp,
            rot,
        )
        u0, u1, u2 = 0.0, 0.0, 0.0
        for i in range(n):
            # (J^T v)_i: the joint's torque per N along v; times its compliance: its goal change.
            jv = J[0, i] * task_vectors[f, 0] + J[1, i] * task_vectors[f, 1] + J[2, i] * task_vectors[f, 2]
            w = compliance[s + i] * jv
            if (w * d > 0.0 and q[s + i] >= upper[s + i]) or (w * d < 0.0 and q[s + i] <= lower[s + i]):
                continue
            u0 += J[0, i] * w
            u1 += J[1, i] * w
            u2 += J[2, i] * w
        along = u0 * task_vectors[f, 0] + u1 * task_vectors[f, 1] + u2 * task_vectors[f, 2]
        if not along > 0.0:
            continue
        u0, u1, u2 = u0 / along, u1 / along, u2 / along
        if u0 * u0 + u1 * u1 + u2 * u2 > MAX_SQUEEZE_STRETCH * MAX_SQUEEZE_STRETCH:
            continue
        out[f, 0], out[f, 1], out[f, 2] = u0, u1, u2


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


# ----- the kernels PadIK calls: the chains' geometry packed into two arrays ---------
# (a compiled call costs about 65 ns per array argument: two instead of fifteen)


def pack_geometry(
    chains: list[FingerChain],
    starts: np.ndarray,
    point: np.ndarray,
    normal: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """``(geometry, layout)``: every chain's base pose, joint origins, axes and tip pose
    (fingers with fewer joints than the longest padded with zeros), the pad point and
    normal (sensor frame) and the joint limits, as one float64 array; the sizes and
    each finger's first joint and joint count as one int64 array (``_unpack``)."""
    nmax = max(c.n for c in chains)

    def padded(get):
        return np.array([np.concatenate([get(c), np.zeros((nmax - c.n, *get(c).shape[1:]))]) for c in chains])

    parts = [
        np.array([c._R_base for c in chains]),
        np.array([c._p_base for c in chains]),
        padded(lambda c: c._R_org),
        padded(lambda c: c._p_org),
        padded(lambda c: c._K),
        padded(lambda c: c._K2),
        padded(lambda c: c.axes),
        np.array([c._R_tip for c in chains]),
        np.array([c._p_tip for c in chains]),
        point,
        normal,
        lower,
        upper,
    ]
    geometry = np.concatenate([np.ascontiguousarray(p, dtype=float).ravel() for p in parts])
    layout = np.concatenate([[len(chains), nmax, len(lower)], starts, [c.n for c in chains]]).astype(np.int64)
    return geometry, layout


@njit
def _unpack(geometry, layout):
    """Views of ``pack_geometry``'s arrays: starts, counts, R_base, p_base, R_org, p_org,
    K, K2, axes, R_tip, p_tip, point, normal, lower, upper."""
    F, nmax, J = layout[0], layout[1], layout[2]
    o = 0
    R_base = geometry[o : o + 9 * F].reshape((F, 3, 3))
    o += 9 * F
    p_base = geometry[o : o + 3 * F].reshape((F, 3))
    o += 3 * F
    R_org = geometry[o : o + 9 * F * nmax].reshape((F, nmax, 3, 3))
    o += 9 * F * nmax
    p_org = geometry[o : o + 3 * F * nmax].reshape((F, nmax, 3))
    o += 3 * F * nmax
    K = geometry[o : o + 9 * F * nmax].reshape((F, nmax, 3, 3))
    o += 9 * F * nmax
    K2 = geometry[o : o + 9 * F * nmax].reshape((F, nmax, 3, 3))
    o += 9 * F * nmax
    axes = geometry[o : o + 3 * F * nmax].reshape((F, nmax, 3))
    o += 3 * F * nmax
    R_tip = geometry[o : o + 9 * F].reshape((F, 3, 3))
    o += 9 * F
    p_tip = geometry[o : o + 3 * F].reshape((F, 3))
    o += 3 * F
    point = geometry[o : o + 3]
    normal = geometry[o + 3 : o + 6]
    lower = geometry[o + 6 : o + 6 + J]
    upper = geometry[o + 6 + J : o + 6 + 2 * J]
    return (
        layout[3 : 3 + F],
        layout[3 + F : 3 + 2 * F],
        R_base,
        p_base,
        R_org,
        p_org,
        K,
        K2,
        axes,
        R_tip,
        p_tip,
        point,
        normal,
        lower,
        upper,
    )


@njit
def pad_points_kernel(q, geometry, layout, out):
    """Every finger's pad point (hand frame) into ``out`` (F, 3)."""
    starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, point, _n, _l, _u = _unpack(
        geometry, layout
    )
    _pad_points(q, starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, point, out)


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


@njit
def step_pads_kernel(q, targets, move, geometry, layout, damping, normal_targets, facing, orient_damping):
    """``_step_pads``: one DLS step per finger with ``move[f]`` (``q`` in place)."""
    starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, point, normal, lower, upper = _unpack(
        geometry, layout
    )
    _step_pads(
        q,
        targets,
        move,
        starts,
        counts,
        R_base,
        p_base,
        R_org,
        p_org,
        K,
        K2,
        axes,
        R_tip,
        p_tip,
        point,
        damping,
        lower,
        upper,
        normal,
        normal_targets,
        facing,
        orient_damping,
    )


@njit
def advance_pads_kernel(
    q, targets, task_vectors, distances, geometry, layout, damping, normal_targets, facing, orient_damping
):
    """``_advance_pads``: targets moved along the task vectors, one DLS step for the fingers
    that moved (``q`` and ``targets`` in place); False when none moves."""
    moved = False
    for f in range(distances.shape[0]):
        moved = moved or distances[f] != 0.0
    if not moved:
        return False
    starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, point, normal, lower, upper = _unpack(
        geometry, layout
    )
    return _advance_pads(
        q,
        targets,
        task_vectors,
        distances,
        starts,
        counts,
        R_base,
        p_base,
        R_org,
        p_org,
        K,
        K2,
        axes,
        R_tip,
        p_tip,
        point,
        damping,
        lower,
        upper,
        normal,
        normal_targets,
        facing,
        orient_damping,
    )


@njit
def squeeze_directions_kernel(q, task_vectors, distances, compliance, geometry, layout, out):
    """``_squeeze_directions``: each moving finger's stiffness-aware squeeze direction into ``out`` (F, 3)."""
    starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, point, _n, lower, upper = _unpack(
        geometry, layout
    )
    _squeeze_directions(
        q,
        task_vectors,
        distances,
        compliance,
        starts,
        counts,
        R_base,
        p_base,
        R_org,
        p_org,
        K,
        K2,
        axes,
        R_tip,
        p_tip,
        point,
        lower,
        upper,
        out,
    )


@njit
def squeeze_targets_kernel(
    q_goal,
    q_measured,
    targets,
    task_vectors,
    distances,
    compliance,
    pad_along,
    max_cross,
    geometry,
    layout,
    directions,
    pads,
):
    """The stiffness-aware squeeze's pad targets (``targets`` in place): each finger with a
    distance d moves its target by v d along its closing vector v plus (u - v) (d - s),
    u its squeeze direction at ``q_goal`` (``_squeeze_directions``, v . u = 1), s how far
    its measured pad (at ``q_measured``) moved along v since the last squeeze tick
    (``pad_along`` (F,): each pad's last position along v, updated in place; NaN: none
    yet, s = 0). The part of the advance that the pad followed (the object carrying it
    along v) moves the goal along v only: the springs' cross force comes from the pad's
    deflection, not from where it went. d - s is capped at +/- ``max_cross``.
    ``directions``, ``pads``: (F, 3) scratch (the directions and the measured pads).
    True when a finger moved."""
    starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, point, _n, lower, upper = _unpack(
        geometry, layout
    )
    _squeeze_directions(
        q_goal,
        task_vectors,
        distances,
        compliance,
        starts,
        counts,
        R_base,
        p_base,
        R_org,
        p_org,
        K,
        K2,
        axes,
        R_tip,
        p_tip,
        point,
        lower,
        upper,
        directions,
    )
    _pad_points(q_measured, starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, point, pads)
    moved = False
    for f in range(distances.shape[0]):
        along = (pads[f, 0] * task_vectors[f, 0] + pads[f, 1] * task_vectors[f, 1]) + pads[f, 2] * task_vectors[f, 2]
        d = distances[f]
        if d != 0.0:
            moved = True
            last = pad_along[f]
            cross = d - (along - last) if last == last else d  # (NaN: no last position)
            cross = min(max(cross, -max_cross), max_cross)
            for r in range(3):
                v = task_vectors[f, r]
                targets[f, r] = targets[f, r] + (v * d + (directions[f, r] - v) * cross)
        pad_along[f] = along
    return moved


class PadIK:
    """Pad points and IK steps of all fingers of one hand (hand-file finger order)."""

    def __init__(
        self, kin: HandKinematics, point_sensor: np.ndarray = PAD_POINT_SENSOR, compiled: bool | None = None
    ) -> None:
        self.kin = kin
        self.names = list(kin.chains)
        self.point = np.ascontiguousarray(point_sensor, dtype=float)
        self.normal = np.ascontiguousarray(PAD_NORMAL_SENSOR, dtype=float)
        chains = [kin.chains[n] for n in self.names]
        n_joints = max(sl.stop for sl in kin.slices.values())
        self.lower, self.upper = np.full(n_joints, -np.inf), np.full(n_joints, np.inf)
        for name, chain in zip(self.names, chains):
            self.lower[kin.slices[name]] = chain.lower
            self.upper[kin.slices[name]] = chain.upper
        self.compiled = jit.JIT if compiled is None else compiled
        F = len(chains)
        self.starts = np.array([kin.slices[n].start for n in self.names], dtype=np.int64)
        self.counts = np.array([c.n for c in chains], dtype=np.int64)
        # The kernels' view of the chains (only read): two arrays, so a call passes few arguments.
        self.geometry, self.layout = pack_geometry(chains, self.starts, self.point, self.normal, self.lower, self.upper)
        self._batched = BatchedKinematics(kin)
        self._no_facing = Facing.none(F)

    def pad_points(self, q_all: np.ndarray) -> np.ndarray:
        """(F, 3) pad points, hand frame."""
        q = np.ascontiguousarray(q_all, dtype=float)
        if self.compiled:
            out = np.empty((len(self.names), 3))
            pad_points_kernel(q, self.geometry, self.layout, out)
            return out
        out = np.empty((len(self.names), 3))
        for f, name in enumerate(self.names):
            R, p = self.kin.chains[name].fk_rp(q[self.kin.slices[name]])
            out[f] = R @ self.point + p
        return out

    def sensor_rotations(self, q_all: np.ndarray) -> np.ndarray:
        """(F, 3, 3) sensor-frame rotations in the hand frame."""
        if self.compiled:
            out = np.empty((len(self.names), 3, 3))
            sensor_rotations_kernel(np.ascontiguousarray(q_all, dtype=float), self.geometry, self.layout, out)
            return out
        return self._batched.sensor_frames(q_all)[0]

    def sensor_forces(self, q_all: np.ndarray, f_sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Forces (F, 3) from the sensor frames to the hand frame, and each one's size
        across the hand's z axis (F,): ``(f_hand, grip)``."""
        if self.compiled:
            f_hand = np.empty((len(self.names), 3))
            grip = np.empty(len(self.names))
            sensor_forces_kernel(
                np.ascontiguousarray(q_all, dtype=float),
                self.geometry,
                self.layout,
                np.ascontiguousarray(f_sensor, dtype=float),
                f_hand,
                grip,
            )
            return f_hand, grip
        f_hand = np.einsum("nij,nj->ni", self.sensor_rotations(q_all), f_sensor)
        return f_hand, np.sqrt(f_hand[:, 0] ** 2 + f_hand[:, 1] ** 2)

    def pad_normals(self, q_all: np.ndarray) -> np.ndarray:
        """(F, 3) outward pad normals, hand frame."""
        return np.einsum("nij,j->ni", self.sensor_rotations(q_all), self.normal)

    def advance(
        self,
        q_all: np.ndarray,
        targets: np.ndarray,
        task_vectors: np.ndarray,
        distances: np.ndarray,
        damping: float,
        facing: Facing | None = None,
    ) -> bool:
        """Move the pad ``targets`` (F, 3, in place) along ``task_vectors`` (F, 3) by
        ``distances`` (F,) and take one DLS step for the fingers that moved (``q_all``
        in place); False when every distance is 0 (nothing changes). With ``facing``,
        its fingers also turn their pads toward its normals (``step``)."""
        facing = facing or self._no_facing
        if self.compiled:
            return bool(
                advance_pads_kernel(
                    q_all,
                    targets,
                    task_vectors,
                    distances,
                    self.geometry,
                    self.layout,
                    damping,
                    facing.normals_hand,
                    facing.fingers,
                    facing.damping,
                )
            )
        move = distances != 0.0
        if not move.any():
            return False
        targets += task_vectors * distances[:, None]
        self.step(q_all, targets, move, damping, facing)
        return True

    def squeeze_directions(
        self, q_all: np.ndarray, task_vectors: np.ndarray, distances: np.ndarray, compliance: np.ndarray
    ) -> np.ndarray:
        """(F, 3): for each finger with a distance, the direction to move its pad goal so that
        the joints' position springs (``compliance`` per joint, rad per N m) push the pad
        along its task vector (``_squeeze_directions``); the task vector itself for the others."""
        q = np.ascontiguousarray(q_all, dtype=float)
        v = np.ascontiguousarray(task_vectors, dtype=float)
        out = np.empty((len(self.names), 3))
        if self.compiled:
            squeeze_directions_kernel(
                q,
                v,
                np.ascontiguousarray(distances, dtype=float),
                np.ascontiguousarray(compliance, dtype=float),
                self.geometry,
                self.layout,
                out,
            )
            return out
        out[:] = v
        for f, name in enumerate(self.names):
            d = float(distances[f])
            if d == 0.0:
                continue
            chain, sl = self.kin.chains[name], self.kin.slices[name]
            _, J = chain.point_and_jacobian(q[sl], self.point)
            w = compliance[sl] * (J.T @ v[f])
            blocked = ((w * d > 0.0) & (q[sl] >= chain.upper)) | ((w * d < 0.0) & (q[sl] <= chain.lower))
            u = J @ np.where(blocked, 0.0, w)
            along = float(u @ v[f])
            if along > 0.0 and float((u / along) @ (u / along)) <= MAX_SQUEEZE_STRETCH**2:
                out[f] = u / along
        return out

    def squeeze_targets(
        self,
        q_goal: np.ndarray,
        q_measured: np.ndarray,
        targets: np.ndarray,
        task_vectors: np.ndarray,
        distances: np.ndarray,
        compliance: np.ndarray,
        pad_along: np.ndarray,
        max_cross: float,
    ) -> bool:
        """``squeeze_targets_kernel``: the stiffness-aware squeeze's pad ``targets`` and
        ``pad_along`` (in place); True when a finger moved. The numpy form without numba."""
        if self.compiled:
            F = len(self.names)
            return bool(
                squeeze_targets_kernel(
                    np.ascontiguousarray(q_goal, dtype=float),
                    np.ascontiguousarray(q_measured, dtype=float),
                    targets,
                    np.ascontiguousarray(task_vectors, dtype=float),
                    np.ascontiguousarray(distances, dtype=float),
                    np.ascontiguousarray(compliance, dtype=float),
                    pad_along,
                    float(max_cross),
                    self.geometry,
                    self.layout,
                    np.empty((F, 3)),
                    np.empty((F, 3)),
                )
            )
        v = np.asarray(task_vectors, dtype=float)
        u = self.squeeze_directions(q_goal, v, distances, compliance)
        along = np.einsum("fr,fr->f", self.pad_points(q_measured), v)
        moving = distances != 0.0
        followed = np.where(np.isnan(pad_along), 0.0, along - pad_along)
        cross = np.clip(distances - followed, -max_cross, max_cross)
        targets[moving] += (v * distances[:, None] + (u - v) * cross[:, None])[moving]
        pad_along[:] = along
        return bool(moving.any())

    def step(
        self, q_all: np.ndarray, targets: np.ndarray, move: np.ndarray, damping: float, facing: Facing | None = None
    ) -> None:
        """One DLS step toward ``targets`` (F, 3) for the fingers with ``move``; ``q_all``
        in place. Fingers in ``facing`` also turn their pad normal toward its target
        with the joints the position task leaves spare (its null space), so the pad
        keeps facing the object while it moves along the closing vector."""
        facing = facing or self._no_facing
        if self.compiled:
            step_pads_kernel(
                q_all,
                targets,
                move,
                self.geometry,
                self.layout,
                damping,
                facing.normals_hand,
                facing.fingers,
                facing.damping,
            )
            return
        for f, name in enumerate(self.names):
            if not move[f]:
                continue
            chain, sl = self.kin.chains[name], self.kin.slices[name]
            pad, J = chain.point_and_jacobian(q_all[sl], self.point)
            if not facing.fingers[f]:
                q_all[sl] = chain.dls_step(q_all[sl], J, targets[f] - pad, damping)
                continue
            q_all[sl] = facing_dls_step(
                chain, q_all[sl], J, targets[f] - pad, self.normal, facing.normals_hand[f], damping, facing.damping
            )


@functools.lru_cache(maxsize=8)
def shared_pad_ik(kin: HandKinematics) -> PadIK:
    """The PadIK of a hand's kinematics (pad point PAD_POINT_SENSOR), set up once for all
    its controllers and sensing pipelines (they only read it)."""
    return PadIK(kin)


@dataclass
class Facing:
    """Which fingers keep their pads facing a direction while they move, and which
    direction (outward pad normals, hand frame, (F, 3)); ``damping`` of that
    secondary task (its errors are unit-vector differences)."""

    fingers: np.ndarray  # (F,) bool
    normals_hand: np.ndarray  # (F, 3)
    damping: float = 0.1

    @classmethod
    def none(cls, n_fingers: int) -> Facing:
        return cls(np.zeros(n_fingers, dtype=bool), np.zeros((n_fingers, 3)))


def facing_dls_step(
    chain: FingerChain,
    q: np.ndarray,
    J: np.ndarray,
    dp_hand: np.ndarray,
    normal_sensor: np.ndarray,
    normal_target_hand: np.ndarray,
    damping: float,
    orient_damping: float,
) -> np.ndarray:
    """``FingerChain.dls_step`` plus the null-space turn of the pad normal toward
    ``normal_target_hand`` (numpy form of the compiled ``_facing_step``)."""
    R_s = chain.fk_rp(q)[0]
    normal = R_s @ normal_sensor
    axes_hand = chain.joint_axes_and_origins(q)[0]
    Jn = np.cross(axes_hand, normal).T  # (3, n): d(normal)/dq
    dn = normal_target_hand - normal
    step = chain.dls_delta(q, J, dp_hand, damping)
    if step is None:
        return np.clip(q, chain.lower, chain.upper)
    dq1, active = step
    Ja, Jna = J * active, Jn * active  # inactive joints: zero columns
    A = Ja @ Ja.T + damping**2 * np.eye(3)
    N = np.eye(chain.n) - Ja.T @ np.linalg.inv(A) @ Ja
    W = (N @ Jna.T) * active[:, None]
    C = Jna @ W + orient_damping**2 * np.eye(3)
    dq = dq1 + W @ np.linalg.solve(C, dn - Jna @ dq1)
    _keep_within(q, 0, chain.n, dq1, dq, chain.lower, chain.upper)
    return np.clip(q + dq, chain.lower, chain.upper)
