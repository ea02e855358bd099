"""The pad IK's compiled kernels: forward kinematics to each finger's pad point, its
position Jacobian and one damped least-squares step per finger (with the pad-facing turn
in the position task's null space), for all fingers in one call.

The arithmetic is that of ``FingerChain.point_and_jacobian`` and ``FingerChain.dls_step``
(and ``pad_ik.facing_dls_step``), as plain loops over the chains' generic pieces (base
pose, joint origins, axes, tip pose), so any serial-chain geometry works. ``PadIK``
(kinematics/pad_ik.py) calls the ``*_kernel`` entry points with the geometry that
kinematics/chain_packing.py packs into two arrays.
"""

from __future__ import annotations

import math

import numpy as np

from grasp_ctrl.kinematics.chain_packing import _unpack
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


# ----- the kernels PadIK calls, on the geometry chain_packing.pack_geometry packs -----


@njit
def pad_points_kernel(q, geometry, layout, out):
    """Every finger's pad point (hand frame) into ``out`` (F, 3)."""
    starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, point, _n, _l, _u = _unpack(
        geometry, layout
    )
    _pad_points(q, starts, counts, R_base, p_base, R_org, p_org, K, K2, axes, R_tip, p_tip, point, out)


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
