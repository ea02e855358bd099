"""The hand file's contents as frozen dataclasses (``HandConfig`` and its sections) and the
bounds its values are checked against. config/hand.py's ``load_hand`` fills them (with
config/hand_sections.py's section parsers) and re-exports them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from grasp_ctrl.config.sensor_layout import SensorLayout, layout_for
from grasp_ctrl.config.servos import MODELS as SERVO_MODELS
from grasp_ctrl.config.servos import ServoModel

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
