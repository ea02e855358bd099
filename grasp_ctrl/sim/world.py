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
  ``k * penetration`` with the object's stiffness; vertical friction through a
  stick-slip spring capped by ``mu * N`` (grip.py); the table only pushes up.
- Outcomes: crushing (deformable objects, grip above crush force), knocking
  over (push into the table above ``tip_force_n``), slipping and dropping are
  recorded as events from the simulated truth.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.kinematics.batched import BatchedKinematics
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.sim.biotac_model import BioTacParams, BioTacSensorModel
from grasp_ctrl.sim.grip import solve_object_height, tangential_forces
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR, contact_on_skin

GRAVITY = 9.81
NEAR_M = 0.01   # fingertips further than this from the object cannot touch it this step


@dataclass(frozen=True)
class WorldParams:
    servo_time_constant_s: float = 0.03
    servo_stiffness_nm_per_rad: float = 10.0
    servo_max_speed_rad_s: float = 6.0
    torque_per_amp_nm: float = 0.5
    tangential_stiffness_n_per_m: float = 400.0
    placement_jitter_m: float = 0.003
    mass_jitter: float = 0.03
    friction_jitter: float = 0.03
    stiffness_jitter: float = 0.05
    start_clearance_m: float = 0.05      # palm starts this far above the reach pose
    # Contact on the skin point facing the object (cap or pad) instead of the pad centre.
    # More faithful, but the shipped policies cannot yet detect placement with it: off.
    skin_contact: bool = False
    biotac: BioTacParams = field(default_factory=BioTacParams)


@dataclass
class WorldEvent:
    t: float
    kind: str     # crushed | knocked_over | fell | lifted | contact | released
    detail: str = ""


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
        self.kin = HandKinematics(hand)
        self.bkin = BatchedKinematics(self.kin)
        self.dt = hand.dt
        self.t = 0.0
        self.phase = "idle"

        # Object, randomised within a few percent / millimetres.
        self.obj = obj
        rng = self.rng
        self.obj_xy = rng.uniform(-p.placement_jitter_m, p.placement_jitter_m, size=2)
        self.mass = obj.mass_kg * (1.0 + p.mass_jitter * rng.uniform(-1, 1))
        self.mu = obj.mu * (1.0 + p.friction_jitter * rng.uniform(-1, 1))
        self.k_contact = obj.stiffness_n_per_m * (1.0 + p.stiffness_jitter * rng.uniform(-1, 1))
        self.obj_z = 0.0
        self.table_n = self.mass * GRAVITY
        self.max_obj_z = 0.0

        # Hand and arm.
        joints = hand.joints
        self.lower = np.array([j.lower_rad for j in joints])
        self.upper = np.array([j.upper_rad for j in joints])
        self.q_goal = np.array([j.open_rad for j in joints])
        self.q_servo = self.q_goal.copy()          # the servo's internal (lagged) position
        self.q = self.q_goal.copy()                # actual, after contact deflection
        self.torque_on = True
        self.tau_max = np.array([j.current_limit_a for j in joints]) * p.torque_per_amp_nm
        self.palm_world = self.reach_pose_world() + np.array([0.0, 0.0, p.start_clearance_m])
        self.palm_target = self.palm_world.copy()
        self.arm_speed = hand.arm.max_speed_m_s

        # Fingertips and sensors (in hand-file finger order).
        self.fingers = [f.name for f in hand.fingers]
        self.sensor_ids = [f.sensor_id for f in hand.fingers]
        n = len(self.fingers)
        self.normal_n = np.zeros(n)
        self.tangential_up_n = np.zeros(n)   # upward force of each finger on the object
        self.in_contact = np.zeros(n, dtype=bool)
        self.stick_offset = np.zeros(n)       # finger height minus object height at stick
        self.slip_speed = np.zeros(n)
        self.f_world = np.zeros((n, 3))       # force ON each sensor skin, world frame
        self.f_sensor = np.zeros((n, 3))
        self.n_out_world = np.zeros((n, 3))
        self.sensors = BioTacSensorModel(n, self.rng, p.biotac)
        self.seq = 0
        self.contact_sensor = np.tile(PAD_POINT_SENSOR, (n, 1))       # where each fingertip touches
        self.skin_normal_sensor = np.tile(PAD_NORMAL_SENSOR, (n, 1))  # outward skin normal there
        self._pad_heights()
        self.raw = self._sense()

        self.events: list[WorldEvent] = []
        self.crushed = False
        self.knocked_over = False

    # ----- geometry -------------------------------------------------------
    def reach_pose_world(self) -> np.ndarray:
        """Nominal palm position for grasping (the controller does not see the jitter)."""
        return np.array([0.0, 0.0, self.obj.grasp_height_m + self.hand.grasp.palm_above_contact_m])

    def _penetration(self, p_world: np.ndarray) -> tuple[float, np.ndarray]:
        """Penetration depth of a point into the object (<= 0 outside) and the
        outward surface normal there (horizontal)."""
        z_rel = p_world[2] - self.obj_z
        if z_rel < 0.0 or z_rel > self.obj.height_m:
            return -1.0, np.zeros(3)
        dx = p_world[0] - self.obj_xy[0]
        dy = p_world[1] - self.obj_xy[1]
        if self.obj.shape == "cylinder":
            r = float(np.hypot(dx, dy))
            if r < 1e-9:
                return self.obj.half_width_m, np.array([1.0, 0.0, 0.0])
            return self.obj.half_width_m - r, np.array([dx / r, dy / r, 0.0])
        hx, hy = 0.5 * self.obj.size_m[0], 0.5 * self.obj.size_m[1]
        px, py = hx - abs(dx), hy - abs(dy)
        if px <= py:
            return px, np.array([np.sign(dx) or 1.0, 0.0, 0.0])
        return py, np.array([0.0, np.sign(dy) or 1.0, 0.0])

    # ----- stepping -------------------------------------------------------
    def step(self) -> None:
        p = self.params
        dt = self.dt
        self.t += dt
        # Arm: straight line toward the target at the speed limit.
        delta = self.palm_target - self.palm_world
        dist = float(np.linalg.norm(delta))
        max_step = self.arm_speed * dt
        self.palm_world = self.palm_target.copy() if dist <= max_step else self.palm_world + delta * (max_step / dist)

        # Servos: first-order lag toward the goal, speed limited; no torque = limp (stays).
        if self.torque_on:
            alpha = 1.0 - np.exp(-dt / p.servo_time_constant_s)
            step = np.clip(alpha * (self.q_goal - self.q_servo), -p.servo_max_speed_rad_s * dt, p.servo_max_speed_rad_s * dt)
            # The servo's internal position cannot run away from the actual one further than
            # the current limit allows (current-based position mode).
            reach = self.tau_max / p.servo_stiffness_nm_per_rad
            self.q_servo = np.clip(self.q_servo + step, self.q - reach, self.q + reach)
        else:
            self.q_servo = self.q.copy()
        self.q_servo = np.clip(self.q_servo, self.lower, self.upper)

        self._contacts()
        self._object()
        self.raw = self._sense()
        self._judge()

    def _contacts(self) -> None:
        p = self.params
        kp = p.servo_stiffness_nm_per_rad
        kt = p.tangential_stiffness_n_per_m
        q = self.q_servo.copy()
        # Where does each fingertip touch? By default on the pad centre; with skin_contact,
        # at the skin point facing the object's surface there (contact_on_skin).
        if p.skin_contact:
            pads_hand, _, R_sensor = self.bkin.points_and_jacobians(self.q_servo, PAD_POINT_SENSOR)
            for i in range(len(self.fingers)):
                d_pad, n_out = self._penetration(self.palm_world + pads_hand[i])
                if d_pad > -NEAR_M:
                    self.contact_sensor[i], self.skin_normal_sensor[i] = contact_on_skin(R_sensor[i].T @ -n_out)
        points_hand, jacobians, _ = self.bkin.points_and_jacobians(self.q_servo, self.contact_sensor)
        for i, name in enumerate(self.fingers):
            d0, n_out = self._penetration(self.palm_world + points_hand[i])
            was = self.in_contact[i]
            if d0 <= 0.0:
                self.normal_n[i] = 0.0
                self.in_contact[i] = False
                continue
            sl = self.kin.slices[name]
            J = jacobians[i]
            a = J.T @ (-n_out)   # d(penetration)/dq
            k = self.k_contact
            pad_z = self.palm_world[2] + points_hand[i][2]
            # Vertical stick spring of a contact that already sticks: it resists the pad
            # sliding up or down the object while the finger deflects.
            stretch = pad_z - self.stick_offset[i] - self.obj_z if was else 0.0
            sticking = was and abs(kt * stretch) < self.mu * self.normal_n[i]
            if not self.torque_on or float(a @ a) < 1e-12:
                # A limp finger yields completely: no squeeze force.
                q[sl] = self.q_servo[sl] + self._retract(a, d0)
                normal = 0.0
            else:
                # Servo spring (kp per joint) in series with the contact springs: the
                # minimiser of 0.5*kp*|dq|^2 + 0.5*k*(d0 + a.dq)^2 + 0.5*kt*(s0 + b.dq)^2.
                if sticking:
                    b = J[2]
                    g11, g12, g22 = float(a @ a), float(a @ b), float(b @ b)
                    # (kp I + D G) y = D r, 2x2, solved in closed form.
                    m11, m12, m21, m22 = kp + k * g11, k * g12, kt * g12, kp + kt * g22
                    det = m11 * m22 - m12 * m21
                    r1, r2 = k * d0, kt * stretch
                    y1 = (m22 * r1 - m12 * r2) / det
                    y2 = (m11 * r2 - m21 * r1) / det
                    dq = -(a * y1 + b * y2)
                else:
                    dq = -a * (k * d0 / (kp + k * float(a @ a)))
                d = d0 + float(a @ dq)
                normal = k * d
                over = normal * np.abs(a) / np.maximum(self.tau_max[sl], 1e-9)
                if over.max() > 1.0:           # current limit: the servo yields
                    normal /= over.max()
                    dq = self._retract(a, d0 - normal / k)
                q[sl] = self.q_servo[sl] + dq
            self.normal_n[i] = normal
            self.n_out_world[i] = n_out
            self.in_contact[i] = normal > 1e-6
            if self.in_contact[i] and not was:
                self.stick_offset[i] = pad_z - self.obj_z
                self.events.append(WorldEvent(self.t, "contact", name))
        self.q = np.clip(q, self.lower, self.upper)
        self._pad_heights()

    @staticmethod
    def _retract(a: np.ndarray, depth: float) -> np.ndarray:
        """Smallest joint motion that backs a fingertip out of the object by ``depth``."""
        a2 = float(a @ a)
        return -(depth / a2) * a if a2 > 1e-12 else np.zeros_like(a)

    def _pad_heights(self) -> None:
        """Sensor orientations and contact-point heights at the actual (deflected) joint angles."""
        R, p = self.bkin.sensor_frames(self.q)
        self._R_sensor = R
        self._pad_z = self.palm_world[2] + ((R @ self.contact_sensor[..., None])[..., 0] + p)[:, 2]

    def _object(self) -> None:
        kt = self.params.tangential_stiffness_n_per_m
        capacity = np.where(self.in_contact, self.mu * self.normal_n, 0.0)
        anchors = self._pad_z - self.stick_offset
        weight = self.mass * GRAVITY
        z, table_n = solve_object_height(anchors, capacity, kt, weight)
        t_up, slipping = tangential_forces(anchors, capacity, kt, z)
        # Slipping contacts drag their anchor: the spring stays at the friction limit.
        new_offset = np.where(slipping & self.in_contact, self._pad_z - (z + t_up / kt), self.stick_offset)
        self.slip_speed = np.abs(new_offset - self.stick_offset) / self.dt
        self.stick_offset = new_offset
        prev_z = self.obj_z
        self.obj_z = z
        self.table_n = table_n
        self.tangential_up_n = np.where(self.in_contact, t_up, 0.0)
        self.max_obj_z = max(self.max_obj_z, z)
        if prev_z > 0.002 and z == 0.0:
            self.events.append(WorldEvent(self.t, "fell", f"from {prev_z * 1000:.1f} mm while {self.phase}"))
        # Force ON each fingertip skin: the object pushes the pad outward and drags it
        # opposite to the finger's upward force on the object.
        self.f_world = self.normal_n[:, None] * self.n_out_world
        self.f_world[:, 2] -= self.tangential_up_n

    def _sense(self) -> np.ndarray:
        n = len(self.fingers)
        f_sensor = np.zeros((n, 3))
        for i in range(n):
            if self.in_contact[i]:
                f_sensor[i] = self._R_sensor[i].T @ self.f_world[i]
        self.f_sensor = f_sensor
        p_contact = self.contact_sensor
        n_out = self.skin_normal_sensor
        self.seq = (self.seq + 1) & 0xFFFF
        return self.sensors.frames(p_contact, f_sensor, n_out, self.in_contact.copy(), self.slip_speed, self.dt)

    def _judge(self) -> None:
        if self.obj.deformable and not self.crushed:
            assert self.obj.crush_force_n is not None
            worst = float(self.normal_n.max())
            if worst > self.obj.crush_force_n:
                self.crushed = True
                self.events.append(WorldEvent(self.t, "crushed", f"grip {worst:.2f} N > {self.obj.crush_force_n} N"))
        if not self.knocked_over:
            push = self.table_n - self.mass * GRAVITY
            if push > self.obj.tip_force_n:
                self.knocked_over = True
                self.events.append(WorldEvent(self.t, "knocked_over", f"pushed {push:.2f} N into the table"))

    # ----- helpers for backends and outcome --------------------------------
    def set_phase(self, phase: str) -> None:
        self.phase = phase

    def true_f_sensor(self, finger: str) -> np.ndarray:
        return self.f_sensor[self.fingers.index(finger)].copy()
