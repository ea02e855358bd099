"""The MuJoCo world: the mock world's interface over a MuJoCo simulation.

Same seam as ``sim/mock/world.py``'s MockWorld (what the trial runner, the backends,
the oracle and the judge read): ``step`` advances one control period, the hand
follows ``q_goal`` through position actuators at the servos' current limits,
the wrist follows ``palm_target`` at the arm's speed (a mocap body the hand is
welded to), and the fingertip contacts that MuJoCo solves feed the same BioTac
forward model (``sim/biotac/model.py``) as the mock world. Outcome flags
(crushed, knocked over) and events (contact, fell) come from MuJoCo's state.

Deterministic per seed: the seed draws the object's placement, yaw, mass,
friction and stiffness and the joints' calibration offsets within the
half-widths of ``params.variation`` (sim/variation.py; ``nominal`` by default,
the command line's default is ``bench``) and the sensors; MuJoCo itself runs
with fixed settings on one thread. The joint offsets are the servos' error:
the hand backends read ``q_measured`` (= q - offset) and command through
``command_goal`` (the joint goes to goal + offset), so the controller never sees
the draw. See docs/mujoco.md.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from grasp_ctrl.config.actuation import torque_limits_nm
from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.numeric.gravity import GRAVITY_M_S2
from grasp_ctrl.numeric.limits import offset_clamp
from grasp_ctrl.sim.biotac.model import BioTacParams, BioTacSensorModel
from grasp_ctrl.sim.mujoco.scene import PlacedObject, SceneParams, build_scene, with_servo_facts
from grasp_ctrl.sim.mujoco.tick_kernel import (
    GEOM_OBJECT,
    NEW_CONTACT,
    SUM_FLAGS,
    SUM_ON_TABLE,
    SUM_OTHER_N,
    SUM_PEAK_OTHER_N,
    SUM_TABLE_N,
    mj_tick_frames,
    mj_tip_buffers,
)
from grasp_ctrl.sim.variation import NOMINAL, Variation, draw_extra, draw_object, draw_record, max_rotated_half_extents
from grasp_ctrl.sim.world_parts import NOISE_BLOCK, WorldEvent, checked_palm_target, in_place_view

FALL_SPEED_M_S = 0.1  # landing on the table faster than this is a drop (placing is slower)
AIRBORNE_M = 0.002  # above this the object has left the table
TIPPED_RAD = math.radians(30.0)  # tipped over while handled
UPRIGHT_RAD = math.radians(10.0)  # standing upright at the end of the trial

_PACK3 = struct.Struct("3d").pack  # three floats' bits: equal bytes = the same position, zeros' signs too


def mocap_step(mocap: Sequence[float], tx: float, ty: float, tz: float, max_move: float) -> tuple[float, float, float]:
    """The wrist's mocap position moved toward the target (tx, ty, tz) by at most
    ``max_move``: ``delta = target - mocap; mocap += delta`` (or ``delta * (max_move / dist)``)
    with ``dist`` from ``vec3.norm3`` (squares summed left to right, the same bits on any
    CPU), on Python floats: a fraction of the cost of five numpy calls per substep."""
    mx, my, mz = mocap
    dx, dy, dz = tx - mx, ty - my, tz - mz
    dist = math.sqrt(0.0 + ((dx * dx + dy * dy) + dz * dz))
    if dist <= max_move:
        return mx + dx, my + dy, mz + dz
    k = max_move / dist
    return mx + dx * k, my + dy * k, mz + dz * k


@dataclass(frozen=True)
class MuJoCoParams:
    scene: SceneParams = field(default_factory=SceneParams)
    # The per-trial draws' half-widths (sim/variation.py); library worlds keep the small nominal ones.
    variation: Variation = NOMINAL
    start_clearance_m: float = 0.05  # the wrist starts this far above the reach pose
    top_clearance_m: float = 0.005  # the hand above the object's top when reaching
    footprint_margin_m: float = 0.008  # hand parts this close to the footprint count as above it
    settle_s: float = 0.2  # the scene settles (object on the table, fingers sag) before t = 0
    biotac: BioTacParams = field(default_factory=BioTacParams)


def _mujoco():
    try:
        import mujoco
    except ImportError:
        from grasp_ctrl.errors import UsageError

        raise UsageError("the MuJoCo world needs mujoco>=3.1, a dependency of grasp-ctrl: pip install -e .") from None
    from grasp_ctrl.sim.mujoco.log import install

    install(mujoco)  # its warnings: the run directory or nowhere, never ./MUJOCO_LOG.TXT
    return mujoco


def _selector(index: np.ndarray) -> slice | np.ndarray:
    """``index`` as a slice when its addresses run in one block (a view, not a copy, to read)."""
    if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
        return slice(int(index[0]), int(index[0]) + index.size)
    return index


class MuJoCoWorld:
    def __init__(self, hand: HandConfig, obj: ObjectProfile, seed: int, params: MuJoCoParams | None = None) -> None:
        mujoco = _mujoco()
        self._mj = mujoco
        self.hand = hand
        self.params = p = params or MuJoCoParams()
        self.rng = rng = np.random.default_rng(seed)
        self.dt = hand.dt
        self.t = 0.0
        self.phase = "idle"
        self.obj = obj
        # The same draws, in the same order, as the mock world; the yaw and the joint
        # offsets from a second stream of the seed (the sensors' noise follows on this one).
        v = p.variation
        drawn = draw_object(rng, v)
        self.mass = obj.mass_kg * (1.0 + drawn.mass_frac)
        self.mu = obj.mu * (1.0 + drawn.friction_frac)
        self.k_contact = obj.stiffness_n_per_m * (1.0 + drawn.stiffness_frac)
        self._weight = self.mass * GRAVITY_M_S2
        self.yaw_rad, self.joint_offset_rad = draw_extra(seed, v, len(hand.joints))
        #: The trial's actual draws (the record's ``variation_draw``); the controller never sees them.
        self.draw = draw_record(drawn, self.yaw_rad, self.joint_offset_rad)
        placed = PlacedObject(obj, drawn.xy_m, self.mass, self.mu, self.k_contact, self.yaw_rad)

        self.fingers = [f.name for f in hand.fingers]
        self.sensor_ids = [f.sensor_id for f in hand.fingers]
        n = len(self.fingers)
        self.grasp_height_m = obj.grasp_height_m  # set by _fit_grasp_height
        self.scene_params = with_servo_facts(p.scene, hand)
        scene = build_scene(hand, placed, np.zeros(3), self.scene_params)
        self.scene = scene
        self.model = m = mujoco.MjModel.from_xml_string(scene.xml)
        self.data = d = mujoco.MjData(m)
        self._substeps = max(1, int(round(self.dt / m.opt.timestep)))
        self._qadr = np.array([m.jnt_qposadr[m.joint(j).id] for j in scene.joint_names])
        self._vadr = np.array([m.jnt_dofadr[m.joint(j).id] for j in scene.joint_names])
        self._act = np.array([m.actuator(j).id for j in scene.joint_names])
        self._sites = np.array([m.site(s).id for s in scene.sensor_sites])
        self._tip_bodies = np.array([m.geom_bodyid[m.geom(g).id] for g in scene.biotac_geoms], dtype=np.int64)
        self._tip_geom_of = np.full(m.ngeom, -1, dtype=np.int64)
        for i, g in enumerate(scene.biotac_geoms):
            self._tip_geom_of[m.geom(g).id] = i
        self._object_geom = np.zeros(m.ngeom, dtype=bool)
        for g in scene.object_geoms:
            self._object_geom[m.geom(g).id] = True
        self._table = m.geom("table").id
        self._obj_body = m.body(scene.object_body).id
        self._hand_body = m.body(scene.hand_body).id
        self._mocap = m.body_mocapid[m.body(scene.mocap_body).id]
        # Views of MjData's arrays of fixed size (MuJoCo never moves them), made once rather
        # than each tick; data.contact and data.efc_force change size and are read each tick.
        self._opt = m.opt
        self._no_actuation = int(mujoco.mjtDisableBit.mjDSBL_ACTUATION)
        self._actuation_off = bool(m.opt.disableflags & self._no_actuation)  # as step last set it
        self._ctrl = d.ctrl
        self._qpos = d.qpos
        self._actuator_force = d.actuator_force
        # the hand's joints in those arrays (one block each in the scenes build_scene makes)
        self._q_sel, self._v_sel, self._a_sel = _selector(self._qadr), _selector(self._vadr), _selector(self._act)
        self._mocap_pos = d.mocap_pos[self._mocap]
        self._qvel = d.qvel
        self._site_xmat = d.site_xmat
        self._site_xpos = d.site_xpos
        self._xpos = d.xpos
        self._xipos = d.xipos
        self._cvel = d.cvel
        self._subtree_com = d.subtree_com
        self._body_rootid = m.body_rootid
        self._obj_xpos = d.xpos[self._obj_body]
        self._palm_xpos = d.xpos[self._hand_body]
        self._obj_xmat = d.xmat[self._obj_body]
        # mj_tick_frames's geom kinds and ids (sim/mujoco/tick_kernel.py)
        self._geom_kind = np.where(self._object_geom, GEOM_OBJECT, self._tip_geom_of)
        self._ids = np.array([self._table, self._obj_body, *self._sites, *self._tip_bodies], dtype=np.int64)
        hand_free = m.joint("hand_free")
        self._hand_qadr = m.jnt_qposadr[hand_free.id]
        obj_free = m.joint("object_free")
        self._obj_qadr = m.jnt_qposadr[obj_free.id]
        self._obj_vadr = m.jnt_dofadr[obj_free.id]

        joints = hand.joints
        self.lower = np.array([j.lower_rad for j in joints])
        self.upper = np.array([j.upper_rad for j in joints])
        self._q_goal = np.array([j.open_rad for j in joints])
        self._q_goal_cmd = self._q_goal - self.joint_offset_rad  # the servos' goal, calibrated angles
        # N m/A of the current the servos report (with_servo_facts); None: the hand reports none
        self.torque_per_amp_nm = self.scene_params.torque_per_amp_nm
        self.tau_max = torque_limits_nm(hand, self.scene_params.torque_per_amp_nm)
        self.torque_on = True
        self.arm_speed = hand.arm.max_speed_m_s
        self._fit_grasp_height()
        start = self.reach_pose_world() + np.array([0.0, 0.0, p.start_clearance_m])
        self._palm_target = start.copy()
        self._place_hand(start)
        self._settle(p.settle_s)
        self._z_rest = self._obj_xpos.item(2)
        self.max_obj_z = 0.0

        self.sensors = BioTacSensorModel(n, rng, p.biotac, noise_block=NOISE_BLOCK)
        # The per-fingertip state, views into the two buffers mj_tick_frames updates.
        self._tip_f, self._tip_b, tip = mj_tip_buffers(n)
        self._f_world = tip["f_world"]
        self._f_sensor = tip["f_sensor"]
        self._normal_n = tip["normal"]
        self._in_contact = tip["touching"]
        self._touch_obj = tip["touching_object"]
        self._slip_speed = tip["slip"]
        self._new_contacts = tip["new_contact"]
        self._contact_sensor = tip["contact"]
        self._skin_normal_sensor = tip["skin_normal"]
        self._skin_normal_sensor[:] = (0.0, 0.0, -1.0)
        self._sums = tip["sums"]
        self._airborne = False
        self._descent_speed = 0.0
        self.seq = 0
        self.events: list[WorldEvent] = []
        self.crushed = False
        self._tipped = False
        self.raw = self._sense()

    # ----- set-up ---------------------------------------------------------
    def _fit_grasp_height(self) -> None:
        """Raise the grasp on tall objects so that no part of the hand above the object's
        footprint (with a margin for the jitter and the closing) reaches into it at the
        postures between pregrasp and open (reaching, releasing); the fingertips themselves
        close beside it. The mock world has no link collisions, so its profiles'
        ``grasp_height_m`` may be lower (docs/mujoco.md). The profile's ``approach_offset_m``
        is added to the result."""
        mj, m, d = self._mj, self.model, self.data
        pre = np.array([j.pregrasp_rad for j in self.hand.joints])
        opened = np.array([j.open_rad for j in self.hand.joints])
        obj = self.obj
        # The footprint as far as the profile's placement and yaw may carry it (not this
        # trial's draw: the grasp height, which the controller is told, must not tell it).
        v = self.params.variation
        half = 0.5 * np.array(obj.size_m)
        if obj.shape != "cylinder" and v.yaw_deg > 0.0:
            half = np.array(max_rotated_half_extents(float(half[0]), float(half[1]), math.radians(v.yaw_deg)))
        reach = half + v.placement_m + self.params.footprint_margin_m
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
        hand_geoms = [g for g in np.flatnonzero(m.geom_contype == 2) if self._tip_geom_of[g] < 0]
        low = 0.0
        for blend in np.linspace(0.0, 1.0, 6):
            d.qpos[self._qadr] = (1.0 - blend) * pre + blend * opened
            d.qpos[self._hand_qadr : self._hand_qadr + 3] = 0.0
            d.qpos[self._hand_qadr + 3 : self._hand_qadr + 7] = (1.0, 0.0, 0.0, 0.0)
            mj.mj_kinematics(m, d)
            for g in hand_geoms:
                R = d.geom_xmat[g].reshape(3, 3)
                pts = d.geom_xpos[g] + (corners * m.geom_aabb[g][3:] + m.geom_aabb[g][:3]) @ R.T
                lo, hi = pts.min(axis=0), pts.max(axis=0)
                # Nearest point of the geom's box to the footprint's centre (the hand frame's origin).
                near = np.clip(np.zeros(2), lo[:2], hi[:2])
                if obj.shape == "cylinder":
                    over = float(np.hypot(*near)) < reach[0]
                else:
                    over = bool(np.all(np.abs(near) < reach))
                if over:
                    low = min(low, float(lo[2]))
        self.hand_over_object_below_palm_m = -low
        needed = obj.height_m + self.params.top_clearance_m - low - self.hand.grasp.palm_above_contact_m
        # A capped object keeps its grasp: the cap finger's height is set relative to it.
        if obj.cap is None and needed > obj.grasp_height_m:
            self.grasp_height_m = min(needed, obj.height_m - 0.005)
        # The object file's approach offset moves the grasp from there (the reach pose by exactly it).
        self.grasp_height_m += obj.approach_offset_m

    def _place_hand(self, palm: np.ndarray) -> None:
        mj, m, d = self._mj, self.model, self.data
        d.qpos[self._qadr] = self._q_goal
        d.qpos[self._hand_qadr : self._hand_qadr + 3] = palm
        d.qpos[self._hand_qadr + 3 : self._hand_qadr + 7] = (1.0, 0.0, 0.0, 0.0)
        d.mocap_pos[self._mocap] = palm
        d.ctrl[self._act] = self._q_goal
        mj.mj_forward(m, d)

    def _settle(self, seconds: float) -> None:
        for _ in range(int(round(seconds / self.model.opt.timestep))):
            self._mj.mj_step(self.model, self.data)

    # ----- state (the MockWorld interface) -----------------------------------
    @property
    def q_goal(self) -> np.ndarray:
        return self._q_goal

    @q_goal.setter
    def q_goal(self, q: np.ndarray) -> None:
        """The joints' true goal (within their limits); the servos' goal follows, less the offsets."""
        self._q_goal = np.clip(np.asarray(q, dtype=float), self.lower, self.upper)
        self._q_goal_cmd = self._q_goal - self.joint_offset_rad

    def command_goal(self, q_measured_goal: np.ndarray) -> None:
        """A goal in the servos' calibrated angles (what a hand backend writes): each joint is
        driven to goal + its offset, within its limits."""
        q = np.array(q_measured_goal, dtype=float)
        if q.shape != self.lower.shape:
            raise ValueError(f"a goal per joint ({self.lower.size}), got shape {q.shape}")
        goal = np.empty(q.shape[0])
        offset_clamp(q, self.joint_offset_rad, self.lower, self.upper, goal)
        self._q_goal = goal
        self._q_goal_cmd = q

    @property
    def q_goal_measured(self) -> np.ndarray:
        """The goal as the servos hold it (calibrated angles): the last ``command_goal``."""
        return self._q_goal_cmd

    @property
    def q(self) -> np.ndarray:
        """The joints' true angles (ground truth; the backends read ``q_measured``)."""
        return self._qpos[self._q_sel].copy()

    @property
    def q_measured(self) -> np.ndarray:
        """What the servos report: the true angles less each joint's calibration offset."""
        return self._qpos[self._q_sel] - self.joint_offset_rad

    @property
    def dq(self) -> np.ndarray:
        return self._qvel[self._v_sel].copy()

    @property
    def joint_torque_nm(self) -> np.ndarray:
        """The actuators' torques (what the servos' current measures)."""
        return self._actuator_force[self._a_sel].copy()

    @property
    def joint_current_a(self) -> np.ndarray:
        """The servos' present current (A): the actuators' torques over the torque constant; NaN
        on a hand whose joints report no current (a torque-controlled hand)."""
        if self.torque_per_amp_nm is None:
            return np.full(len(self._act), np.nan)
        return self._actuator_force[self._a_sel] / self.torque_per_amp_nm  # (a new array)

    @property
    def palm_world(self) -> np.ndarray:
        return self._palm_xpos.copy()

    @property
    def palm_target(self) -> np.ndarray:
        return self._palm_target

    @palm_target.setter
    def palm_target(self, p: np.ndarray) -> None:
        self._palm_target = checked_palm_target(p)

    normal_n = in_place_view("_normal_n", "normal force of the object on each fingertip (N)")
    in_contact = in_place_view("_in_contact", "whether each fingertip touches the object")
    slip_speed = in_place_view("_slip_speed", "slip speed of each contact (m/s)")
    f_world = in_place_view("_f_world", "force ON each sensor skin, world frame (N)")
    f_sensor = in_place_view("_f_sensor", "force ON each sensor skin, sensor frame (N)")
    contact_sensor = in_place_view("_contact_sensor", "where each fingertip touches, sensor frame (m)")
    skin_normal_sensor = in_place_view("_skin_normal_sensor", "outward skin normal there, sensor frame")

    @property
    def obj_xy(self) -> np.ndarray:
        return self._obj_xpos[:2].copy()

    @property
    def obj_z(self) -> float:
        """Height of the object above its resting pose on the table (m)."""
        return max(0.0, self._obj_xpos.item(2) - self._z_rest)

    @property
    def obj_tilt_rad(self) -> float:
        zz = self._obj_xmat.item(8)
        return math.acos(min(max(zz, -1.0), 1.0))

    @property
    def table_n(self) -> float:
        return self._sums.item(SUM_TABLE_N)

    @property
    def other_hand_contact_n(self) -> float:
        """Normal force of hand links other than the fingertips on the object (N)."""
        return self._sums.item(SUM_OTHER_N)

    @property
    def peak_other_hand_contact_n(self) -> float:
        return self._sums.item(SUM_PEAK_OTHER_N)

    def reach_pose_world(self) -> np.ndarray:
        """Nominal wrist position for grasping (the controller does not see the jitter)."""
        return np.array([0.0, 0.0, self.grasp_height_m + self.hand.grasp.palm_above_contact_m])

    def sensor_pose(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Fingertip i's sensor frame in the world (rotation, origin)."""
        s = self._sites[i]
        return self.data.site_xmat[s].reshape(3, 3).copy(), self.data.site_xpos[s].copy()

    # ----- stepping -------------------------------------------------------
    def step(self) -> None:
        mj, m, d = self._mj, self.model, self.data
        self.t += self.dt
        opt = self._opt
        if self.torque_on == self._actuation_off:  # switched since the last step: MuJoCo's flag follows
            self._actuation_off = not self.torque_on
            if self.torque_on:
                opt.disableflags &= ~self._no_actuation
            else:
                opt.disableflags |= self._no_actuation
        self._ctrl[self._a_sel] = self._q_goal
        # The substeps, the wrist's mocap moved toward the palm target before each (mocap_step;
        # MuJoCo's step leaves the mocap where it is): the moving substeps one call each, the
        # rest, with the mocap at its target, in one call (nstep), so that little Python runs
        # between MuJoCo's steps.
        step = mj.mj_step  # through self._mj: the bench's recorder notes each step's inputs
        mocap = self._mocap_pos
        tx, ty, tz = self._palm_target.tolist()
        max_move = self.arm_speed * opt.timestep
        p = mocap.tolist()
        pack = _PACK3
        moved = 0
        while moved < self._substeps:
            q = mocap_step(p, tx, ty, tz, max_move)
            if pack(*q) == pack(*p):
                break  # at the target, bit for bit: every later substep would write the same
            mocap[:] = p = q
            step(m, d)
            moved += 1
        if moved < self._substeps:
            step(m, d, self._substeps - moved)
        self.raw = self._sense()
        self._record()

    def _sense(self) -> np.ndarray:
        """This step's contacts -> the sensors' inputs (sensor frame) -> their raw frames."""
        # One kernel (sim/mujoco/tick_kernel.py) for what the reference reading's read_contacts and
        # skin_point_and_normal define and the BioTac model's frames: calls cost most here.
        d = self.data
        con = d.contact
        sensors = self.sensors
        noisy_base = sensors.advance(self.dt)
        # Contiguous: MuJoCo's view of two or more contacts is strided, of fewer it is not, and
        # numba compiles a kernel per layout; one layout, so no trial meets a second compile.
        asc = np.ascontiguousarray
        frames = mj_tick_frames(
            asc(con.geom),
            asc(con.efc_address),
            asc(con.frame),
            asc(con.pos),
            d.efc_force,
            self._geom_kind,
            self._ids,
            self._body_rootid,
            self._site_xmat,
            self._site_xpos,
            self._cvel,
            self._xipos,
            self._subtree_com,
            self._xpos,
            self._tip_f,
            self._tip_b,
            noisy_base,
            sensors.state,
            sensors.gain,
            sensors.consts,
            sensors.t,
            self.dt,
        )
        self.seq = (self.seq + 1) & 0xFFFF
        return frames

    def _record(self) -> None:
        """Events and outcome flags from MuJoCo's state."""
        z = max(0.0, self._obj_xpos.item(2) - self._z_rest)  # obj_z
        if z > self.max_obj_z:
            self.max_obj_z = z
        if int(self._sums.item(SUM_FLAGS)) & NEW_CONTACT:
            for i in np.flatnonzero(self._new_contacts):
                self.events.append(WorldEvent(self.t, "contact", self.fingers[i]))
        if z > AIRBORNE_M:
            self._airborne = True
            self._descent_speed = max(-self._qvel.item(self._obj_vadr + 2), 0.0)
        elif self._airborne and self._sums.item(SUM_ON_TABLE) > 0.0:
            # Back on the table: a drop if it came down faster than any placing does.
            self._airborne = False
            if self._descent_speed > FALL_SPEED_M_S:
                self.events.append(
                    WorldEvent(self.t, "fell", f"landed at {self._descent_speed:.2f} m/s while {self.phase}")
                )
        obj = self.obj
        if obj.deformable and obj.crush_force_n is not None and not self.crushed:
            worst = float(self._normal_n.max(initial=0.0))
            if worst > obj.crush_force_n:
                self.crushed = True
                self.events.append(WorldEvent(self.t, "crushed", f"grip {worst:.2f} N > {obj.crush_force_n} N"))
        # Knocked over: MuJoCo simulates the tipping itself (the mock world's push-into-the-table
        # proxy is not needed); placed upright is checked again at the end (``knocked_over``).
        if not self._tipped:
            tilt = math.acos(min(max(self._obj_xmat.item(8), -1.0), 1.0))  # obj_tilt_rad
            if tilt > TIPPED_RAD:
                self._tipped = True
                self.events.append(WorldEvent(self.t, "knocked_over", f"tilted {math.degrees(tilt):.0f} degrees"))

    @property
    def knocked_over(self) -> bool:
        """Tipped past TIPPED_RAD at some point, or not standing upright (within UPRIGHT_RAD) now."""
        return self._tipped or self.obj_tilt_rad > UPRIGHT_RAD

    # ----- helpers for backends and outcome --------------------------------
    def set_phase(self, phase: str) -> None:
        self.phase = phase

    def close(self) -> object:
        """End of the trial (the recording world writes its video here)."""
        return None

    def true_f_sensor(self, finger: str) -> np.ndarray:
        return self._f_sensor[self.fingers.index(finger)].copy()

    def skin_contacts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """What the BioTac model was given this step, per fingertip (copies, sensor frame):
        contact point on the skin (m), the skin's outward normal there, the force ON the
        skin (N) and whether the fingertip touches the object."""
        return (
            self._contact_sensor.copy(),
            self._skin_normal_sensor.copy(),
            self._f_sensor.copy(),
            self._touch_obj.copy(),
        )
