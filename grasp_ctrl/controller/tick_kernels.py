"""The controller's per-tick arithmetic as compiled loops (grasp_ctrl/numeric/jit.py).

Each replaces Python list arithmetic and several numpy calls on 4-element
arrays (the fingertips) in ``GraspController``, whose own code stays the
reference: the same operations in the same order, so the same bits
(tests/test_controller_kernels.py). Python's ``min``/``max`` of two floats are
spelled out (``max(a, b)`` is ``b if b > a else a``), so NaN passes through as it
does in Python.
"""

from __future__ import annotations

import math

import numpy as np

from grasp_ctrl.kinematics.pad_ik_kernels import advance_pads_kernel, step_pads_kernel
from grasp_ctrl.kinematics.stiffness_squeeze import squeeze_targets_kernel
from grasp_ctrl.numeric.jit import njit
from grasp_ctrl.numeric.limits import step_toward

#: ``tick_checks`` result bits.
WITHIN_TOLERANCE = 1  # every grasping grip within the ramp tolerance of tau
RELEASE_BELOW = 2  # the release fingertip's force below -release threshold
FORCE_NOT_FINITE = 4  # an estimated |f_sensor|^2 is not finite
OVERFORCE = 8  # the largest |f_sensor| is above the limit (all finite)
#: ``squeeze_state_tick``'s further bits.
TICK_DONE = 16  # no fault and no guard held: squeezed and the goal stepped
PADS_MOVED = 32  # the squeeze moved a fingertip (the motion's posture no longer holds)

#: The states ``squeeze_state_tick`` takes: GraspController's squeeze states lift, hold and
#: lower, close (the fingertips closing along their task vectors until they touch) and
#: release (the grasping fingertips backing off along them), and the arm's moves reach and
#: retreat (the palm toward a goal).
LIFT, HOLD, LOWER, CLOSE, RELEASE, REACH, RETREAT = 0, 1, 2, 3, 4, 5, 6


@njit
def tick_checks(
    grip: np.ndarray,
    in_contact: np.ndarray,
    f_sensor: np.ndarray,
    f_world: np.ndarray,
    grasping: np.ndarray,
    tau: float,
    tolerance: float,
    floor: float,
    release_idx: int,
    release_threshold: float,
    limit: float,
    lost: np.ndarray,
) -> int:
    """``GraspController._update_counters``' flags and lost counts (``lost`` in place:
    +1 for a fingertip out of contact or with its grip below ``floor``, else 0), then
    the over-force check of ``tick``: squared norms summed as ((0 + x^2) + z^2) + y^2,
    the largest above ``limit``^2. Returns the bits above."""
    out = 0
    within = True
    for i in range(grip.shape[0]):
        if grasping[i] and not abs(tau - grip[i]) <= tolerance:
            within = False
            break
    if within:
        out |= WITHIN_TOLERANCE
    for i in range(grip.shape[0]):
        lost[i] = lost[i] + 1 if not in_contact[i] or grip[i] < floor else 0
    if -f_world[release_idx, 2] < -release_threshold:
        out |= RELEASE_BELOW
    largest = 0.0
    for i in range(f_sensor.shape[0]):
        x, y, z = f_sensor[i, 0], f_sensor[i, 1], f_sensor[i, 2]
        sq = ((0.0 + x * x) + z * z) + y * y
        if not math.isfinite(sq):
            if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
                return out | FORCE_NOT_FINITE
            sq = math.inf  # finite components whose square overflows: above any limit (overforce)
        if i == 0 or sq > largest:
            largest = sq
    if f_sensor.shape[0] and largest > limit * limit:
        out |= OVERFORCE
    return out


@njit
def squeeze_pads(
    grip: np.ndarray,
    grasping: np.ndarray,
    tau: float,
    gain: float,
    max_speed: float,
    dt: float,
    q: np.ndarray,
    targets: np.ndarray,
    task_vectors: np.ndarray,
    geometry: np.ndarray,
    layout: np.ndarray,
    damping: float,
    normal_targets: np.ndarray,
    facing: np.ndarray,
    orient_damping: float,
    distances: np.ndarray,
    move_palm: bool,
    palm: np.ndarray,
    palm_goal: np.ndarray,
    palm_step: float,
    compliance: np.ndarray,
    q_measured: np.ndarray,
    pad_along: np.ndarray,
    directions: np.ndarray,
    pads: np.ndarray,
) -> bool:
    """``GraspController._squeeze`` without the variance slowdown: each grasping
    fingertip's speed ``min(max(gain (tau - grip), -max_speed), max_speed)`` times dt
    into ``distances``; then, with the joints' ``compliance``, the stiffness-aware pad
    targets (``stiffness_squeeze.squeeze_targets_kernel`` from ``q_measured``, ``pad_along`` in place,
    the cross part capped at ``max_speed`` dt; ``directions`` and ``pads`` (F, 3) scratch)
    and one IK step (``pad_ik_kernels.step_pads_kernel``), or, when ``compliance`` is empty (the
    stiffness is unknown), ``pad_ik_kernels.advance_pads_kernel`` along the task vectors (``q``
    and ``targets`` in place either way); with ``move_palm`` also
    ``move_palm_toward(palm, palm_goal, palm_step)`` (the lift and the lowering move the
    arm while they squeeze). True when a fingertip moved."""
    if move_palm:
        move_palm_toward(palm, palm_goal, palm_step)
    low = -max_speed
    for f in range(grip.shape[0]):
        v = gain * (tau - grip[f])
        if low > v:
            v = low
        if max_speed < v:
            v = max_speed
        distances[f] = v * dt if grasping[f] else 0.0
    if compliance.shape[0] > 0:
        if not squeeze_targets_kernel(
            q,
            q_measured,
            targets,
            task_vectors,
            distances,
            compliance,
            pad_along,
            max_speed * dt,
            geometry,
            layout,
            directions,
            pads,
        ):
            return False
        move = np.empty(distances.shape[0], dtype=np.bool_)
        for f in range(distances.shape[0]):
            move[f] = distances[f] != 0.0
        step_pads_kernel(q, targets, move, geometry, layout, damping, normal_targets, facing, orient_damping)
        return True
    return advance_pads_kernel(
        q, targets, task_vectors, distances, geometry, layout, damping, normal_targets, facing, orient_damping
    )


@njit
def distance3(a: np.ndarray, b: np.ndarray) -> float:
    """|a - b| of two (3,) arrays as ``machine._distance`` computes it without numba
    (``vec3.norm3``: the squares summed left to right, the same bits on any CPU)."""
    d0, d1, d2 = a[0] - b[0], a[1] - b[1], a[2] - b[2]
    return math.sqrt(0.0 + ((d0 * d0 + d1 * d1) + d2 * d2))


@njit
def move_palm_toward(palm: np.ndarray, target: np.ndarray, step: float) -> None:
    """``GraspController._move_palm_toward`` in place: ``palm`` (3,) to ``target`` when
    it is at most ``step`` away, else ``step`` along the straight line. The distance
    is ``vec3.norm3`` (squares summed left to right), as the numpy path computes it."""
    d0, d1, d2 = target[0] - palm[0], target[1] - palm[1], target[2] - palm[2]
    dist = math.sqrt(0.0 + ((d0 * d0 + d1 * d1) + d2 * d2))
    if dist <= step:
        palm[0], palm[1], palm[2] = target[0], target[1], target[2]
        return
    s = step / dist
    palm[0], palm[1], palm[2] = palm[0] + d0 * s, palm[1] + d1 * s, palm[2] + d2 * s


#: ``squeeze_state_tick``'s constants (one float64 array, GraspController.squeeze_plan):
#: tau, ramp tolerance, grip-lost floor, release fingertip (index), release threshold,
#: force limit, state (LIFT, HOLD, LOWER), dt, contact-lost time, release debounce,
#: hold time, lift height, reach tolerance, lowest palm height, squeeze gain and
#: speed limit, IK damping, facing damping, whether the palm moves, joint step limit,
#: closing step per tick and closing time-out, release step per tick (negative) and
#: opening time, the arm's step per tick and the reach time-out.
(
    C_TAU,
    C_TOLERANCE,
    C_FLOOR,
    C_RELEASE_IDX,
    C_RELEASE_THRESHOLD,
    C_LIMIT,
    C_STATE,
    C_DT,
    C_LOST_S,
    C_DEBOUNCE,
    C_HOLD_S,
    C_LIFT_TOP_Z,
    C_REACH_TOLERANCE,
    C_LOWER_LIMIT_Z,
    C_GAIN,
    C_MAX_SPEED,
    C_DAMPING,
    C_ORIENT_DAMPING,
    C_MOVE_PALM,
    C_MAX_STEP,
    C_CLOSE_STEP,
    C_CLOSE_TIMEOUT_S,
    C_RELEASE_STEP,
    C_OPEN_S,
    C_ARM_STEP,
    C_REACH_TIMEOUT_S,
) = range(26)
N_SQUEEZE_CONSTS = 26


@njit
def squeeze_state_tick(
    grip: np.ndarray,
    in_contact: np.ndarray,
    f_sensor: np.ndarray,
    f_world: np.ndarray,
    q_measured: np.ndarray,
    palm_measured: np.ndarray,
    c: np.ndarray,
    grasping: np.ndarray,
    lost: np.ndarray,
    task_vectors: np.ndarray,
    geometry: np.ndarray,
    layout: np.ndarray,
    normal_targets: np.ndarray,
    facing: np.ndarray,
    distances: np.ndarray,
    palm_goal: np.ndarray,
    compliance: np.ndarray,
    pad_along: np.ndarray,
    directions: np.ndarray,
    pads: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    ticks_in_state: int,
    release_count: int,
    q: np.ndarray,
    targets: np.ndarray,
    palm: np.ndarray,
    palm_step: float,
    q_sent: np.ndarray,
) -> int:
    """One ``GraspController.tick`` in a squeeze state (``LIFT``, ``HOLD``, ``LOWER``), in
    ``CLOSE``, ``RELEASE``, ``REACH`` or ``RETREAT`` as far as no fault and no transition interrupt it (the snapshot's arrays first, then
    ``GraspController.squeeze_plan``: the constants ``c`` (``C_TAU``...), the arrays that
    stay, then what changes from tick to tick): ``tick_checks`` (its bits returned,
    ``lost`` updated); then, unless a force check failed, the state's guards as the
    controller has them (``grip_lost``, and ``at_lift_height``, ``hold_done`` or
    ``release_detected`` and ``lower_exhausted``; in close ``all_in_contact`` and
    ``close_timed_out``, in release ``fingers_open``, in reach ``at_reach_pose`` and
    ``reach_timed_out``, in retreat ``retreat_done``; ``ticks_in_state`` counts this tick,
    ``release_count`` is the count before this tick's update). When none holds, the
    state's action (``squeeze_pads``; in close and release ``advance_tick``; in reach and
    retreat the palm's step toward ``palm_goal``, ``move_palm_toward``) and the joint goal's step
    (``limits.step_toward`` of ``q`` into ``q_sent``), with ``TICK_DONE`` (and
    ``PADS_MOVED``) set; otherwise nothing more is done and the controller's Python
    goes on from its guards."""
    tau, dt = c[C_TAU], c[C_DT]
    flags = tick_checks(
        grip,
        in_contact,
        f_sensor,
        f_world,
        grasping,
        tau,
        c[C_TOLERANCE],
        c[C_FLOOR],
        int(c[C_RELEASE_IDX]),
        c[C_RELEASE_THRESHOLD],
        c[C_LIMIT],
        lost,
    )
    if flags & (FORCE_NOT_FINITE | OVERFORCE):
        return flags
    state = int(c[C_STATE])
    if state == REACH or state == RETREAT:
        if distance3(palm_measured, palm_goal) < c[C_REACH_TOLERANCE] or (
            state == REACH and ticks_in_state * dt > c[C_REACH_TIMEOUT_S]
        ):
            return flags
        move_palm_toward(palm, palm_goal, c[C_ARM_STEP])
        step_toward(q, q_sent, c[C_MAX_STEP], lower, upper)
        return flags | TICK_DONE
    if state == CLOSE or state == RELEASE:
        return advance_tick(
            flags,
            state,
            in_contact,
            c,
            grasping,
            task_vectors,
            geometry,
            layout,
            normal_targets,
            facing,
            distances,
            pad_along,
            lower,
            upper,
            ticks_in_state,
            q,
            targets,
            q_sent,
        )
    palm_z = palm_measured[2]
    held = False
    for i in range(lost.shape[0]):  # grip_lost
        if grasping[i] and lost[i] * dt >= c[C_LOST_S]:
            held = True
            break
    if state == LIFT:
        held = held or abs(palm_z - c[C_LIFT_TOP_Z]) < c[C_REACH_TOLERANCE]
    elif state == HOLD:
        held = held or ticks_in_state * dt >= c[C_HOLD_S]
    else:
        count = release_count + 1 if flags & RELEASE_BELOW else 0
        held = held or count >= c[C_DEBOUNCE] or palm_z <= c[C_LOWER_LIMIT_Z] + 1e-4
    if held:
        return flags
    moved = squeeze_pads(
        grip,
        grasping,
        tau,
        c[C_GAIN],
        c[C_MAX_SPEED],
        dt,
        q,
        targets,
        task_vectors,
        geometry,
        layout,
        c[C_DAMPING],
        normal_targets,
        facing,
        c[C_ORIENT_DAMPING],
        distances,
        c[C_MOVE_PALM] != 0.0,
        palm,
        palm_goal,
        palm_step,
        compliance,
        q_measured,
        pad_along,
        directions,
        pads,
    )
    step_toward(q, q_sent, c[C_MAX_STEP], lower, upper)
    return flags | TICK_DONE | (PADS_MOVED if moved else 0)


@njit
def advance_tick(
    flags: int,
    state: int,
    in_contact: np.ndarray,
    c: np.ndarray,
    grasping: np.ndarray,
    task_vectors: np.ndarray,
    geometry: np.ndarray,
    layout: np.ndarray,
    normal_targets: np.ndarray,
    facing: np.ndarray,
    distances: np.ndarray,
    pad_along: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    ticks_in_state: int,
    q: np.ndarray,
    targets: np.ndarray,
    q_sent: np.ndarray,
) -> int:
    """``squeeze_state_tick`` in close or release after the checks (``flags``): the guards
    (close: ``all_in_contact``, ``close_timed_out``; release: ``fingers_open``); when none
    holds, the action, ``FingertipMotion.advance_all`` (which forgets the squeeze's last pad
    positions) by the closing step for each grasping fingertip not in contact, or by the
    (negative) release step for each grasping fingertip, 0 for the others; then the goal step."""
    elapsed = ticks_in_state * c[C_DT]
    if state == CLOSE:
        all_in = True
        for i in range(grasping.shape[0]):
            if grasping[i] and not in_contact[i]:
                all_in = False
                break
        if all_in or elapsed > c[C_CLOSE_TIMEOUT_S]:
            return flags
        step = c[C_CLOSE_STEP]
        for f in range(distances.shape[0]):
            distances[f] = step if grasping[f] and not in_contact[f] else 0.0
    else:
        if elapsed >= c[C_OPEN_S]:
            return flags
        step = c[C_RELEASE_STEP]
        for f in range(distances.shape[0]):
            distances[f] = step if grasping[f] else 0.0
    for f in range(pad_along.shape[0]):
        pad_along[f] = np.nan
    moved = advance_pads_kernel(
        q, targets, task_vectors, distances, geometry, layout, c[C_DAMPING], normal_targets, facing, c[C_ORIENT_DAMPING]
    )
    step_toward(q, q_sent, c[C_MAX_STEP], lower, upper)
    return flags | TICK_DONE | (PADS_MOVED if moved else 0)
