"""The paper controller's compiled tick: the checks and, in the states whose usual tick runs
in one compiled call (``_SQUEEZE_STATES``), the whole tick through ``tk.squeeze_state_tick``.

``GraspController`` (controller/machine.py) binds these functions as its methods (their
``self`` is the controller); each checks that the snapshot's arrays are the kernels' usual
float64 shapes and returns -1 or None to leave the tick to the controller's Python, the
reference the kernels are checked against (tests/test_fused_tick.py,
tests/test_controller_kernels.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from grasp_ctrl.controller import tick_kernels as tk
from grasp_ctrl.controller.snapshot import Command, Snapshot

if TYPE_CHECKING:
    from grasp_ctrl.controller.machine import GraspController

_FLOAT64 = np.dtype(np.float64)

#: The states whose usual tick runs in one compiled call (GraspController._squeeze_state_tick):
#: the squeeze states, close, release and the arm's moves reach and retreat.
_SQUEEZE_STATES = {
    "lift": tk.LIFT,
    "hold": tk.HOLD,
    "lower": tk.LOWER,
    "close": tk.CLOSE,
    "release": tk.RELEASE,
    "reach": tk.REACH,
    "retreat": tk.RETREAT,
}


def _compiled_checks(self: GraspController, snap: Snapshot, limit: float) -> int:
    """``_update_counters`` then ``_force_checks`` in one compiled call (``tk.tick_checks``)
    for a snapshot of float64 arrays of the usual shapes; -1 (nothing done) otherwise."""
    nd = np.ndarray
    grip, f_sensor, f_world, contact = snap.grip_n, snap.f_sensor, snap.f_world, snap.in_contact
    if not (
        self._compiled
        and type(grip) is nd
        and type(f_sensor) is nd
        and type(f_world) is nd
        and type(contact) is nd
        and grip.dtype is _FLOAT64
        and f_sensor.dtype is _FLOAT64
        and f_world.dtype is _FLOAT64
        and grip.shape == self._tip_shape
        and contact.shape == self._tip_shape
        and f_sensor.shape == self._force_shape
        and f_world.shape == self._force_shape
    ):
        return -1
    tau = self.tau
    flags = tk.tick_checks(
        grip,
        contact,
        f_sensor,
        f_world,
        self.grasp_mask,
        tau,
        self.s.ramp_tolerance_n,
        self.s.grip_lost_fraction * tau,
        self.release_idx,
        self.obj.release_threshold_n,
        limit,
        self._lost,
    )
    self.settle_count = self.settle_count + 1 if flags & tk.WITHIN_TOLERANCE else 0
    if self.state == "ramp":
        self.ramp_settle.update(tau - grip[self.grasp_mask])
    self.release_count = self.release_count + 1 if flags & tk.RELEASE_BELOW else 0
    return flags & (tk.FORCE_NOT_FINITE | tk.OVERFORCE)


def squeeze_plan(self: GraspController, palm_z: float) -> tuple | None:
    """In a squeeze state (lift, hold, lower), close, release, reach (its posture already
    set) or retreat (its goal already set) with the compiled kernels, the torque on
    and a float64 (3,) palm target: every argument of ``tk.squeeze_state_tick`` after
    the snapshot's arrays and its palm height ``palm_z`` (a float) for this tick
    (``ticks_in_state`` counting it), so that ``_squeeze_state_tick`` can run it before
    ``squeeze_done``. None otherwise. What
    stays within a state is made once (``_squeeze_statics``)."""
    state = _SQUEEZE_STATES.get(self.state)
    p = self.palm_target
    if (
        state is None
        or not self._compiled
        or not self.torque_on
        or type(p) is not np.ndarray
        or p.dtype is not _FLOAT64
        or p.shape != (3,)
    ):
        return None
    m = self.motion
    if state == tk.REACH and not m.holds_posture(self.reach_q):
        return None  # (the first reach tick sets its posture: the Python way)
    goal = self._state_palm_goal(state)
    if goal is None:
        return None
    got = self._squeeze_cache.get(state)
    if got is None or got[0] is not m.facing or got[1] is not m.ik or got[2] is not goal:
        got = self._squeeze_cache[state] = (m.facing, m.ik, goal, self._squeeze_statics(state, goal))
    statics = got[3]
    if statics is None:
        return None
    s = self.s
    if state == tk.HOLD or state == tk.CLOSE or state == tk.RELEASE:
        palm, step = self._no_palm, 0.0
    elif state == tk.REACH or state == tk.RETREAT:
        palm, step = p, 0.0
    elif state == tk.LIFT:
        palm, step = p, s.lift_speed_m_s * self.dt
    else:
        near = palm_z - self.reach_pose[2] < s.lower_slow_zone_m
        palm, step = p, (s.lower_slow_speed_m_s if near else s.lower_speed_m_s) * self.dt
    return statics + (self.ticks_in_state + 1, self.release_count, m.q_goal, m.targets, palm, step, m.q_sent)


def _state_palm_goal(self: GraspController, state: int) -> np.ndarray | None:
    """Where the palm goes in ``state`` (the stand-in zeros where it stays); None in retreat
    before its goal is set."""
    if state == tk.LIFT:
        return self.lift_top
    if state == tk.LOWER:
        return self.lower_bottom
    if state == tk.REACH:
        return self.reach_pose
    if state == tk.RETREAT:
        return self._retreat_goal
    return self._no_palm


def _squeeze_statics(self: GraspController, state: int, goal: np.ndarray) -> tuple | None:
    """``squeeze_plan``'s arguments that stay within a state: the constants array
    (``tk.C_TAU``...) and the arrays from the grasp mask to the joint limits; None when
    the palm ``goal`` (``_state_palm_goal``) is not a float64 (3,) array (``_squeeze``'s and
    ``_move_palm_toward``'s Python then). Made once per state: the hand, the object and
    the settings do not change during a trial, and the motion's facing and IK, which a
    caller may replace, and the goal are checked by ``squeeze_plan``."""
    s, tau, obj = self.s, self.tau, self.obj
    if not (type(goal) is np.ndarray and goal.dtype is _FLOAT64 and goal.shape == (3,)):
        return None
    move = state == tk.LIFT or state == tk.LOWER  # (the squeeze moves the palm too)
    (damping, orient_damping, max_step), before, after = self.motion.squeeze_statics()
    c = np.empty(tk.N_SQUEEZE_CONSTS)
    c[tk.C_TAU], c[tk.C_TOLERANCE], c[tk.C_FLOOR] = tau, s.ramp_tolerance_n, s.grip_lost_fraction * tau
    c[tk.C_RELEASE_IDX], c[tk.C_RELEASE_THRESHOLD] = self.release_idx, obj.release_threshold_n
    c[tk.C_LIMIT], c[tk.C_STATE], c[tk.C_DT] = self.hand.safety.max_fingertip_force_n, state, self.dt
    c[tk.C_LOST_S], c[tk.C_DEBOUNCE], c[tk.C_HOLD_S] = s.contact_lost_s, obj.release_debounce, obj.hold_s
    c[tk.C_LIFT_TOP_Z], c[tk.C_REACH_TOLERANCE] = self.lift_top[2], s.reach_tolerance_m
    c[tk.C_LOWER_LIMIT_Z], c[tk.C_GAIN], c[tk.C_MAX_SPEED] = (
        self.lower_limit_z,
        s.hold_gain_m_s_per_n,
        s.hold_max_speed_m_s,
    )
    c[tk.C_DAMPING], c[tk.C_ORIENT_DAMPING] = damping, orient_damping
    c[tk.C_MOVE_PALM], c[tk.C_MAX_STEP] = float(move), max_step
    c[tk.C_CLOSE_STEP], c[tk.C_CLOSE_TIMEOUT_S] = s.close_speed_m_s * self.dt, s.close_timeout_s
    c[tk.C_RELEASE_STEP], c[tk.C_OPEN_S] = -s.release_back_off_m_s * self.dt, s.open_s  # (as _act computes it)
    c[tk.C_ARM_STEP], c[tk.C_REACH_TIMEOUT_S] = self.hand.arm.max_speed_m_s * self.dt, s.reach_timeout_s
    return (c, self.grasp_mask, self._lost) + before + (goal,) + after


def squeeze_done(self: GraspController, snap: Snapshot, flags: int) -> Command | None:
    """The rest of ``tick(snap)`` after ``tk.squeeze_state_tick`` ran on its snapshot
    with ``squeeze_plan``'s arguments (``flags``: its result): the counters, then, with
    ``tk.TICK_DONE``, None (the command is the motion's ``sent_goal`` and the palm
    target); without it, the tick's failure checks, guards and action as ``tick`` has
    them, and its command."""
    self.snap = snap
    self.ticks_in_state += 1
    self.settle_count = self.settle_count + 1 if flags & tk.WITHIN_TOLERANCE else 0
    self.release_count = self.release_count + 1 if flags & tk.RELEASE_BELOW else 0
    if flags & tk.PADS_MOVED:
        self.motion.squeezed()
    if flags & tk.TICK_DONE:
        return None
    self._decide(snap, flags & (tk.FORCE_NOT_FINITE | tk.OVERFORCE), self.hand.safety.max_fingertip_force_n)
    self._act(snap)
    palm = self.palm_target
    assert palm is not None  # set by the first tick, before any squeeze state
    return Command(self.motion.next_goal(), palm.copy(), self.torque_on)


def _squeeze_state_tick(self: GraspController, snap: Snapshot) -> Command | None:
    """``tick`` in the states of ``squeeze_plan`` through it, ``tk.squeeze_state_tick`` and
    ``squeeze_done``, for a snapshot without fault or variance whose arrays
    ``_compiled_checks`` and ``_squeeze`` would take; None (nothing done) otherwise."""
    nd = np.ndarray
    grip, f_sensor, f_world, contact, q = snap.grip_n, snap.f_sensor, snap.f_world, snap.in_contact, snap.q
    palm = snap.p_palm_world
    if not (
        snap.fault is None
        and snap.variance is None
        and type(grip) is nd
        and type(f_sensor) is nd
        and type(f_world) is nd
        and type(contact) is nd
        and type(q) is nd
        and type(palm) is nd
        and grip.dtype is _FLOAT64
        and f_sensor.dtype is _FLOAT64
        and f_world.dtype is _FLOAT64
        and q.dtype is _FLOAT64
        and palm.dtype is _FLOAT64
        and grip.shape == self._tip_shape
        and contact.shape == self._tip_shape
        and f_sensor.shape == self._force_shape
        and f_world.shape == self._force_shape
        and q.shape == self.motion.q_goal.shape
        and palm.shape == (3,)
    ):
        return None
    plan = self.squeeze_plan(float(palm[2]))
    if plan is None:
        return None
    flags = tk.squeeze_state_tick(grip, contact, f_sensor, f_world, q, palm, *plan)
    cmd = self.squeeze_done(snap, flags)
    if cmd is not None:
        return cmd
    palm_target = self.palm_target
    assert palm_target is not None  # tick sets it before a squeeze state's tick
    return Command(self.motion.sent_goal(), palm_target.copy(), self.torque_on)
