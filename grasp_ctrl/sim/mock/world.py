"""The mock world: a hand on a Cartesian arm, one object on a table, fingertip sensors.

Deterministic from a seed and stepped in simulated time (one control period
per ``step``), so trials run far faster than real time and repeat exactly.

Model (quasi-static, documented in docs/mock_world.md):
- Arm: the palm moves toward its target at the arm's speed limit; the hand
  frame keeps the world's orientation.
- Servos: each joint's internal position follows its goal with a first-order
  lag; the joint is a torsional spring (``servo_stiffness``) from that position,
  its torque capped by the current limit. A fingertip pressing on the object
  is deflected back until servo torque and contact force balance, so the force
  follows from position error and stiffness, not from a script.
- Contact: one contact point per fingertip (the pad); normal force
  ``k * penetration`` with the object's stiffness, along the surface normal of
  the body or of a domed cap (shapes.py); vertical friction through a
  stick-slip spring capped by ``mu * N`` (grip.py); the table only pushes up.
- Outcomes: crushing (deformable objects, grip above crush force), knocking
  over (push into the table above ``tip_force_n``), slipping and dropping are
  recorded as events from the simulated truth.

Speed: a step must cost tens of microseconds (``bench``'s
``mock_realtime_factor``), so the physics is one kernel over arrays
(sim/mock/world_step.py), compiled by numba when the ``sim`` extra is installed
(grasp_ctrl/numeric/jit.py). The kinematics of all fingers are one tensor contraction
(kinematics/multilinear.py) at the servo positions; the contact solve, linear
in the deflection, then moves each contact point and sensor frame to first
order (the deflections are hundredths of a radian).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from grasp_ctrl.config.actuation import torque_limits_nm, torque_per_amp_nm
from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR
from grasp_ctrl.kinematics.multilinear import MultilinearKinematics, contract
from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.gravity import GRAVITY_M_S2
from grasp_ctrl.numeric.jit import njit
from grasp_ctrl.numeric.limits import clamp, clamp_palm_height, limit_goal
from grasp_ctrl.sim.biotac.model import BioTacSensorModel
from grasp_ctrl.sim.mock import world_step as ws
from grasp_ctrl.sim.mock.shapes import shape_params
from grasp_ctrl.sim.variation import draw_object, draw_record
from grasp_ctrl.sim.world_params import WorldParams
from grasp_ctrl.sim.world_parts import NOISE_BLOCK, WorldEvent, checked_palm_target, in_place_view

NEAR_M = 0.01  # fingertips further than this from the object cannot touch it this step
_FLOAT64 = np.dtype(np.float64)


@functools.lru_cache(maxsize=8)
def hand_kinematics(hand: HandConfig) -> HandKinematics:
    """The kinematics of a hand, built once and shared by its worlds (which only read them)."""
    return HandKinematics(hand)


@functools.lru_cache(maxsize=8)
def pad_tables(hand: HandConfig) -> tuple[np.ndarray, np.ndarray]:
    """The multilinear kinematics of every finger's pad point (``take``, ``W``): built
    once per hand (milliseconds, a noticeable share of a short trial) and shared by
    its worlds, whose step kernel only reads them."""
    mk = MultilinearKinematics(hand_kinematics(hand))
    return mk.take, mk.point_table(np.tile(PAD_POINT_SENSOR, (mk.F, 1)))


@njit
def _clip_into(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, out: np.ndarray) -> None:
    """``out`` = ``np.minimum(np.maximum(q, lower), upper)``."""
    for j in range(q.shape[0]):
        out[j] = clamp(q[j], lower[j], upper[j])


@njit
def _limited_goal(
    goal: np.ndarray,
    prev: np.ndarray,
    max_step: float,
    lower: np.ndarray,
    upper: np.ndarray,
    joint_lower: np.ndarray,
    joint_upper: np.ndarray,
    out: np.ndarray,
) -> bool:
    """``out`` = ``goal`` within ``max_step`` of ``prev``, then within [lower, upper], then
    within [joint_lower, joint_upper] (``limits.limit_goal`` then ``_clip_into``), when
    every goal is finite; False (``out`` unset) when one is not."""
    for j in range(goal.shape[0]):
        if not math.isfinite(goal[j]):
            return False
    limit_goal(goal, prev, max_step, lower, upper, out)
    for j in range(goal.shape[0]):
        out[j] = clamp(out[j], joint_lower[j], joint_upper[j])
    return True


@njit
def _clamped_target(p: np.ndarray, z_min: float, z_max: float, out: np.ndarray) -> bool:
    """``out`` = ``p`` with its height clamped as every arm clamps it (``clamp_palm_height``);
    whether every coordinate of the result is finite (else the caller drops ``out``)."""
    clamp_palm_height(p, z_min, z_max, out)
    return math.isfinite(out[0]) and math.isfinite(out[1]) and math.isfinite(out[2])


#: The world's own float arrays packed into one buffer (MockWorld._pack_state), in world_step's order,
#: then the step's watch levels.
PACKED = (
    "_q_servo",
    "_q",
    "lower",
    "upper",
    "_reach",
    "tau_max",
    "_palm",
    "_pad_local",
    "_contact_sensor",
    "_skin_normal_sensor",
    "_shape",
    "_obj",
    "_normal_n",
    "_stick_offset",
    "_slip_speed",
    "_n_out_world",
    "_contact_z",
    "_omega",
    "_tangential_up_n",
    "_f_world",
    "_f_sensor",
    "_rows",
    "_consts",
    "_watch",
)
#: ``_watch``: the highest object height, the height before the last step, the grip that
#: may crush the object (inf: it cannot be crushed), the table force that may knock it over.
MAX_Z, PREV_Z, CRUSH_N, TIP_N = range(4)


@njit
def _part(state: np.ndarray, layout: np.ndarray, k: int) -> np.ndarray:
    """Array ``k`` of a packed state: a one-dimensional view."""
    return state[layout[k, 0] : layout[k, 0] + layout[k, 1]]


@njit
def _part2(state: np.ndarray, layout: np.ndarray, k: int) -> np.ndarray:
    """Array ``k`` of a packed state: a (rows, columns) view."""
    start, rows, cols = layout[k, 0], layout[k, 1], layout[k, 2]
    return state[start : start + rows * cols].reshape((rows, cols))


@njit
def step_packed(
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
) -> bool:
    """``MockWorld.step``'s arithmetic on a world whose float arrays are views of ``state``
    (``PACKED``, ``layout``: start, rows, columns of each): the torque flag into the
    constants, the object height before (``_watch[PREV_Z]``), ``world_step``, then the
    highest height (``_watch[MAX_Z]``). True when ``MockWorld._record`` may have an
    event to note: a new contact, a fall to the table, a grip or table force past its
    watch level (``_record`` decides)."""
    c = _part(state, layout, 22)
    watch = _part(state, layout, 23)
    obj = _part(state, layout, 11)
    c[ws.TORQUE_ON] = torque_on
    prev_z = obj[ws.OZ]
    watch[PREV_Z] = prev_z
    ws.world_step(
        q_goal,
        palm_target,
        frame_base,
        sensor_t,
        frame_out,
        _part(state, layout, 0),
        _part(state, layout, 1),
        _part(state, layout, 2),
        _part(state, layout, 3),
        _part(state, layout, 4),
        _part(state, layout, 5),
        starts,
        counts,
        _part(state, layout, 6),
        take,
        W,
        _part(state, layout, 7),
        _part2(state, layout, 8),
        _part2(state, layout, 9),
        _part(state, layout, 10),
        _part(state, layout, 11),
        _part(state, layout, 12),
        touch,
        _part(state, layout, 13),
        _part(state, layout, 14),
        _part2(state, layout, 15),
        _part(state, layout, 16),
        _part2(state, layout, 17),
        _part(state, layout, 18),
        _part2(state, layout, 19),
        _part2(state, layout, 20),
        _part2(state, layout, 21),
        _part(state, layout, 22),
        sensor_state,
        sensor_gain,
        sensor_consts,
    )
    z = obj[ws.OZ]
    if z > watch[MAX_Z]:
        watch[MAX_Z] = z
    return (
        obj[ws.NEW_CONTACTS] != 0.0
        or (prev_z > 0.002 and z == 0.0)
        or obj[ws.MAX_NORMAL] > watch[CRUSH_N]
        or obj[ws.TABLE_N] - c[ws.WEIGHT] > watch[TIP_N]
    )


class MockWorld:
    def __init__(
        self,
        hand: HandConfig,
        obj: ObjectProfile,
        seed: int,
        params: WorldParams | None = None,
    ) -> None:
        self.hand = hand
        self.params = p = params or WorldParams()
        self.rng = np.random.default_rng(seed)
        self.kin = hand_kinematics(hand)
        self._take, self._W = pad_tables(hand)
        self.dt = hand.dt
        self.t = 0.0
        self.phase = "idle"

        # Object, randomised within a few percent / millimetres.
        self.obj = obj
        self._shape = shape_params(obj)
        rng = self.rng
        drawn = draw_object(rng, p.variation)
        xy = drawn.xy_m
        self.mass = obj.mass_kg * (1.0 + drawn.mass_frac)
        self.mu = obj.mu * (1.0 + drawn.friction_frac)
        self.k_contact = obj.stiffness_n_per_m * (1.0 + drawn.stiffness_frac)
        #: The trial's actual draws (the record's ``variation_draw``); no yaw, no joint offsets here.
        self.draw = draw_record(drawn, 0.0, np.zeros(len(hand.joints)))
        self._weight = self.mass * GRAVITY_M_S2
        self._obj = np.array([xy[0], xy[1], 0.0, self._weight, 0.0, 0.0])
        # The highest object height, the height before the last step, and the levels past
        # which a step's grip or table force may be an event (_record; read by step_packed).
        crush = obj.crush_force_n if obj.deformable and obj.crush_force_n is not None else math.inf
        self._watch = np.array([0.0, 0.0, crush, obj.tip_force_n])

        # Hand and arm.
        joints = hand.joints
        self.lower = np.array([j.lower_rad for j in joints])
        self.upper = np.array([j.upper_rad for j in joints])
        self._q_goal = np.array([j.open_rad for j in joints])
        self._q_servo = self._q_goal.copy()  # the servo's internal (lagged) position
        self._q = self._q_goal.copy()  # actual, after contact deflection
        self.torque_on = True
        # N m/A of the current the servos report; NaN: a hand that reports none (torque-controlled)
        per_amp = p.torque_per_amp_nm if p.torque_per_amp_nm is not None else torque_per_amp_nm(hand)
        self.torque_per_amp_nm = per_amp if per_amp is not None else math.nan
        self.tau_max = torque_limits_nm(hand, p.torque_per_amp_nm)
        self._reach = self.tau_max / p.servo_stiffness_nm_per_rad
        self._palm = self.reach_pose_world() + np.array([0.0, 0.0, p.start_clearance_m])
        self._palm_target = self._palm.copy()
        self.arm_speed = hand.arm.max_speed_m_s

        # Fingertips and sensors (in hand-file finger order).
        self.fingers = [f.name for f in hand.fingers]
        self.sensor_ids = [f.sensor_id for f in hand.fingers]
        slices = [self.kin.slices[f] for f in self.fingers]
        self._starts = np.array([sl.start for sl in slices], dtype=np.int64)
        self._counts = np.array([sl.stop - sl.start for sl in slices], dtype=np.int64)
        n = len(self.fingers)
        self._normal_n = np.zeros(n)
        self._tangential_up_n = np.zeros(n)  # upward force of each finger on the object
        self._in_contact = np.zeros(n, dtype=bool)
        self._stick_offset = np.zeros(n)  # contact height minus object height at stick
        self._slip_speed = np.zeros(n)
        self._f_world = np.zeros((n, 3))  # force ON each sensor skin, world frame
        self._f_sensor = np.zeros((n, 3))
        self._n_out_world = np.zeros((n, 3))  # object's outward surface normal at each contact
        self._contact_z = np.zeros(n)  # contact height (world) after deflection
        self._omega = np.zeros((n, 3))  # rotation of each sensor frame by the deflection
        self._rows = np.zeros((n, self._W.shape[2]))
        self.sensors = BioTacSensorModel(n, self.rng, p.biotac, noise_block=NOISE_BLOCK)
        self.seq = 0
        self._contact_sensor = np.tile(PAD_POINT_SENSOR, (n, 1))  # where each fingertip touches
        self._skin_normal_sensor = np.tile(PAD_NORMAL_SENSOR, (n, 1))  # outward skin normal there
        self._pad_local = np.array(PAD_POINT_SENSOR)
        self._consts = np.zeros(ws.N_CONSTS)
        c = self._consts
        c[ws.DT], c[ws.ARM_SPEED] = self.dt, self.arm_speed
        c[ws.ALPHA] = 1.0 - math.exp(-self.dt / p.servo_time_constant_s)
        c[ws.MAX_SERVO_STEP] = p.servo_max_speed_rad_s * self.dt
        c[ws.KP], c[ws.KT] = p.servo_stiffness_nm_per_rad, p.tangential_stiffness_n_per_m
        c[ws.K_CONTACT], c[ws.MU], c[ws.WEIGHT] = self.k_contact, self.mu, self._weight
        c[ws.SKIN_CONTACT], c[ws.NEAR] = float(p.skin_contact), NEAR_M
        contract(self._q_servo, self._take, self._W, self._rows)
        self.raw = self._sense()
        sens = self.sensors
        self._pack_state()
        # The world's own arrays, bound once: the kernel updates them in place.
        self._arrays = (
            self._q_servo,
            self._q,
            self.lower,
            self.upper,
            self._reach,
            self.tau_max,
            self._starts,
            self._counts,
            self._palm,
            self._take,
            self._W,
            self._pad_local,
            self._contact_sensor,
            self._skin_normal_sensor,
            self._shape,
            self._obj,
            self._normal_n,
            self._in_contact,
            self._stick_offset,
            self._slip_speed,
            self._n_out_world,
            self._contact_z,
            self._omega,
            self._tangential_up_n,
            self._f_world,
            self._f_sensor,
            self._rows,
            self._consts,
            sens.state,
            sens.gain,
            sens.consts,
        )
        # What the packed step (step_packed) takes besides the state buffer and its layout.
        self._packed_args = (
            self._take,
            self._W,
            self._starts,
            self._counts,
            self._in_contact,
            sens.state,
            sens.gain,
            sens.consts,
        )

        self.events: list[WorldEvent] = []
        self.crushed = False
        self.knocked_over = False

    def _pack_state(self) -> None:
        """Move the world's own float arrays (``PACKED``, in that order) into one buffer,
        each attribute becoming its view (same values, updated in place as before): the
        compiled step then takes one array for 23 (``step_packed``), and a compiled
        call's cost grows with the arrays it is handed."""
        arrays = [getattr(self, name) for name in PACKED]
        layout = np.zeros((len(arrays), 3), dtype=np.int64)  # start, rows, columns (0: one-dimensional)
        at = 0
        for k, a in enumerate(arrays):
            layout[k] = at, a.shape[0], a.shape[1] if a.ndim == 2 else 0
            at += a.size
        state = np.empty(at)
        for k, (name, a) in enumerate(zip(PACKED, arrays)):
            view = state[layout[k, 0] : layout[k, 0] + a.size].reshape(a.shape)
            view[...] = a
            setattr(self, name, view)
        self._state, self._layout = state, layout

    # ----- state --------------------------------------------------------------
    @property
    def q_goal(self) -> np.ndarray:
        return self._q_goal

    @q_goal.setter
    def q_goal(self, q: np.ndarray) -> None:
        # Goals inside the joint limits keep the servos' first-order steps inside them too.
        if jit.JIT and type(q) is np.ndarray and q.dtype is _FLOAT64 and q.shape == self.lower.shape:
            goal = np.empty(self.lower.shape[0])
            _clip_into(q, self.lower, self.upper, goal)
            self._q_goal = goal
            return
        self._q_goal = np.minimum(np.maximum(np.asarray(q, dtype=float), self.lower), self.upper)  # = np.clip, cheaper

    # Updated in place by the step kernel, so read-only here.
    def write_limited_goal(self, goal: np.ndarray, max_step: float, lower: np.ndarray, upper: np.ndarray) -> bool:
        """The mock hand's goal write in one compiled pass (sim/mock/backends.py): ``goal``
        (float64, one per joint) within ``max_step`` of the current goal and within
        [lower, upper], then the ``q_goal`` setter's clamp to the joint limits. False,
        with nothing changed, when a goal is not finite."""
        out = np.empty(self.lower.shape[0])
        if not _limited_goal(goal, self._q_goal, max_step, lower, upper, self.lower, self.upper, out):
            return False
        self._q_goal = out
        return True

    def set_clamped_palm_target(self, p: np.ndarray, z_min: float, z_max: float) -> bool:
        """The mock arm's command in one compiled pass (sim/mock/backends.py): ``p`` (float64,
        (3,)) with its height clamped to [z_min, z_max] becomes the wrist target when it
        is finite; False, with nothing changed, when it is not."""
        out = np.empty(3)
        if not _clamped_target(p, z_min, z_max, out):
            return False
        self._palm_target = out
        return True

    @property
    def q(self) -> np.ndarray:
        return self._q

    @property
    def q_servo(self) -> np.ndarray:
        return self._q_servo

    # ----- what the servos see (the mock world has no calibration offsets) ---------
    @property
    def q_measured(self) -> np.ndarray:
        """The joint angles the servos report: the mock's angles as they are."""
        return self._q

    def command_goal(self, q_measured_goal: np.ndarray) -> None:
        """A goal in the servos' calibrated angles: the mock's goal as it is."""
        self.q_goal = q_measured_goal

    @property
    def q_goal_measured(self) -> np.ndarray:
        """The goal the servos hold, in their calibrated angles: the mock's goal as it is."""
        return self._q_goal

    @property
    def joint_current_a(self) -> np.ndarray:
        """The servos' present current (A): the servo spring's torque over the torque constant."""
        p = self.params
        return p.servo_stiffness_nm_per_rad * (np.asarray(self._q_servo) - np.asarray(self._q)) / self.torque_per_amp_nm

    @property
    def palm_world(self) -> np.ndarray:
        return self._palm

    normal_n = in_place_view("_normal_n", "normal force of each fingertip (N)")
    tangential_up_n = in_place_view("_tangential_up_n", "upward force of each finger on the object (N)")
    in_contact = in_place_view("_in_contact", "whether each fingertip touches the object")
    stick_offset = in_place_view("_stick_offset", "contact height minus object height at stick (m)")
    slip_speed = in_place_view("_slip_speed", "slip speed of each contact (m/s)")
    f_world = in_place_view("_f_world", "force ON each sensor skin, world frame (N)")
    f_sensor = in_place_view("_f_sensor", "force ON each sensor skin, sensor frame (N)")
    n_out_world = in_place_view("_n_out_world", "object's outward surface normal at each contact")
    contact_sensor = in_place_view("_contact_sensor", "where each fingertip touches, sensor frame (m)")
    skin_normal_sensor = in_place_view("_skin_normal_sensor", "outward skin normal there, sensor frame")

    @property
    def palm_target(self) -> np.ndarray:
        return self._palm_target

    @palm_target.setter
    def palm_target(self, p: np.ndarray) -> None:
        self._palm_target = checked_palm_target(p)

    @property
    def obj_xy(self) -> np.ndarray:
        return self._obj[:2].copy()

    @property
    def obj_z(self) -> float:
        return float(self._obj[ws.OZ])

    @property
    def table_n(self) -> float:
        return float(self._obj[ws.TABLE_N])

    @property
    def _R_sensor(self) -> np.ndarray:
        """Sensor rotations (F, 3, 3) in the hand frame at the deflected joint angles."""
        out = np.empty((len(self.fingers), 3, 3))
        for i, row in enumerate(self._rows):
            R = row[:9].reshape(3, 3)
            w = self._omega[i]
            for col in range(3):
                out[i, :, col] = ws._rotate(w[0], w[1], w[2], R[0, col], R[1, col], R[2, col])
        return out

    def reach_pose_world(self) -> np.ndarray:
        """Nominal palm position for grasping (the controller does not see the jitter); the
        profile's grasp height plus its ``approach_offset_m``."""
        obj = self.obj
        return np.array([0.0, 0.0, obj.grasp_height_m + obj.approach_offset_m + self.hand.grasp.palm_above_contact_m])

    # ----- stepping -------------------------------------------------------
    def step(self) -> None:
        if jit.JIT:  # the same kernel on the same arrays, handed over as one buffer (compiled: cheaper to call)
            args = self.begin_packed_step()
            self.end_packed_step(args[5], step_packed(*args))
            return
        self.t += self.dt
        sens = self.sensors
        self._consts[ws.TORQUE_ON] = 1.0 if self.torque_on else 0.0
        prev_z = self._obj[ws.OZ]
        frame_base = sens.advance(self.dt)
        raw = np.empty(self.raw.shape, dtype=self.raw.dtype)
        ws.world_step(self._q_goal, self._palm_target, frame_base, sens.t, raw, *self._arrays)
        self.raw = raw
        self.seq = (self.seq + 1) & 0xFFFF
        self._record(prev_z)

    def begin_packed_step(self) -> tuple:
        """``step``'s compiled path up to its kernel: the clock, this step's noisy sensor
        baselines and a new frame array (frames delivered earlier keep theirs); returns
        ``step_packed``'s arguments (the new frame array is the sixth). The caller runs
        ``step_packed`` on them, then ``end_packed_step``."""
        self.t += self.dt
        sens = self.sensors
        frame_base = sens.advance(self.dt)
        raw = np.empty(self.raw.shape, dtype=self.raw.dtype)
        return (
            1.0 if self.torque_on else 0.0,
            self._q_goal,
            self._palm_target,
            frame_base,
            sens.t,
            raw,
            self._state,
            self._layout,
        ) + self._packed_args

    def end_packed_step(self, raw: np.ndarray, events: bool) -> None:
        """``step``'s compiled path after its kernel: the new frames (``raw``) and their
        sequence number, and the step's events when ``step_packed`` said there may be some."""
        self.raw = raw
        self.seq = (self.seq + 1) & 0xFFFF
        if events:
            self._record(float(self._watch[PREV_Z]))

    @property
    def max_obj_z(self) -> float:
        """The highest object height so far (m)."""
        return float(self._watch[MAX_Z])

    @max_obj_z.setter
    def max_obj_z(self, z: float) -> None:
        self._watch[MAX_Z] = z

    def _sense(self) -> np.ndarray:
        """Frames of the current contact state (at start-up; ``step`` makes its own)."""
        self.seq = (self.seq + 1) & 0xFFFF
        return self.sensors.frames(
            self._contact_sensor, self._f_sensor, self._skin_normal_sensor, self._in_contact, self._slip_speed, self.dt
        )

    def _record(self, prev_z: float) -> None:
        """Events and outcome flags from the step's truth."""
        z, table_n, worst, new_contacts = self._obj[ws.OZ :].tolist()
        if z > self.max_obj_z:
            self.max_obj_z = z
        if new_contacts:
            for i, name in enumerate(self.fingers):
                if int(new_contacts) >> i & 1:
                    self.events.append(WorldEvent(self.t, "contact", name))
        if prev_z > 0.002 and z == 0.0:
            self.events.append(WorldEvent(self.t, "fell", f"from {prev_z * 1000:.1f} mm while {self.phase}"))
        obj = self.obj
        if obj.crush_force_n is not None and obj.deformable and not self.crushed and worst > obj.crush_force_n:
            self.crushed = True
            self.events.append(WorldEvent(self.t, "crushed", f"grip {worst:.2f} N > {obj.crush_force_n} N"))
        if not self.knocked_over and table_n - self._weight > obj.tip_force_n:
            self.knocked_over = True
            self.events.append(
                WorldEvent(self.t, "knocked_over", f"pushed {table_n - self._weight:.2f} N into the table")
            )

    # ----- helpers for backends and outcome --------------------------------
    def set_phase(self, phase: str) -> None:
        self.phase = phase

    def close(self) -> None:
        """End of the trial: nothing to finish (sim/world_api.World)."""

    def true_f_sensor(self, finger: str) -> np.ndarray:
        return self.f_sensor[self.fingers.index(finger)].copy()
