"""The mock trial's tick, the world's step included, in few compiled calls (grasp_ctrl/numeric/jit.py).

The runner's generic tick steps the world, then ``control_tick`` (loop/tick.py)
reads the backends, builds the snapshot, runs the controller and writes the
command, and the runner tracks the force peaks and appends the tick log's row. On
the mock world's own backends most of those steps copy a few small arrays, and
each Python call and compiled call costs more than its arithmetic, so
``MockTick.tick`` does the same in two or three compiled calls around the policy:

- ``step_inputs``: the world's step (``world.step_packed``), then ``mock_inputs``:
  MockHand.read's angles (and its velocity reference), MockArm.position,
  MockSensors.latest_matrix's frames as floats, then the snapshot's first half
  (``sense_inputs``: checks, tare, contact gate);
- in lift, hold, lower, close and release with a fingertip in contact, after the policy's
  product: ``squeeze_outputs``, the forces placed and turned into the hand frame,
  the controller's tick (``GraspController.squeeze_plan``, controller/tick_kernels.py
  ``squeeze_state_tick``) and, when no fault or transition interrupts it, the
  outputs below;
- otherwise the snapshot's second half and ``ctrl.tick`` as in control_tick, then
  ``mock_outputs``: control_tick's finiteness check of the command, MockHand.write_goals
  and MockArm.command (the world's one-pass writes), the runner's force peaks
  and the tick log's row.

Whatever these shortcuts do not cover (the tare, a hardware fault, a paused
sensor, a frame or angle that is not finite, a non-finite force or command,
torque off, a fault or transition of the controller, a log row that does not fit)
goes the generic way for that tick, from the point where it departs, so every
tick does what the runner's generic tick does, bit for bit (tests/test_mock_tick.py,
tests/test_fused_tick.py).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.controller.snapshot import Command, Snapshot
from grasp_ctrl.controller.tick_kernels import C_TAU, TICK_DONE, squeeze_state_tick
from grasp_ctrl.loop.loop_kernels import log_row, place_forces, sense_inputs, track_peaks
from grasp_ctrl.loop.sensing import SensingPipeline
from grasp_ctrl.loop.tick import control_tick, pac_spread, send_command
from grasp_ctrl.loop.ticklog import TickLog
from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.jit import njit
from grasp_ctrl.sim import world_step as ws
from grasp_ctrl.sim.backends import MockArm, MockHand, MockSensors
from grasp_ctrl.sim.world import PACKED, MockWorld, _clamped_target, _limited_goal, _part, step_packed

_FLOAT64 = np.dtype(np.float64)
PACKED_Q, PACKED_PALM = PACKED.index("_q"), PACKED.index("_palm")  # the world's joint angles and palm position


@njit
def mock_inputs(
    q_world: np.ndarray,
    q_prev: np.ndarray,
    palm_world: np.ndarray,
    frames_world: np.ndarray,
    baseline: np.ndarray,
    count: np.ndarray,
    threshold: float,
    frames: int,
    q: np.ndarray,
    palm: np.ndarray,
    raw: np.ndarray,
    tared: np.ndarray,
    contact: np.ndarray,
    touching: np.ndarray,
) -> int:
    """The angles into ``q`` and ``q_prev`` (MockHand.read), the palm position into
    ``palm`` (MockArm.position), the world's frames as floats into ``raw``
    (MockSensors.latest_matrix), then ``sense_inputs`` (its result: the contact bits,
    or < 0 with the gate unchanged)."""
    for j in range(q_world.shape[0]):
        q[j] = q_world[j]
        q_prev[j] = q_world[j]
    for k in range(3):
        palm[k] = palm_world[k]
    for i in range(frames_world.shape[0]):
        for c in range(frames_world.shape[1]):
            raw[i, c] = frames_world[i, c]
    return sense_inputs(q, palm, raw, baseline, count, threshold, frames, tared, contact, touching)


#: ``step_inputs``' bit for a world step that may have events (MockWorld.end_packed_step).
STEP_EVENTS = 1 << 16


@njit
def step_inputs(
    torque_on: float,
    q_goal: np.ndarray,
    palm_target: np.ndarray,
    frame_base: np.ndarray,
    sensor_t: float,
    frame_out: np.ndarray,
    state: np.ndarray,
    layout: np.ndarray,
    take: np.ndarray,
    W: np.ndarray,
    starts: np.ndarray,
    counts: np.ndarray,
    touch: np.ndarray,
    sensor_state: np.ndarray,
    sensor_gain: np.ndarray,
    sensor_consts: np.ndarray,
    q_prev: np.ndarray,
    baseline: np.ndarray,
    count: np.ndarray,
    threshold: float,
    frames: int,
    q: np.ndarray,
    palm: np.ndarray,
    raw: np.ndarray,
    tared: np.ndarray,
    contact: np.ndarray,
    touching: np.ndarray,
) -> int:
    """The mock world's step (``world.step_packed`` on ``MockWorld.begin_packed_step``'s
    arguments, ``torque_on`` to ``sensor_consts``), then ``mock_inputs`` on the new frames
    ``frame_out`` and the world's joint angles and palm position: ``mock_inputs``' result
    plus 2, with ``STEP_EVENTS`` when the step may have events."""
    events = step_packed(
        torque_on,
        q_goal,
        palm_target,
        frame_base,
        sensor_t,
        frame_out,
        state,
        layout,
        take,
        W,
        starts,
        counts,
        touch,
        sensor_state,
        sensor_gain,
        sensor_consts,
    )
    bits = mock_inputs(
        _part(state, layout, PACKED_Q),
        q_prev,
        _part(state, layout, PACKED_PALM),
        frame_out,
        baseline,
        count,
        threshold,
        frames,
        q,
        palm,
        raw,
        tared,
        contact,
        touching,
    )
    return (bits + 2) | (STEP_EVENTS if events else 0)


#: ``mock_outputs`` results.
WRITTEN = 0  # command written, peaks tracked, log row stored
NOT_FINITE = 1  # a goal or the arm target is not finite: nothing done
LOG_ROW_REFUSED = 2  # written and tracked, but the log row does not fit (the log's own append names why)


@njit
def mock_outputs(
    q_goal: np.ndarray,
    p_target: np.ndarray,
    prev_goal: np.ndarray,
    max_step: float,
    limits: np.ndarray,
    z_min: float,
    z_max: float,
    goal_out: np.ndarray,
    target_out: np.ndarray,
    f_sensor: np.ndarray,
    grip: np.ndarray,
    true_normal: np.ndarray,
    peaks: np.ndarray,
    block: np.ndarray,
    row: int,
    t: float,
    palm: np.ndarray,
    grip_target: float,
    raw: np.ndarray,
    contact: np.ndarray,
    tared: np.ndarray,
    f_world: np.ndarray,
    q: np.ndarray,
    true_f: np.ndarray,
    obj: np.ndarray,
) -> int:
    """control_tick's ``both_finite`` check of the command (NOT_FINITE: nothing done),
    MockHand.write_goals (``_limited_goal`` into ``goal_out``; ``limits``: the hand's
    lower and upper goal limits, then the world's joint limits, (4, J)) and MockArm.command
    (``_clamped_target`` into ``target_out``), the runner's ``track_peaks`` (``peaks``:
    |f|^2, grip and true normal force, (3, F)) and the tick log's row ``row`` (-1: no
    log) as ``TickLog.append`` stores it (``log_row``)."""
    for j in range(q_goal.shape[0]):
        if not math.isfinite(q_goal[j]):
            return NOT_FINITE
    for k in range(p_target.shape[0]):
        if not math.isfinite(p_target[k]):
            return NOT_FINITE
    if not _limited_goal(q_goal, prev_goal, max_step, limits[0], limits[1], limits[2], limits[3], goal_out):
        return NOT_FINITE
    if not _clamped_target(p_target, z_min, z_max, target_out):
        return NOT_FINITE
    track_peaks(f_sensor, grip, true_normal, peaks[0], peaks[1], peaks[2])
    if row >= 0 and not log_row(
        block,
        row,
        t,
        palm,
        p_target,
        grip_target,
        raw,
        contact,
        tared,
        grip,
        f_sensor,
        f_world,
        q,
        q_goal,
        true_f,
        obj[ws.OZ],
        obj[ws.TABLE_N],
    ):
        return LOG_ROW_REFUSED
    return WRITTEN


#: ``squeeze_outputs``' result when a placed force is not finite (nothing else done).
FORCES_NOT_FINITE = -1
#: ``squeeze_outputs``' bits above the controller's: ``mock_outputs``' result, shifted.
OUTPUTS_SHIFT = 8
_CONTROLLER_BITS = (1 << OUTPUTS_SHIFT) - 1


@njit
def squeeze_outputs(
    rows: np.ndarray,
    bits: int,
    q: np.ndarray,
    f_sensor: np.ndarray,
    f_hand: np.ndarray,
    grip: np.ndarray,
    contact: np.ndarray,
    palm: np.ndarray,
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
    q_goal: np.ndarray,
    targets: np.ndarray,
    palm_target: np.ndarray,
    palm_step: float,
    q_sent: np.ndarray,
    command_palm: np.ndarray,
    prev_goal: np.ndarray,
    goal_out: np.ndarray,
    target_out: np.ndarray,
    block: np.ndarray,
    row: int,
    t: float,
    raw: np.ndarray,
    tared: np.ndarray,
    sense_geometry: np.ndarray,
    sense_layout: np.ndarray,
    hand_max_step: float,
    limits: np.ndarray,
    z_min: float,
    z_max: float,
    true_normal: np.ndarray,
    peaks: np.ndarray,
    true_f: np.ndarray,
    obj: np.ndarray,
) -> int:
    """A squeeze state's tick after the policy's product, in one call: the policy's
    ``rows`` placed and turned into ``f_sensor``, ``f_hand`` and ``grip``
    (``place_forces`` with the pipeline's ``sense_geometry`` and ``sense_layout``;
    ``FORCES_NOT_FINITE`` when one is not finite: nothing else done), then the
    controller's tick (``squeeze_state_tick`` with the arguments of
    ``GraspController.squeeze_plan``, ``c`` to ``q_sent``: its bits returned) and,
    when that finished the tick (``TICK_DONE``), the command's outputs, peaks and log
    row (``mock_outputs`` of the sent goal ``q_sent`` and the controller's palm target
    ``command_palm``, its result in the bits from ``OUTPUTS_SHIFT``). The arguments
    from ``sense_geometry`` on stay for a trial (``MockTick``)."""
    if not place_forces(rows, bits, q, sense_geometry, sense_layout, f_sensor, f_hand, grip):
        return FORCES_NOT_FINITE
    flags = squeeze_state_tick(
        grip,
        contact,
        f_sensor,
        f_hand,
        q,
        palm,
        c,
        grasping,
        lost,
        task_vectors,
        geometry,
        layout,
        normal_targets,
        facing,
        distances,
        palm_goal,
        compliance,
        pad_along,
        directions,
        pads,
        lower,
        upper,
        ticks_in_state,
        release_count,
        q_goal,
        targets,
        palm_target,
        palm_step,
        q_sent,
    )
    if not flags & TICK_DONE:
        return flags
    done = mock_outputs(
        q_sent,
        command_palm,
        prev_goal,
        hand_max_step,
        limits,
        z_min,
        z_max,
        goal_out,
        target_out,
        f_sensor,
        grip,
        true_normal,
        peaks,
        block,
        row,
        t,
        palm,
        c[C_TAU],
        raw,
        contact,
        tared,
        f_hand,
        q,
        true_f,
        obj,
    )
    return flags | (done << OUTPUTS_SHIFT)


def ctrl_command(ctrl: GraspController) -> Command:
    """The command of a tick that ``squeeze_state_tick`` finished: the goal it stepped and the palm target."""
    return Command(ctrl.motion.sent_goal(), ctrl.palm_target.copy(), ctrl.torque_on)  # type: ignore[union-attr]


class MockTick:
    """One trial's ticks on the mock world's own backends (``usable``), with fused I/O.

    ``tick(ctrl)`` returns control_tick's ``(snapshot, command, raw frames)`` after the
    force peaks (``peaks``, (3, F): |f_sensor|^2, grip, true normal force) are tracked
    and the log row appended, exactly as the runner's generic tick does them.
    """

    def __init__(
        self,
        world: MockWorld,
        hand: MockHand,
        sensors: MockSensors,
        arm: MockArm,
        pipeline: SensingPipeline,
        log: TickLog | None,
        peaks: np.ndarray,
    ) -> None:
        self.world, self.hand, self.sensors, self.arm = world, hand, sensors, arm
        self.pipeline, self.log, self.peaks = pipeline, log, peaks
        J = len(world.lower)
        self._frame_shape = pipeline._frame_shape
        self._limits = np.array([hand.lower, hand.upper, world.lower, world.upper], dtype=float)
        self._log_rows = log is not None and log._compiled
        self._no_block = np.empty((0, 0))
        self._no_rows = np.zeros((0, 3))  # the policy's rows when no fingertip is in contact
        self._J = J
        self._n = self._frame_shape[0]
        # squeeze_outputs' arguments that stay for the trial (the world's arrays are updated in place)
        self._trial_args = (
            pipeline._geometry,
            pipeline._layout,
            hand.max_step,
            self._limits,
            arm._z_min,
            arm._z_max,
            world._normal_n,
            peaks,
            world._f_sensor,
            world._obj,
        )

    @staticmethod
    def usable(world: Any, hand: Any, sensors: Any, arm: Any, pipeline: SensingPipeline, log: TickLog | None) -> bool:
        """The mock world's own backends (exactly), compiled kernels, and a pipeline that
        reads the world's sensors in its order and counts a frame of this tick as fresh."""
        return (
            jit.JIT
            and type(world) is MockWorld
            and type(hand) is MockHand
            and type(sensors) is MockSensors
            and type(arm) is MockArm
            and hand.world is world
            and sensors.world is world
            and arm.world is world
            and pipeline._compiled
            and pipeline.sensor_ids == world.sensor_ids
            and 0.0 <= pipeline._stale_after_s
            and hand._write_limited is not None
            and arm._set_clamped is not None
            and (log is None or log.truth)
        )

    def tick(self, ctrl: GraspController) -> None:
        """One tick: the world's step (and its phase set to the controller's state), then the
        controller's tick on it (its snapshot is then ``ctrl.snap``), the command, peaks and
        log row. The shortcuts' conditions do not depend on the step, so they are checked
        before it and the step and the inputs run in one call (``step_inputs``)."""
        world, hand, sensors, pipeline = self.world, self.hand, self.sensors, self.pipeline
        tactile = pipeline.tactile
        if (
            not hand.fault
            and not sensors.paused
            and ctrl.state != "tare"
            and tactile.tare.ready
            and tactile.validate
            and type(world.raw) is np.ndarray
            and world.raw.shape == self._frame_shape
        ):
            n = self._n
            empty = np.empty
            q, palm, raw = empty(self._J), empty(3), empty(self._frame_shape)
            tared, in_contact, touching = empty(self._frame_shape), empty(n, dtype=bool), empty(self._frame_shape)
            gate = tactile.gate
            step = world.begin_packed_step()
            code = step_inputs(
                *step,
                hand._q_prev,
                tactile.tare.baseline,
                gate.count,
                gate.threshold,
                gate.frames,
                q,
                palm,
                raw,
                tared,
                in_contact,
                touching,
            )
            world.end_packed_step(step[5], code & STEP_EVENTS)
            world.set_phase(ctrl.state)
            sensors._delivered = (world.raw, world.seq, world.t)  # what latest_matrix notes
            bits = (code & (STEP_EVENTS - 1)) - 2
            if bits >= 0:
                if not self._squeeze_tick(ctrl, raw, q, palm, tared, in_contact, bits, touching):
                    return
                self._finish(
                    ctrl, pipeline.snapshot_gated(raw, q, palm, world.t, tared, in_contact, bits, touching), raw
                )
                return
        else:
            world.step()
            world.set_phase(ctrl.state)
        # the generic tick (it reads the backends again: the same values)
        snap, cmd, raw = control_tick(hand, self.arm, sensors, pipeline, ctrl, world.t)
        self._track_and_log(ctrl, snap, cmd, raw)

    def _squeeze_tick(
        self,
        ctrl: GraspController,
        raw: np.ndarray,
        q: np.ndarray,
        palm: np.ndarray,
        tared: np.ndarray,
        in_contact: np.ndarray,
        bits: int,
        touching: np.ndarray,
    ) -> bool:
        """The tick after ``mock_inputs`` (fingertips in contact: ``bits``) when the controller
        is in a state of ``GraspController.squeeze_plan`` and the policy has no variance:
        the policy's product (none without contact), then ``squeeze_outputs`` (forces, the
        controller's tick and, when it finished the tick, the outputs), then what its result
        leaves to Python; what ``snapshot_gated``, ``ctrl.tick`` and ``_finish`` would do, bit
        for bit. True (nothing done) when it does not apply."""
        pipeline = self.pipeline
        estimator = pipeline.tactile.estimator
        if estimator.has_variance:
            return True
        palm_z = float(palm[2])
        plan = ctrl.squeeze_plan(palm_z)
        if plan is None:
            return True
        world = self.world
        t = world.t
        pipeline.raw, pipeline._last_q, pipeline._last_palm = raw, q, palm  # as snapshot_gated
        gated = tared, in_contact, bits, touching
        n = self._n
        if bits:
            rows, idx = pipeline.estimate_contacts(estimator, tared, touching, bits)
            if not (
                type(rows) is np.ndarray
                and rows.dtype is _FLOAT64
                and rows.shape == (idx.size, 3)
                and rows.flags.c_contiguous
            ):
                self._finish(
                    ctrl,
                    pipeline._snapshot(raw, q, palm, t, gated, False, None, None, pipeline.placed_rows(rows, idx)),
                    raw,
                )
                return False
        else:  # no fingertip in contact: no policy call, zero forces (as TactilePipeline.forces)
            rows = self._no_rows
        empty = np.empty
        f_sensor, f_hand, grip = empty((n, 3)), empty((n, 3)), empty(n)
        goal, target = empty(self._J), empty(3)
        row, block = self._log_slot()
        code = squeeze_outputs(
            rows,
            bits,
            q,
            f_sensor,
            f_hand,
            grip,
            in_contact,
            palm,
            *plan,
            ctrl.palm_target,
            world._q_goal,
            goal,
            target,
            block,
            row,
            t,
            raw,
            tared,
            *self._trial_args,
        )
        if code == FORCES_NOT_FINITE:  # the long way names it
            self._finish(ctrl, pipeline._snapshot(raw, q, palm, t, gated, False, None, None, f_sensor), raw)
            return False
        pipeline.tared = tared
        snap = Snapshot(t, q, palm, True, in_contact, f_sensor, f_hand, f_hand, grip, None, None, None)
        cmd = ctrl.squeeze_done(snap, code & _CONTROLLER_BITS)
        if cmd is not None:  # a fault or a transition: the controller's own command
            self._send(ctrl, snap, cmd, raw)
            return False
        done = code >> OUTPUTS_SHIFT
        if done == NOT_FINITE:  # control_tick's own output half, then the runner's peaks and row
            cmd = send_command(self.hand, self.arm, ctrl, snap, ctrl_command(ctrl))
            self._track_and_log(ctrl, snap, cmd, raw)
            return False
        self._written(ctrl, snap, raw, goal, target, done, row, None)
        return False

    def _log_slot(self) -> tuple[int, np.ndarray]:
        """The tick log's next row and its block, grown if full; (-1, a dummy) without a log."""
        log = self.log
        if log is None or not self._log_rows:
            return -1, self._no_block
        row = log._n
        if row == len(log._block):
            log._grow()
        return row, log._block

    def _finish(self, ctrl: GraspController, snap: Snapshot, raw: np.ndarray) -> None:
        """The controller's tick on ``snap``, then the command's outputs, peaks and log row."""
        if ctrl.reads_vibration:  # as control_tick gives it
            snap = snap._replace(pac_spread=pac_spread(raw))
        self._send(ctrl, snap, ctrl.tick(snap), raw)

    def _send(self, ctrl: GraspController, snap: Snapshot, cmd: Command, raw: np.ndarray) -> None:
        """``cmd`` to the world (``mock_outputs``, else ``send_command``), the peaks and the log row."""
        world = self.world
        row, block = self._log_slot()
        goal, target = np.empty(self._J), np.empty(3)
        q_goal, p_target = cmd.q_goal, cmd.p_palm_world
        done = NOT_FINITE
        if (
            cmd.torque_on
            and type(q_goal) is np.ndarray
            and type(p_target) is np.ndarray
            and q_goal.dtype is _FLOAT64
            and p_target.dtype is _FLOAT64
            and q_goal.shape == (self._J,)
            and p_target.shape == (3,)
        ):
            done = mock_outputs(
                q_goal,
                p_target,
                world.q_goal,
                self.hand.max_step,
                self._limits,
                self.arm._z_min,
                self.arm._z_max,
                goal,
                target,
                snap.f_sensor,
                snap.grip_n,
                world.normal_n,
                self.peaks,
                block,
                row,
                snap.t,
                snap.p_palm_world,
                ctrl.tau,
                raw,
                snap.in_contact,
                self.pipeline.tared,
                snap.f_world,
                snap.q,
                world.f_sensor,
                world._obj,
            )
        if done == NOT_FINITE:  # control_tick's own output half, then the runner's peaks and row
            cmd = send_command(self.hand, self.arm, ctrl, snap, cmd)
            self._track_and_log(ctrl, snap, cmd, raw)
            return
        self._written(ctrl, snap, raw, goal, target, done, row, cmd)

    def _written(
        self,
        ctrl: GraspController,
        snap: Snapshot,
        raw: np.ndarray,
        goal: np.ndarray,
        target: np.ndarray,
        done: int,
        row: int,
        cmd: Command | None,
    ) -> None:
        """After ``mock_outputs`` or ``squeeze_outputs`` wrote a command (``done``): the world's
        new goal and wrist target, the log's state and row count, or its own append when the
        row did not fit (or there is no compiled row). ``cmd`` None: the controller's own
        command, made only for that append (the squeeze path has none at hand)."""
        world, log = self.world, self.log
        world._q_goal = goal
        world._palm_target = target
        if row >= 0 and done == WRITTEN:
            log._states.append(ctrl.state)  # type: ignore[union-attr]
            log._n = row + 1  # type: ignore[union-attr]
        elif log is not None:
            self._append(ctrl, snap, ctrl_command(ctrl) if cmd is None else cmd, raw)

    def _track_and_log(self, ctrl: GraspController, snap: Snapshot, cmd: Command, raw: np.ndarray) -> None:
        track_peaks(snap.f_sensor, snap.grip_n, self.world.normal_n, self.peaks[0], self.peaks[1], self.peaks[2])
        if self.log is not None:
            self._append(ctrl, snap, cmd, raw)

    def _append(self, ctrl: GraspController, snap: Snapshot, cmd: Command, raw: np.ndarray) -> None:
        w = self.world
        self.log.append(
            ctrl.state,
            snap,
            cmd,
            self.pipeline.tared,
            w.f_sensor,
            w.obj_z,
            w.table_n,  # type: ignore[union-attr]
            raw=raw,
            grip_target_n=ctrl.tau,
        )
