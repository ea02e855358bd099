"""Hand configuration: servos, joint limits, kinematics, sensors, arm, grasp.

Loaded from a TOML file under ``hand_configs/`` and validated on load. See
``hand_configs/leap_hand.toml`` for a documented example of every key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from grasp_ctrl.config.identifiers import check_identifier
from grasp_ctrl.config.sensor_layout import LAYOUTS, SensorLayout, layout_for
from grasp_ctrl.config.servos import MODELS as SERVO_MODELS
from grasp_ctrl.config.servos import ServoModel
from grasp_ctrl.config.toml_reader import Table, read_toml

Vec3 = tuple[float, float, float]

SAFE_ACTIONS = ("hold", "open", "torque_off")
ACTUATOR_KINDS = ("dynamixel", "torque_pd")
TORQUE_PD_KEYS = ("kp_nm_per_rad", "kd_nm_s_per_rad", "torque_limit_nm")  # each joint's, actuator = "torque_pd"
DYNAMIXEL_JOINT_KEYS = ("current_limit_a", "gain_scale")  # each joint's, actuator = "dynamixel"
CAN_INTERFACES = ("socketcan", "pcan", "virtual")
# [torque_pd]'s optional keys of the CAN link (hardware/allegro/)
CAN_KEYS = ("bitrate", "can_device_id", "pwm_per_nm", "pwm_limit", "position_stale_s", "max_temperature_c")
ARM_KINDS = ("mock", "dynamixel", "external")
SERIAL_MODES = ("binary", "text")
DXL_MAX_BAUD = 4_500_000  # the fastest rate of the Dynamixel X series' bus
DXL_MAX_PROFILE = 32_767  # Profile Velocity / Acceleration registers (velocity-based profile)
SERIAL_MAX_BAUD = 12_000_000  # a full-speed USB serial bridge's fastest rate
MAX_OFFSET_M = 10.0  # any position or offset in the file, per component (the arm's chain: up to this)
MAX_ANGLE_RAD = 10.0  # any roll, pitch or yaw
# A finger is hand-sized: its links and sensor mount within this per component (the shipped hands'
# largest, the LEAP thumb's first joint origin, is 0.07 m), its base within MAX_FINGER_BASE_M of
# the hand frame's origin (shipped: 0.05 m). Beyond them is a unit slip (mm for m), not a hand.
MAX_FINGER_LINK_M = 0.5
MAX_FINGER_BASE_M = 1.0
# A grasping finger closes across the lift: the horizontal (hand x-y) part of its unit task vector
# is at least this (no steeper than 60 degrees from the x-y plane). The preshape, the grip targets
# and the grip itself work in that plane; a vertical vector has no closing direction there.
MIN_CLOSING_COMPONENT = 0.5


@dataclass(frozen=True)
class JointConfig:
    name: str
    servo_id: int
    axis: tuple[float, float, float]  # unit, in the parent link frame
    origin_xyz: tuple[float, float, float]  # m, parent link -> joint
    origin_rpy: tuple[float, float, float]  # rad
    lower_rad: float
    upper_rad: float
    open_rad: float  # safe open posture
    pregrasp_rad: float  # posture used when reaching
    offset_rad: float = 0.0  # servo zero -> joint zero
    sign: int = 1  # servo direction
    current_limit_a: float = 1.0
    gain_scale: float = 1.0  # x the [dynamixel] position gains (LEAP API: 0.75 on abduction)
    # actuator = "torque_pd" (the host runs each joint's PD loop and sends torques): its gains
    # and torque limit; None on a Dynamixel hand (its servos' gains and current limits apply)
    kp_nm_per_rad: float | None = None
    kd_nm_s_per_rad: float | None = None
    torque_limit_nm: float | None = None


@dataclass(frozen=True)
class FingerConfig:
    name: str
    sensor_id: int  # finger number on the tactile link
    grasp: bool  # takes part in the grasp
    task_vector_hand: tuple[float, float, float]  # unit closing direction, hand frame
    base_xyz: tuple[float, float, float]
    base_rpy: tuple[float, float, float]
    joints: tuple[JointConfig, ...]
    tip_xyz: tuple[float, float, float]  # last link -> sensor frame
    tip_rpy: tuple[float, float, float]


@dataclass(frozen=True)
class CollisionBox:
    """A box of a link's collision shape, in that link's frame (the joint frame that moves it)."""

    half_m: tuple[float, float, float]  # half sizes
    pos_m: tuple[float, float, float]  # centre
    quat: tuple[float, float, float, float] | None = None  # w x y z; None: the link's axes


@dataclass(frozen=True)
class TorquePDConfig:
    """``[torque_pd]``: a torque-controlled hand whose joint PD loop runs on the host (the Allegro v4
    over CAN); each joint's gains and torque limit are in its ``[[fingers.joints]]`` table."""

    rate_hz: float = 333.0  # the host PD loop's rate
    interface: str = "socketcan"  # python-can interface: socketcan | pcan | virtual
    channel: str = "can0"
    damping_nm_s_per_rad: float = 0.0  # each joint's passive damping (gears, motor), besides the PD's
    armature_kg_m2: float | None = None  # reflected rotor inertia; None: the simulated worlds' default
    source: str = ""  # where the gains and limits come from (required in the file)
    # The CAN link of a hand on the bus (hardware/allegro/, docs/hardware.md); optional keys, their
    # defaults the Allegro v4's (SimLab allegro_hand_ros_v4: AllegroHandDrv.cpp, pcan.cpp)
    bitrate: int = 1_000_000  # bit/s; the driver opens the bus at CAN_BAUD_1M
    can_device_id: int = 0  # the two low bits of every frame's id (the driver's CAN_ID, 0)
    pwm_per_nm: float = 1200.0  # torque -> the hand's PWM units (_tau_cov_const: v4 1200, v3 800)
    pwm_limit: float = 1200.0  # the PWM ceiling (PWM_LIMIT_GLOBAL_12V); torque_limit_nm x pwm_per_nm within it
    position_stale_s: float = 0.02  # no full set of joint positions for this long: a fault, zero torque
    max_temperature_c: float = 70.0  # a temperature report above this: a fault (assumed; not published)


@dataclass(frozen=True)
class DynamixelConfig:
    port: str = "/dev/ttyUSB0"
    baud: int = 4_000_000
    model: str = "XC330-M288-T"
    packet_timeout_ms: float = 8.0
    retries: int = 2
    profile_velocity: int = 0
    profile_acceleration: int = 0
    fast_sync_read: bool = True  # fall back to plain Sync Read if unsupported
    latency_timer_ms: int = 1  # USB serial latency timer set on connect
    position_p_gain: int | None = None  # None: keep the servo's value
    position_i_gain: int | None = None
    position_d_gain: int | None = None
    custom_model: ServoModel | None = None  # the hand file's [servo_models.NAME] when `model` names one

    @property
    def servo(self) -> ServoModel | None:
        """The servos' facts and ratings: the hand file's own table, else config/servos.py's."""
        return self.custom_model or SERVO_MODELS.get(self.model)


@dataclass(frozen=True)
class TactileConfig:
    sensor_type: str = "biotac"  # one of config/sensor_layout.py's LAYOUTS
    port: str = "/dev/ttyACM0"
    baud: int = 1_000_000
    mode: str = "binary"
    stale_after_s: float = 0.05
    contact_pdc_threshold: float = 10.0
    contact_frames: int = 10
    tare_frames: int = 50
    # Optional per-finger ports (finger name -> port); fingers not listed use ``port``.
    ports: tuple[tuple[str, str], ...] = ()
    reconnect: bool = True  # reopen an unplugged port when it comes back

    def port_for(self, finger_name: str) -> str:
        return dict(self.ports).get(finger_name, self.port)

    @property
    def layout(self) -> SensorLayout:
        """The channel layout of this sensor type's frames."""
        return layout_for(self.sensor_type)


@dataclass(frozen=True)
class ArmConfig:
    kind: str = "mock"
    max_speed_m_s: float = 0.05
    lift_height_m: float = 0.10
    z_min_m: float = 0.0
    z_max_m: float = 0.6
    # kind = "dynamixel": a serial chain from base (world frame) to the palm (tool)
    port: str = "/dev/ttyUSB1"
    baud: int = 4_000_000
    model: str = "XM430-W350-T"
    joints: tuple[JointConfig, ...] = ()
    base_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tool_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tool_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    line_xy: tuple[float, float] | None = None  # vertical line; None: where the palm is at connect
    tolerance_m: float = 0.002  # IK accuracy / "arrived" distance
    # kind = "external": ask for a confirmation every time the target moved this far
    confirm_step_m: float = 0.02
    custom_model: ServoModel | None = None  # the hand file's [servo_models.NAME] when `model` names one

    @property
    def servo(self) -> ServoModel | None:
        """The arm servos' facts and ratings: the hand file's own table, else config/servos.py's."""
        return self.custom_model or SERVO_MODELS.get(self.model)


@dataclass(frozen=True)
class SafetyConfig:
    on_fault: str = "open"
    max_fingertip_force_n: float = 8.0
    max_joint_step_rad: float = 0.05


@dataclass(frozen=True)
class GraspConfig:
    palm_above_contact_m: float = 0.11
    release_finger: str = "index"


@dataclass(frozen=True)
class HandConfig:
    name: str
    path: str
    rate_hz: float
    fingers: tuple[FingerConfig, ...]
    actuator: str = "dynamixel"  # one of ACTUATOR_KINDS: which section below drives the joints
    torque_pd: TorquePDConfig | None = None  # actuator = "torque_pd"
    dynamixel: DynamixelConfig = field(default_factory=DynamixelConfig)
    tactile: TactileConfig = field(default_factory=TactileConfig)
    arm: ArmConfig = field(default_factory=ArmConfig)
    safety: SafetyConfig = field(default_factory=SafetyConfig)
    grasp: GraspConfig = field(default_factory=GraspConfig)
    # [collision]: the links' shapes for the simulated worlds; a link with none listed gets a
    # capsule from its joint to the next (or to the sensor's mount)
    palm_boxes: tuple[CollisionBox, ...] = ()  # in the first finger's base frame
    link_boxes: tuple[tuple[str, tuple[CollisionBox, ...]], ...] = ()  # joint name -> its link's boxes
    # [inertia]: the simulated worlds' palm and per-link masses; None: the world's defaults
    palm_mass_kg: float | None = None
    link_mass_kg: float | None = None
    # [controllers.NAME]: this hand's own choices among controller NAME's settings (checked
    # against the settings by controller/settings.py: the config layer does not know them)
    controller_choices: tuple[tuple[str, tuple[tuple[str, Any], ...]], ...] = ()

    def choices_of(self, controller: str) -> dict[str, Any]:
        """The hand file's ``[controllers.NAME]`` choices for ``controller`` (empty without one)."""
        return dict(dict(self.controller_choices).get(controller, ()))

    @property
    def servo_driven(self) -> bool:
        """Position-controlled Dynamixel servos drive the joints (``actuator = "dynamixel"``)."""
        return self.actuator == "dynamixel"

    def boxes_of(self, joint_name: str) -> tuple[CollisionBox, ...] | None:
        """The collision boxes of the link ``joint_name`` moves; None where the file lists none."""
        return dict(self.link_boxes).get(joint_name)

    @property
    def dt(self) -> float:
        return 1.0 / self.rate_hz

    @property
    def joints(self) -> tuple[JointConfig, ...]:
        """All joints, finger by finger: the order of every joint vector."""
        return tuple(j for f in self.fingers for j in f.joints)

    @property
    def grasp_fingers(self) -> tuple[FingerConfig, ...]:
        return tuple(f for f in self.fingers if f.grasp)

    def finger(self, name: str) -> FingerConfig:
        for f in self.fingers:
            if f.name == name:
                return f
        raise KeyError(name)

    def joint_slice(self, finger_name: str) -> slice:
        start = 0
        for f in self.fingers:
            if f.name == finger_name:
                return slice(start, start + len(f.joints))
            start += len(f.joints)
        raise KeyError(finger_name)


MAX_BOX_M = 0.5  # a box's half size or centre offset, per component


def _boxes(t: Table, name: str) -> tuple[CollisionBox, ...]:
    """An array of ``{ half_m = [x, y, z], pos_m = [x, y, z], quat = [w, x, y, z] }`` tables."""
    out = []
    for b in t.tables(name):
        b.unknown_keys({"half_m", "pos_m", "quat"})
        half = b.vector("half_m", 3, bound=MAX_BOX_M)
        if min(half) <= 0.0:
            raise b.fail("half_m", f"three positive half sizes (got {list(half)})")
        quat = None
        if b.has("quat"):
            w, x, y, z = b.vector("quat", 4)
            if abs(math.sqrt(w * w + x * x + y * y + z * z) - 1.0) > 1e-3:  # kept as written: the scene's text
                raise b.fail("quat", f"a unit quaternion w, x, y, z (got {[w, x, y, z]})")
            quat = (w, x, y, z)
        out.append(CollisionBox(half, b.vector("pos_m", 3, bound=MAX_BOX_M), quat))
    return tuple(out)


def _collision(
    root: Table, fingers: tuple[FingerConfig, ...]
) -> tuple[tuple[CollisionBox, ...], tuple[tuple[str, tuple[CollisionBox, ...]], ...]]:
    """``[collision]``: ``palm`` boxes and ``[collision.links]`` boxes by joint name."""
    c = root.table("collision", {})
    c.unknown_keys({"palm", "links"})
    palm = _boxes(c, "palm")
    links_t = c.table("links", {})
    joint_names = [j.name for f in fingers for j in f.joints]
    links = []
    for name in links_t.data:
        if name not in joint_names:
            raise links_t.fail(name, f"a joint name of the hand ({', '.join(joint_names)})")
        links.append((name, _boxes(links_t, name)))
    return palm, tuple(links)


def _hand_sized(t: Table, name: str, bound: float, default: Vec3 | None = None) -> Vec3:
    """A position (m) of a finger: refused, naming the key, beyond ``bound`` per component."""
    vec = t.vector(name, 3) if default is None else t.vector(name, 3, default)
    if any(abs(v) > bound for v in vec):
        raise t.fail(name, f"a hand-sized position, each component within +-{bound:g} m (got {list(vec)})")
    return vec


def _closing_vector(t: Table, grasp: bool) -> Vec3:
    """``task_vector_hand`` as a unit vector; a grasping finger's must close across the lift."""
    vec = t.vector("task_vector_hand", 3, unit=True)
    if grasp and math.hypot(vec[0], vec[1]) < MIN_CLOSING_COMPONENT:
        raise t.fail(
            "task_vector_hand",
            f"a closing direction of a grasping finger with at least {MIN_CLOSING_COMPONENT:g} of its length in "
            f"the hand's x-y plane (no steeper than 60 degrees from it; got {t.data['task_vector_hand']})",
        )
    return vec


def _joint(t: Table, in_finger: bool = False) -> JointConfig:
    """A finger's joint (``in_finger``: a hand-sized origin) or an arm's."""
    t.unknown_keys(
        {
            "name",
            "servo_id",
            "axis",
            "origin_xyz",
            "origin_rpy",
            "lower_rad",
            "upper_rad",
            "open_rad",
            "pregrasp_rad",
            "offset_rad",
            "sign",
            "current_limit_a",
            "gain_scale",
            *TORQUE_PD_KEYS,
        }
    )
    lower = t.float("lower_rad", lo=-6.3, hi=6.3)
    upper = t.float("upper_rad", lo=-6.3, hi=6.3)
    if upper <= lower:
        raise t.fail("upper_rad", f"a value > lower_rad ({lower})")
    open_rad = t.float("open_rad", lo=lower, hi=upper)
    sign = t.int("sign", 1)
    if sign not in (-1, 1):
        raise t.fail("sign", "1 or -1")
    return JointConfig(
        # names become MuJoCo scene names and tick-log columns: one safe identifier each
        name=check_identifier(t.str("name"), t.path, t.key("name")),
        servo_id=t.int("servo_id", lo=0, hi=252),
        axis=t.vector("axis", 3, unit=True),
        origin_xyz=_hand_sized(t, "origin_xyz", MAX_FINGER_LINK_M, (0.0, 0.0, 0.0))
        if in_finger
        else t.vector("origin_xyz", 3, (0.0, 0.0, 0.0), bound=MAX_OFFSET_M),
        origin_rpy=t.vector("origin_rpy", 3, (0.0, 0.0, 0.0), bound=MAX_ANGLE_RAD),
        lower_rad=lower,
        upper_rad=upper,
        open_rad=open_rad,
        pregrasp_rad=t.float("pregrasp_rad", open_rad, lo=lower, hi=upper),
        offset_rad=t.float("offset_rad", 0.0, lo=-6.3, hi=6.3),
        sign=sign,
        current_limit_a=t.float("current_limit_a", 1.0, lo=0.0, hi=5.0, lo_open=True),
        gain_scale=t.float("gain_scale", 1.0, lo=0.0, hi=4.0, lo_open=True),
        kp_nm_per_rad=t.float("kp_nm_per_rad", lo=0.0, hi=1000.0) if t.has("kp_nm_per_rad") else None,
        kd_nm_s_per_rad=t.float("kd_nm_s_per_rad", lo=0.0, hi=100.0) if t.has("kd_nm_s_per_rad") else None,
        torque_limit_nm=t.float("torque_limit_nm", lo=0.0, hi=100.0, lo_open=True)
        if t.has("torque_limit_nm")
        else None,
    )


def _finger(t: Table) -> FingerConfig:
    t.unknown_keys(
        {
            "name",
            "sensor_id",
            "grasp",
            "task_vector_hand",
            "base_xyz",
            "base_rpy",
            "joints",
            "tip_xyz",
            "tip_rpy",
        }
    )
    joints = tuple(_joint(j, in_finger=True) for j in t.tables("joints", min_len=1))
    grasp = t.bool("grasp", True)
    return FingerConfig(
        name=check_identifier(t.str("name"), t.path, t.key("name")),
        sensor_id=t.int("sensor_id", lo=0, hi=255),
        grasp=grasp,
        task_vector_hand=_closing_vector(t, grasp),
        base_xyz=_hand_sized(t, "base_xyz", MAX_FINGER_BASE_M),
        base_rpy=t.vector("base_rpy", 3, (0.0, 0.0, 0.0), bound=MAX_ANGLE_RAD),
        joints=joints,
        tip_xyz=_hand_sized(t, "tip_xyz", MAX_FINGER_LINK_M),
        tip_rpy=t.vector("tip_rpy", 3, (0.0, 0.0, 0.0), bound=MAX_ANGLE_RAD),
    )


SERVO_MODEL_KEYS = {
    "model_number",
    "current_unit_a",
    "max_current_limit",
    "stall_current_a",
    "stall_voltage_v",
    "stall_torque_nm",
    "no_load_speed_rpm",
    "max_velocity_limit",
    "max_position_gain",
}
DXL_MAX_GAIN = 16383  # the largest position gain the bus writes (hardware/dynamixel/setup.py)


def _servo_models(root: Table) -> dict[str, ServoModel]:
    """``[servo_models.NAME]``: a servo that config/servos.py does not know, with its ratings
    (docs/hardware.md). A model the table knows keeps its data-sheet ratings: redefining it is refused."""
    t = root.table("servo_models", {})
    out: dict[str, ServoModel] = {}
    for name in t.data:
        check_identifier(name, t.path, "servo_models.<model name>")
        if name in SERVO_MODELS:
            raise t.fail(
                name,
                f"a model that config/servos.py does not know ({name} is there, with its data-sheet "
                "ratings; remove this table)",
            )
        m = t.table(name)
        m.unknown_keys(SERVO_MODEL_KEYS)
        out[name] = ServoModel(
            name=name,
            model_number=m.int("model_number", lo=0, hi=65535),
            amp_per_current_unit=m.float("current_unit_a", lo=0.0, hi=0.1, lo_open=True),
            max_current_limit=m.int("max_current_limit", lo=1, hi=65535),
            stall_current_a=_positive(m, "stall_current_a", 100.0),
            stall_voltage_v=_positive(m, "stall_voltage_v", 100.0),
            stall_torque_nm=_positive(m, "stall_torque_nm", 1000.0),
            no_load_speed_rpm=_positive(m, "no_load_speed_rpm", 10000.0),
            max_velocity_limit=m.int("max_velocity_limit", lo=0, hi=DXL_MAX_PROFILE)
            if m.has("max_velocity_limit")
            else None,
            max_position_gain=m.int("max_position_gain", lo=0, hi=DXL_MAX_GAIN) if m.has("max_position_gain") else None,
        )
    return out


def _positive(t: Table, key: str, hi: float) -> float | None:
    return t.float(key, lo=0.0, hi=hi, lo_open=True) if t.has(key) else None


def _model_name(t: Table, default: str, custom: dict[str, ServoModel]) -> str:
    model = t.str("model", default)
    if model not in SERVO_MODELS and model not in custom:
        raise t.fail(
            "model",
            f"one of {', '.join(SERVO_MODELS)} or a model of a [servo_models.NAME] table (got {model!r})",
        )
    return model


def _check_ratings(root: Table, fingers: tuple[FingerConfig, ...], dxl: DynamixelConfig, arm: ArmConfig) -> None:
    """What the file asks of each servo, against its model's ratings (config/servos.py or the file's
    [servo_models.NAME]): current limits, the profile velocity and the position gains as written."""
    model = dxl.servo
    if model is None:  # not reached: _model_name refuses a model without facts
        return
    for i, f in enumerate(fingers):
        for k, j in enumerate(f.joints):
            _check_current(root, f"fingers[{i}].joints[{k}].current_limit_a", j.current_limit_a, model)
    if arm.servo is not None:
        for k, j in enumerate(arm.joints):
            _check_current(root, f"arm.joints[{k}].current_limit_a", j.current_limit_a, arm.servo)
    vmax = model.max_velocity_limit
    if vmax is not None and dxl.profile_velocity > vmax:
        raise root.fail(
            "dynamixel.profile_velocity",
            f"at most {vmax} ({vmax * model.velocity_unit_rpm:.1f} rev/min), the {model.name}'s Velocity Limit "
            f"register maximum, which bounds Goal and Profile Velocity (got {dxl.profile_velocity})",
        )
    gmax = model.max_position_gain if model.max_position_gain is not None else DXL_MAX_GAIN
    whose = (
        f"the {model.name}'s Position {{}} Gain register maximum"
        if model.max_position_gain is not None
        else f"the largest gain the bus writes ({model.name}'s register range unknown)"
    )
    for letter, gain in (("P", dxl.position_p_gain), ("I", dxl.position_i_gain), ("D", dxl.position_d_gain)):
        if gain is None:
            continue
        key = f"position_{letter.lower()}_gain"
        if gain > gmax:
            raise root.fail(f"dynamixel.{key}", f"at most {gmax}, {whose.format(letter)} (got {gain})")
        for i, f in enumerate(fingers):
            for k, j in enumerate(f.joints):
                written = int(round(gain * j.gain_scale))
                if written > gmax:
                    raise root.fail(
                        f"fingers[{i}].joints[{k}].gain_scale",
                        f"at most {gmax / gain:.4g} with {key} = {gain}: {gain} x {j.gain_scale:g} = {written} "
                        f"is above {gmax}, {whose.format(letter)} (got {j.gain_scale:g})",
                    )


def _check_current(root: Table, key: str, amps: float, model: ServoModel) -> None:
    register = model.max_current_a
    stall = model.stall_current_a
    if stall is not None and stall <= register:
        at = f" at {model.stall_voltage_v:g} V" if model.stall_voltage_v is not None else ""
        limit, what = stall, f"the {model.name}'s stall current{at}"
    else:
        limit = register
        what = (
            f"the {model.name}'s Current Limit register maximum "
            f"({model.max_current_limit} x {model.amp_per_current_unit * 1000:g} mA)"
        )
    if amps > limit + 1e-9:
        raise root.fail(key, f"at most {limit:g} A, {what} (got {amps:g})")


def _refuse_joint_keys(root: Table, raw: list[tuple[str, dict]], keys: tuple[str, ...], why: str) -> None:
    """The first joint table that sets one of ``keys``: a one-line error naming it."""
    for where, data in raw:
        for k in keys:
            if k in data:
                raise root.fail(f"{where}.{k}", why)


def _actuation(root: Table, actuator: str, fingers: tuple[FingerConfig, ...]) -> TorquePDConfig | None:
    """The actuator section that ``actuator`` names, and each joint's keys of that kind only: a
    Dynamixel hand's joints take current limits and gain scales, a torque-controlled hand's take
    PD gains and torque limits; a key or section of the other kind is a contradiction, refused."""
    raw = [
        (f"fingers[{i}].joints[{k}]", root.data["fingers"][i]["joints"][k])
        for i, f in enumerate(fingers)
        for k in range(len(f.joints))
    ]
    if actuator == "dynamixel":
        if root.has("torque_pd"):
            raise root.fail(
                "torque_pd", 'no [torque_pd] table with actuator = "dynamixel" (set actuator = "torque_pd")'
            )
        _refuse_joint_keys(
            root, raw, TORQUE_PD_KEYS, 'no torque-control key with actuator = "dynamixel" (its servos\' gains apply)'
        )
        return None
    if root.has("dynamixel"):
        raise root.fail(
            "dynamixel", 'no [dynamixel] table with actuator = "torque_pd" (its [torque_pd] table drives the joints)'
        )
    if not root.has("torque_pd"):
        raise root.fail(
            "torque_pd", 'a [torque_pd] table (actuator = "torque_pd": the host PD loop\'s rate, bus and source)'
        )
    _refuse_joint_keys(
        root,
        raw,
        DYNAMIXEL_JOINT_KEYS,
        f'no Dynamixel key with actuator = "torque_pd" (set {", ".join(TORQUE_PD_KEYS)})',
    )
    for key, data in raw:
        for k in TORQUE_PD_KEYS:
            if k not in data:
                raise root.fail(
                    f"{key}.{k}",
                    'a value (every joint of a hand with actuator = "torque_pd" has its PD gains and torque limit)',
                )
    t = root.table("torque_pd")
    t.unknown_keys({"rate_hz", "interface", "channel", "damping_nm_s_per_rad", "armature_kg_m2", "source", *CAN_KEYS})
    d = TorquePDConfig
    cfg = TorquePDConfig(
        rate_hz=t.float("rate_hz", d.rate_hz, lo=1.0, hi=10000.0),
        interface=t.str("interface", d.interface, choices=CAN_INTERFACES),
        channel=t.str("channel", d.channel),
        damping_nm_s_per_rad=t.float("damping_nm_s_per_rad", 0.0, lo=0.0, hi=100.0),
        armature_kg_m2=t.float("armature_kg_m2", lo=0.0, hi=1.0) if t.has("armature_kg_m2") else None,
        source=t.str("source"),
        bitrate=t.int("bitrate", d.bitrate, lo=10_000, hi=1_000_000),
        can_device_id=t.int("can_device_id", d.can_device_id, lo=0, hi=3),
        pwm_per_nm=t.float("pwm_per_nm", d.pwm_per_nm, lo=0.0, hi=100_000.0, lo_open=True),
        pwm_limit=t.float("pwm_limit", d.pwm_limit, lo=0.0, hi=32_767.0, lo_open=True),
        position_stale_s=t.float("position_stale_s", d.position_stale_s, lo=0.001, hi=1.0),
        max_temperature_c=t.float("max_temperature_c", d.max_temperature_c, lo=0.0, hi=150.0),
    )
    # Every torque a joint may get must fit in the hand's PWM range (the backend also clamps).
    for i, f in enumerate(fingers):
        for n, j in enumerate(f.joints):
            if j.torque_limit_nm is not None and j.torque_limit_nm * cfg.pwm_per_nm > cfg.pwm_limit + 1e-9:
                raise root.fail(
                    f"fingers[{i}].joints[{n}].torque_limit_nm",
                    f"at most {cfg.pwm_limit / cfg.pwm_per_nm:.6g} N m ([torque_pd] pwm_limit {cfg.pwm_limit:g} / "
                    f"pwm_per_nm {cfg.pwm_per_nm:g}; got {j.torque_limit_nm:g})",
                )
    return cfg


def _controller_choices(root: Table) -> tuple[tuple[str, tuple[tuple[str, Any], ...]], ...]:
    """``[controllers.NAME]`` tables of plain values (numbers, booleans, strings), kept as
    hashable pairs in file order."""
    if not root.has("controllers"):
        return ()
    controllers = root.table("controllers")
    out = []
    for name, values in controllers.data.items():
        if not isinstance(values, dict):
            raise controllers.fail(name, "a table of controller settings ([controllers.NAME])")
        for key, value in values.items():
            if isinstance(value, (dict, list)):
                raise controllers.fail(f"{name}.{key}", "a number, true/false or a string")
        out.append((str(name), tuple((str(k), v) for k, v in values.items())))
    return tuple(out)


def load_hand(path: str | Path) -> HandConfig:
    """Read and validate a hand file; raises ConfigError naming file and key."""
    root = Table(path, read_toml(path))
    root.unknown_keys(
        {
            "name",
            "rate_hz",
            "actuator",
            "torque_pd",
            "fingers",
            "dynamixel",
            "tactile",
            "arm",
            "safety",
            "grasp",
            "servo_models",
            "collision",
            "inertia",
            "controllers",
        }
    )
    fingers = tuple(_finger(f) for f in root.tables("fingers", min_len=1))
    custom_models = _servo_models(root)

    names = [f.name for f in fingers]
    for i, n in enumerate(names):
        if n in names[:i]:
            raise root.fail(f"fingers[{i}].name", f"a unique finger name ({n!r} repeats)")
    sensor_ids = [f.sensor_id for f in fingers]
    for i, sid in enumerate(sensor_ids):
        if sid in sensor_ids[:i]:
            raise root.fail(f"fingers[{i}].sensor_id", f"a unique sensor id ({sid} repeats)")
    joint_names = [j.name for f in fingers for j in f.joints]
    for i, n in enumerate(joint_names):
        if n in joint_names[:i]:
            raise root.fail("fingers.joints.name", f"a unique joint name ({n!r} repeats)")
    servo_ids = [j.servo_id for f in fingers for j in f.joints]
    if len(set(servo_ids)) != len(servo_ids):
        dup = sorted({s for s in servo_ids if servo_ids.count(s) > 1})
        raise root.fail("fingers.joints.servo_id", f"unique servo ids (repeated: {dup})")
    if not any(f.grasp for f in fingers):
        raise root.fail("fingers", "at least one finger with grasp = true")
    actuator = root.str("actuator", "dynamixel", choices=ACTUATOR_KINDS)
    torque_pd = _actuation(root, actuator, fingers)
    palm_boxes, link_boxes = _collision(root, fingers)
    inertia = root.table("inertia", {})
    inertia.unknown_keys({"palm_mass_kg", "link_mass_kg"})
    palm_mass = inertia.float("palm_mass_kg", lo=0.0, hi=10.0, lo_open=True) if inertia.has("palm_mass_kg") else None
    link_mass = inertia.float("link_mass_kg", lo=0.0, hi=1.0, lo_open=True) if inertia.has("link_mass_kg") else None

    d = root.table("dynamixel", {})
    d.unknown_keys(
        {
            "port",
            "baud",
            "model",
            "packet_timeout_ms",
            "retries",
            "profile_velocity",
            "profile_acceleration",
            "fast_sync_read",
            "latency_timer_ms",
            "position_p_gain",
            "position_i_gain",
            "position_d_gain",
        }
    )
    dxl_model = _model_name(d, DynamixelConfig.model, custom_models)
    dynamixel = DynamixelConfig(
        port=d.str("port", DynamixelConfig.port),
        baud=d.int("baud", DynamixelConfig.baud, lo=9600, hi=DXL_MAX_BAUD),
        model=dxl_model,
        packet_timeout_ms=d.float("packet_timeout_ms", DynamixelConfig.packet_timeout_ms, lo=1.0, hi=1000.0),
        retries=d.int("retries", DynamixelConfig.retries, lo=0, hi=10),
        profile_velocity=d.int("profile_velocity", 0, lo=0, hi=DXL_MAX_PROFILE),
        profile_acceleration=d.int("profile_acceleration", 0, lo=0, hi=DXL_MAX_PROFILE),
        fast_sync_read=d.bool("fast_sync_read", True),
        latency_timer_ms=d.int("latency_timer_ms", 1, lo=1, hi=255),
        # the register holds 2 bytes; the model's range is checked with the other ratings below
        position_p_gain=d.int("position_p_gain", None, lo=0, hi=65535) if d.has("position_p_gain") else None,
        position_i_gain=d.int("position_i_gain", None, lo=0, hi=65535) if d.has("position_i_gain") else None,
        position_d_gain=d.int("position_d_gain", None, lo=0, hi=65535) if d.has("position_d_gain") else None,
        custom_model=custom_models.get(dxl_model),
    )

    s = root.table("tactile", {})
    s.unknown_keys(
        {
            "sensor_type",
            "port",
            "ports",
            "baud",
            "mode",
            "stale_after_s",
            "contact_pdc_threshold",
            "contact_frames",
            "tare_frames",
            "reconnect",
        }
    )
    port_table = s.table("ports", {})
    ports = []
    for finger_name in port_table.data:
        if finger_name not in names:
            raise port_table.fail(finger_name, f"one of the finger names {names}")
        ports.append((finger_name, port_table.str(finger_name)))
    tactile = TactileConfig(
        sensor_type=s.str("sensor_type", "biotac", choices=tuple(LAYOUTS)),
        port=s.str("port", TactileConfig.port),
        baud=s.int("baud", TactileConfig.baud, lo=9600, hi=SERIAL_MAX_BAUD),
        mode=s.str("mode", "binary", choices=SERIAL_MODES),
        stale_after_s=s.float("stale_after_s", 0.05, lo=0.0, hi=10.0, lo_open=True),
        contact_pdc_threshold=s.float("contact_pdc_threshold", 10.0, lo=0.0, hi=4095.0, lo_open=True),
        contact_frames=s.int("contact_frames", 10, lo=1, hi=1000),
        tare_frames=s.int("tare_frames", 50, lo=1, hi=10000),
        ports=tuple(ports),
        reconnect=s.bool("reconnect", True),
    )

    a = root.table("arm", {})
    a.unknown_keys(
        {
            "kind",
            "max_speed_m_s",
            "lift_height_m",
            "z_min_m",
            "z_max_m",
            "port",
            "baud",
            "model",
            "joints",
            "base_xyz",
            "base_rpy",
            "tool_xyz",
            "tool_rpy",
            "line_xy",
            "tolerance_m",
            "confirm_step_m",
        }
    )
    arm_joints = tuple(_joint(j) for j in a.tables("joints"))
    arm_model = _model_name(a, ArmConfig.model, custom_models)
    arm = ArmConfig(
        kind=a.str("kind", "mock", choices=ARM_KINDS),
        max_speed_m_s=a.float("max_speed_m_s", 0.05, lo=0.0, hi=1.0, lo_open=True),
        lift_height_m=a.float("lift_height_m", 0.10, lo=0.0, hi=1.0, lo_open=True),
        z_min_m=a.float("z_min_m", 0.0, lo=-10.0, hi=10.0),
        z_max_m=a.float("z_max_m", 0.6, lo=-10.0, hi=10.0),
        port=a.str("port", ArmConfig.port),
        baud=a.int("baud", ArmConfig.baud, lo=9600, hi=DXL_MAX_BAUD),
        model=arm_model,
        joints=arm_joints,
        base_xyz=a.vector("base_xyz", 3, (0.0, 0.0, 0.0), bound=MAX_OFFSET_M),
        base_rpy=a.vector("base_rpy", 3, (0.0, 0.0, 0.0), bound=MAX_ANGLE_RAD),
        tool_xyz=a.vector("tool_xyz", 3, (0.0, 0.0, 0.0), bound=MAX_OFFSET_M),
        tool_rpy=a.vector("tool_rpy", 3, (0.0, 0.0, 0.0), bound=MAX_ANGLE_RAD),
        line_xy=a.vector("line_xy", 2) if a.has("line_xy") else None,
        tolerance_m=a.float("tolerance_m", 0.002, lo=0.0, hi=0.1, lo_open=True),
        confirm_step_m=a.float("confirm_step_m", 0.02, lo=0.0, hi=1.0, lo_open=True),
        custom_model=custom_models.get(arm_model),
    )
    if arm.z_max_m <= arm.z_min_m:
        raise a.fail("z_max_m", f"a value > z_min_m ({arm.z_min_m})")
    if arm.kind == "dynamixel" and not arm.joints:
        raise a.fail("joints", "at least one [[arm.joints]] table when kind = \"dynamixel\"")
    arm_ids = [j.servo_id for j in arm.joints]
    if len(set(arm_ids)) != len(arm_ids):
        raise a.fail("joints.servo_id", f"unique servo ids (got {arm_ids})")
    for k, j in enumerate(arm.joints):
        for key in TORQUE_PD_KEYS:
            if getattr(j, key) is not None:
                raise root.fail(
                    f"arm.joints[{k}].{key}", "no torque-control key (the arm's joints are Dynamixel servos)"
                )
    _check_ratings(root, fingers if actuator == "dynamixel" else (), dynamixel, arm)

    sf = root.table("safety", {})
    sf.unknown_keys({"on_fault", "max_fingertip_force_n", "max_joint_step_rad"})
    safety = SafetyConfig(
        on_fault=sf.str("on_fault", "open", choices=SAFE_ACTIONS),
        max_fingertip_force_n=sf.float("max_fingertip_force_n", 8.0, lo=0.0, hi=100.0, lo_open=True),
        max_joint_step_rad=sf.float("max_joint_step_rad", 0.05, lo=0.0, hi=1.0, lo_open=True),
    )

    g = root.table("grasp", {})
    g.unknown_keys({"palm_above_contact_m", "release_finger"})
    grasp = GraspConfig(
        palm_above_contact_m=g.float("palm_above_contact_m", 0.11, lo=0.0, hi=1.0),
        release_finger=g.str("release_finger", "index"),
    )
    if grasp.release_finger not in names:
        raise g.fail("release_finger", f"one of the finger names {names}")
    if not next(f for f in fingers if f.name == grasp.release_finger).grasp:
        raise g.fail("release_finger", "a finger with grasp = true")

    return HandConfig(
        name=check_identifier(root.str("name"), root.path, "name"),
        path=str(path),
        rate_hz=root.float("rate_hz", 100.0, lo=1.0, hi=2000.0),
        fingers=fingers,
        actuator=actuator,
        torque_pd=torque_pd,
        dynamixel=dynamixel,
        tactile=tactile,
        arm=arm,
        safety=safety,
        grasp=grasp,
        palm_boxes=palm_boxes,
        link_boxes=link_boxes,
        palm_mass_kg=palm_mass,
        link_mass_kg=link_mass,
        controller_choices=_controller_choices(root),
    )
