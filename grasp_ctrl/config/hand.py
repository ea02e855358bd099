"""Hand configuration: servos, joint limits, kinematics, sensors, arm, grasp.

Loaded from a TOML file under ``hand_configs/`` and validated on load. See
``hand_configs/leap_hand.toml`` for a documented example of every key.

``load_hand`` reads the file's top-level sections here; the dataclasses it fills and
their bounds live in config/hand_types.py (importable from here as before), the parsers
of the fingers, collision boxes, servo models, actuation tables and controller choices
in config/hand_sections.py.
"""

from __future__ import annotations

from pathlib import Path

from grasp_ctrl.config.hand_sections import (
    _actuation,
    _check_ratings,
    _collision,
    _controller_choices,
    _finger,
    _joint,
    _model_name,
    _servo_models,
)
from grasp_ctrl.config.hand_types import (
    ACTUATOR_KINDS,
    ARM_KINDS,
    CAN_INTERFACES,
    CAN_KEYS,
    DXL_MAX_BAUD,
    DXL_MAX_PROFILE,
    DYNAMIXEL_JOINT_KEYS,
    MAX_ANGLE_RAD,
    MAX_FINGER_BASE_M,
    MAX_FINGER_LINK_M,
    MAX_OFFSET_M,
    MIN_CLOSING_COMPONENT,
    SAFE_ACTIONS,
    SERIAL_MAX_BAUD,
    SERIAL_MODES,
    TORQUE_PD_KEYS,
    ArmConfig,
    CollisionBox,
    DynamixelConfig,
    FingerConfig,
    GraspConfig,
    HandConfig,
    JointConfig,
    SafetyConfig,
    TactileConfig,
    TorquePDConfig,
    Vec3,
)
from grasp_ctrl.config.identifiers import check_identifier
from grasp_ctrl.config.sensor_layout import LAYOUTS
from grasp_ctrl.config.toml_reader import Table, read_toml

# The hand file's dataclasses and bounds (config/hand_types.py) are imported from here.
__all__ = [
    "ACTUATOR_KINDS",
    "ARM_KINDS",
    "ArmConfig",
    "CAN_INTERFACES",
    "CAN_KEYS",
    "CollisionBox",
    "DXL_MAX_BAUD",
    "DXL_MAX_PROFILE",
    "DYNAMIXEL_JOINT_KEYS",
    "DynamixelConfig",
    "FingerConfig",
    "GraspConfig",
    "HandConfig",
    "JointConfig",
    "MAX_ANGLE_RAD",
    "MAX_FINGER_BASE_M",
    "MAX_FINGER_LINK_M",
    "MAX_OFFSET_M",
    "MIN_CLOSING_COMPONENT",
    "SAFE_ACTIONS",
    "SERIAL_MAX_BAUD",
    "SERIAL_MODES",
    "SafetyConfig",
    "TORQUE_PD_KEYS",
    "TactileConfig",
    "TorquePDConfig",
    "Vec3",
    "load_hand",
]


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
