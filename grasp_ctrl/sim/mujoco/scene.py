"""The MuJoCo scene of a trial, generated from the hand file and one object profile.

Scene (MJCF text, documented in docs/mujoco.md):
- a table (a plane at z = 0);
- the hand: a free body welded to a mocap body (the arm), holding the palm and
  one serial chain per finger built joint by joint from the hand file (joint
  origins, axes and limits); each link carries the collision boxes of the hand
  file's ``[collision]`` table (the LEAP's and the Allegro's: MuJoCo Menagerie's
  numbers) or, where it lists none, a capsule between its joint origins; the last link carries the
  BioTac: a capsule of the sensor model's skin radius ending in the tip's cap,
  and a site at the sensor frame;
- position actuators per joint with the hand's PD gains in SI and a force range of
  its torque limit (config/actuation.py: a servo's current limit x its torque per
  amp, or a torque-controlled joint's limit);
- the object: one rigid body with a free joint (cylinder or box, the mustard
  bottle's dome as a sphere cut by the body), its mass, size and friction from
  the profile; deformable objects have a softer contact.

The hand does not collide with itself (contype/conaffinity), only with the
object and the table. Friction of a hand-object contact is the object's
(geom priority), of anything on the table the table's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

# The joints' PD gains, torque limits and damping in SI, shared with the controller and the statics.
from grasp_ctrl.config.actuation import (
    armature_kg_m2,
    hand_servo,
    passive_damping_nm_s_per_rad,
    pd_gains,
    torque_limits_nm,
)
from grasp_ctrl.config.hand import CollisionBox, FingerConfig, HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.kinematics.fingertip import PAD_X_MIN_M, SKIN_RADIUS_M
from grasp_ctrl.kinematics.transforms import rpy_matrix
from grasp_ctrl.numeric.gravity import GRAVITY_M_S2


@dataclass(frozen=True)
class SceneParams:
    timestep_s: float = 0.002
    # Friction (tests/sim/test_mujoco_friction.py): with elliptic cones and impratio 10 a grip holds
    # or slips at Coulomb's limit (mu N), with a creep of about 0.6 mm/s inside the cone (MuJoCo's
    # soft friction). The noslip post-processor removes the creep but costs 40 % of mj_step and
    # does not change which objects are lifted (docs/mujoco.md).
    impratio: float = 10.0
    noslip_iterations: int = 0
    # None: the hand file's servo model's (config/servos.py; XC330-M288-T: 0.93 N m / 1.8 A = 0.517)
    torque_per_amp_nm: float | None = None
    # The gears' reflected rotor inertia (estimate: ~5e-8 kg m^2 rotor x 288^2) and the motor's
    # back-EMF damping under voltage (PWM) drive: stall torque / no-load speed (None: the hand
    # file's servo model's).
    armature_kg_m2: float = 0.004
    joint_damping_nm_s_per_rad: float | None = None
    joint_frictionloss_nm: float = 0.001  # Menagerie's LEAP value
    default_p_gain: float = 600.0  # when the hand file keeps the servos' own gains
    default_d_gain: float = 200.0
    table_mu: float = 0.5
    # Contact softness: MuJoCo's time constant for the stiffest object (lego, 4000 N/m);
    # softer objects get sqrt(4000 / stiffness) times it (a spring-mass time constant).
    contact_timeconst_s: float = 0.004
    reference_stiffness_n_per_m: float = 4000.0
    torsion_radius_m: float = 0.003  # torsional friction = mu x this (pad contact patch)
    hand_root_mass_kg: float = 0.05
    # A hand file without [inertia] masses (the LEAP's: Menagerie's palm, a round figure for the links)
    palm_mass_kg: float = 0.237
    link_mass_kg: float = 0.035
    biotac_mass_kg: float = 0.02
    weld_timeconst_s: float = 0.01  # the arm's grip on the wrist


@dataclass(frozen=True)
class PlacedObject:
    """The object as this trial draws it (randomised around the profile)."""

    profile: ObjectProfile
    xy_m: tuple[float, float]
    mass_kg: float
    mu: float
    stiffness_n_per_m: float
    yaw_rad: float = 0.0  # turned about the vertical through its footprint's centre


@dataclass
class Scene:
    xml: str
    finger_names: list[str]
    joint_names: list[str]
    biotac_geoms: list[str]
    sensor_sites: list[str]
    object_geoms: list[str]
    object_body: str = "object"
    hand_body: str = "hand"
    mocap_body: str = "wrist"
    upper_link_bodies: list[str] = field(default_factory=list)  # palm and first links (clear the object's top)


LINK_CAPSULE_RADIUS_M = 0.008  # a link whose shape the hand file does not give

# The hand: collides with the object and table, not with itself.
HAND_COLLISION = 'contype="2" conaffinity="1"'
WORLD_COLLISION = 'contype="1" conaffinity="3"'


def _f(values: tuple[float, ...] | list[float] | np.ndarray) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def quat_of_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    import mujoco

    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).reshape(9))
    return q


def quat_of_rpy(rpy: tuple[float, float, float]) -> np.ndarray:
    return quat_of_matrix(rpy_matrix(rpy))


def _box_geoms(boxes: tuple[CollisionBox, ...], name: str, extra: str) -> list[str]:
    out = []
    for k, box in enumerate(boxes):
        q = f' quat="{_f(box.quat)}"' if box.quat is not None else ""
        out.append(f'<geom name="{name}_{k}" type="box" size="{_f(box.half_m)}" pos="{_f(box.pos_m)}"{q} {extra}/>')
    return out


def _link_geoms(finger: FingerConfig, k: int, hand: HandConfig, extra: str) -> list[str]:
    """The link joint ``k`` moves: the hand file's boxes, else a capsule from this joint to the
    next one (the last link: to the sensor's mount)."""
    name = f"{finger.joints[k].name}_link"
    boxes = hand.boxes_of(finger.joints[k].name)
    if boxes is not None:
        return _box_geoms(boxes, name, extra)
    end = finger.joints[k + 1].origin_xyz if k + 1 < len(finger.joints) else finger.tip_xyz
    if np.linalg.norm(end) < 1e-6:
        return []
    return [f'<geom name="{name}" type="capsule" size="{LINK_CAPSULE_RADIUS_M}" fromto="0 0 0 {_f(end)}" {extra}/>']


def _mass(from_hand: float | None, default: float) -> float:
    return from_hand if from_hand is not None else default


def _biotac(finger: FingerConfig, p: SceneParams) -> tuple[str, str, str]:
    """The sensor body on the last link: the skin capsule (radius of the sensor model, from
    its mount to the tip's cap centred on the sensor origin) and the sensor-frame site."""
    geom = f"{finger.name}_biotac"
    site = f"{finger.name}_sensor"
    back = PAD_X_MIN_M - SKIN_RADIUS_M  # the skin cylinder runs back past the pad's far edge to the mount
    xml = (
        f'<body name="{finger.name}_tip" pos="{_f(finger.tip_xyz)}" quat="{_f(quat_of_rpy(finger.tip_rpy))}">'
        f'<inertial pos="{_f((0.5 * back, 0.0, 0.0))}" mass="{p.biotac_mass_kg}" diaginertia="1e-6 2e-6 2e-6"/>'
        f'<geom name="{geom}" type="capsule" size="{SKIN_RADIUS_M}" fromto="{_f((back, 0, 0))} 0 0 0" '
        f'{HAND_COLLISION} friction="0.5 0.001 0.0001" condim="4" rgba="0.85 0.7 0.45 1"/>'
        f'<site name="{site}" pos="0 0 0" size="0.002" rgba="1 0 0 1"/>'
        f"</body>"
    )
    return xml, geom, site


def _finger(finger: FingerConfig, hand: HandConfig, p: SceneParams) -> tuple[str, str, str, str]:
    """Nested bodies of one chain, the BioTac at its end; returns (xml, biotac geom, site, first body)."""
    extra = f'{HAND_COLLISION} rgba="0.25 0.25 0.25 1"'
    opened, closes = [], []
    for k, j in enumerate(finger.joints):
        opened.append(
            f'<body name="{j.name}" pos="{_f(j.origin_xyz)}" quat="{_f(quat_of_rpy(j.origin_rpy))}">'
            f'<inertial pos="0 0 0" mass="{_mass(hand.link_mass_kg, p.link_mass_kg)}" diaginertia="5e-6 5e-6 5e-6"/>'
            f'<joint name="{j.name}" type="hinge" axis="{_f(j.axis)}" range="{j.lower_rad:.9g} {j.upper_rad:.9g}" '
            f'limited="true" armature="{p.armature_kg_m2}" damping="{p.joint_damping_nm_s_per_rad:.6g}" '
            f'frictionloss="{p.joint_frictionloss_nm}"/>' + "".join(_link_geoms(finger, k, hand, extra))
        )
        closes.append("</body>")
    tip_xml, geom, site = _biotac(finger, p)
    return "".join(opened) + tip_xml + "".join(closes), geom, site, finger.joints[0].name


def _actuators(hand: HandConfig, p: SceneParams) -> str:
    gains = pd_gains(hand, p.default_p_gain, p.default_d_gain)
    assert gains.kp_nm_per_rad is not None and gains.kv_nm_s_per_rad is not None, gains.reason
    limits = torque_limits_nm(hand, p.torque_per_amp_nm)
    rows = []
    for j, kp, kv, tau in zip(hand.joints, gains.kp_nm_per_rad, gains.kv_nm_s_per_rad, limits):
        rows.append(
            f'<position name="{j.name}" joint="{j.name}" kp="{kp:.6g}" kv="{kv:.6g}" '
            f'ctrlrange="{j.lower_rad:.9g} {j.upper_rad:.9g}" ctrllimited="true" '
            f'forcerange="{-tau:.6g} {tau:.6g}" forcelimited="true"/>'
        )
    return "<actuator>" + "".join(rows) + "</actuator>"


def contact_timeconst(stiffness_n_per_m: float, p: SceneParams) -> float:
    """Softer objects touch with a longer time constant (never below two time steps)."""
    t = p.contact_timeconst_s * math.sqrt(p.reference_stiffness_n_per_m / max(stiffness_n_per_m, 1.0))
    return max(t, 2.0 * p.timestep_s)


def object_contact_attrs(mu: float, stiffness_n_per_m: float, p: SceneParams) -> str:
    """The object geoms' contact attributes: its friction wins over the fingertip's (priority),
    torsional friction over the pad's patch, the softness of its stiffness."""
    tc = contact_timeconst(stiffness_n_per_m, p)
    return f'priority="1" condim="4" friction="{mu:.6g} {mu * p.torsion_radius_m:.6g} 0" solref="{tc:.6g} 1"'


def option_xml(p: SceneParams) -> str:
    """MuJoCo's solver options of the scene (also the friction test's, tests/sim/test_mujoco_friction.py)."""
    return (
        f'<option timestep="{p.timestep_s}" integrator="implicitfast" cone="elliptic" '
        f'impratio="{p.impratio:g}" noslip_iterations="{p.noslip_iterations}" gravity="0 0 -{GRAVITY_M_S2:g}"/>'
    )


def _object(obj: PlacedObject, p: SceneParams) -> tuple[str, list[str]]:
    """The object's body at its resting pose (frame at the footprint centre, on the table)."""
    prof = obj.profile
    h = prof.height_m
    m = obj.mass_kg
    if prof.shape == "cylinder":
        r = prof.half_width_m
        ixx = m * (3 * r * r + h * h) / 12.0
        inertia = (ixx, ixx, 0.5 * m * r * r)
        body = f'type="cylinder" size="{r:.9g} {0.5 * h:.9g}"'
    else:
        sx, sy = prof.size_m
        inertia = (m * (sy * sy + h * h) / 12.0, m * (sx * sx + h * h) / 12.0, m * (sx * sx + sy * sy) / 12.0)
        body = f'type="box" size="{0.5 * sx:.9g} {0.5 * sy:.9g} {0.5 * h:.9g}"'
    common = f'{WORLD_COLLISION} {object_contact_attrs(obj.mu, obj.stiffness_n_per_m, p)} rgba="0.3 0.55 0.85 1"'
    geoms = [f'<geom name="object_body" {body} pos="0 0 {0.5 * h:.9g}" {common}/>']
    names = ["object_body"]
    if prof.cap is not None:
        r, ch = 0.5 * prof.cap.diameter_m, prof.cap.height_m
        R = (r * r + ch * ch) / (2.0 * ch)
        cz = h + ch - R
        ox, oy = prof.cap.offset_m
        geoms.append(
            f'<geom name="object_cap" type="sphere" size="{R:.9g}" pos="{ox:.9g} {oy:.9g} {cz:.9g}" {common}/>'
        )
        names.append("object_cap")
    # No quat attribute without a yaw: the scene of an unturned object is the same XML as ever.
    yaw = f' quat="{_f((math.cos(0.5 * obj.yaw_rad), 0.0, 0.0, math.sin(0.5 * obj.yaw_rad)))}"' if obj.yaw_rad else ""
    xml = (
        f'<body name="object" pos="{obj.xy_m[0]:.9g} {obj.xy_m[1]:.9g} 0"{yaw}>'
        f'<freejoint name="object_free"/>'
        f'<inertial pos="0 0 {0.5 * h:.9g}" mass="{m:.9g}" diaginertia="{_f(inertia)}"/>' + "".join(geoms) + "</body>"
    )
    return xml, names


def with_servo_facts(p: SceneParams, hand: HandConfig) -> SceneParams:
    """``p`` with the actuation facts it leaves open (None) taken from the hand file
    (config/actuation.py): a Dynamixel hand's torque per amp and back-EMF damping (stall torque /
    no-load speed), a torque-controlled hand's passive damping; its armature where the file gives one."""
    per_amp = p.torque_per_amp_nm
    if per_amp is None and hand.servo_driven:
        per_amp = hand_servo(hand).torque_per_amp_nm
    damping = p.joint_damping_nm_s_per_rad
    if damping is None:
        damping = passive_damping_nm_s_per_rad(hand)
    armature = armature_kg_m2(hand)
    return replace(
        p,
        torque_per_amp_nm=per_amp,
        joint_damping_nm_s_per_rad=damping,
        armature_kg_m2=armature if armature is not None else p.armature_kg_m2,
    )


def build_scene(
    hand: HandConfig, obj: PlacedObject, palm_start_world: np.ndarray, p: SceneParams | None = None
) -> Scene:
    """The MJCF text of one trial's scene, the hand at ``palm_start_world``."""
    p = with_servo_facts(p or SceneParams(), hand)
    extra = f'{HAND_COLLISION} rgba="0.25 0.25 0.25 1"'
    # Fingers that share a base pose share a base body (the LEAP palm: all four).
    bases: dict[tuple, list[int]] = {}
    for i, f in enumerate(hand.fingers):
        bases.setdefault((tuple(f.base_xyz), tuple(f.base_rpy)), []).append(i)
    hand_parts, biotacs, sites, upper = [], [], [], []
    for b, ((xyz, rpy), members) in enumerate(bases.items()):
        inner = []
        if b == 0:
            inner += _box_geoms(hand.palm_boxes, "palm", extra)
        for i in members:
            f = hand.fingers[i]
            xml, geom, site, first = _finger(f, hand, p)
            inner.append(xml)
            biotacs.append((i, geom))
            sites.append((i, site))
            upper.append(first)
        mass = _mass(hand.palm_mass_kg, p.palm_mass_kg) if b == 0 else 0.01
        hand_parts.append(
            f'<body name="palm{b}" pos="{_f(xyz)}" quat="{_f(quat_of_rpy(rpy))}">'
            f'<inertial pos="-0.05 -0.04 -0.01" mass="{mass}" diaginertia="4e-4 3e-4 2e-4"/>'
            + "".join(inner)
            + "</body>"
        )
        upper.append(f"palm{b}")
    obj_xml, obj_geoms = _object(obj, p)
    px, py, pz = (float(v) for v in palm_start_world)
    xml = f"""<mujoco model="grasp_ctrl_{hand.name}_{obj.profile.name}">
<compiler angle="radian" autolimits="true"/>
{option_xml(p)}
<visual><global offwidth="640" offheight="480"/></visual>
<asset><texture name="grid" type="2d" builtin="checker" rgb1="0.55 0.5 0.45" rgb2="0.5 0.45 0.4" width="256" height="256"/>
<material name="table" texture="grid" texrepeat="8 8"/></asset>
<worldbody>
<light pos="0.3 -0.3 0.8" dir="-0.3 0.3 -0.8" diffuse="0.8 0.8 0.8"/>
<geom name="table" type="plane" size="0.5 0.5 0.01" material="table" {WORLD_COLLISION} priority="2" friction="{p.table_mu} 0.001 0.0001"/>
{obj_xml}
<body name="wrist" mocap="true" pos="{px:.9g} {py:.9g} {pz:.9g}"/>
<body name="hand" pos="{px:.9g} {py:.9g} {pz:.9g}">
<freejoint name="hand_free"/>
<inertial pos="0 0 0" mass="{p.hand_root_mass_kg}" diaginertia="1e-4 1e-4 1e-4"/>
{"".join(hand_parts)}
</body>
</worldbody>
<equality><weld name="arm" body1="wrist" body2="hand" solref="{p.weld_timeconst_s} 1"/></equality>
{_actuators(hand, p)}
</mujoco>"""
    order = sorted(biotacs)
    return Scene(
        xml=xml,
        finger_names=[f.name for f in hand.fingers],
        joint_names=[j.name for j in hand.joints],
        biotac_geoms=[g for _, g in order],
        sensor_sites=[s for _, s in sorted(sites)],
        object_geoms=obj_geoms,
        upper_link_bodies=upper,
    )
