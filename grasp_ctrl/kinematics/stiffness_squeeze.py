"""The stiffness-aware squeeze's compiled kernels: for each squeezing finger, the direction
to move its pad goal so that the joints' position springs push the pad along its closing
vector (``_squeeze_directions``), and the squeeze's pad targets built from it
(``squeeze_targets_kernel``). ``PadIK.squeeze_directions`` and ``PadIK.squeeze_targets``
hold the numpy forms.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.kinematics.chain_packing import _unpack
from grasp_ctrl.kinematics.pad_ik_kernels import _frames_scratch, _pad_and_jacobian, _pad_points, step_pads_kernel
from grasp_ctrl.numeric.jit import njit

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


@njit
def squeeze_step_kernel(
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
    damping,
    normal_targets,
    facing,
    orient_damping,
):
    """``squeeze_targets_kernel``, then, when a finger moved, ``step_pads_kernel`` for the fingers
    with a distance (``q_goal`` in place): the squeeze's two calls in one. True when one moved."""
    F = distances.shape[0]
    if not squeeze_targets_kernel(
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
        np.empty((F, 3)),
        np.empty((F, 3)),
    ):
        return False
    move = np.empty(F, dtype=np.bool_)
    for f in range(F):
        move[f] = distances[f] != 0.0
    step_pads_kernel(q_goal, targets, move, geometry, layout, damping, normal_targets, facing, orient_damping)
    return True
