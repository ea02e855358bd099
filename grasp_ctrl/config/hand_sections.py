"""The hand file's section parsers: fingers and their joints, collision boxes, custom servo
models and the servos' ratings, the joints' actuation ([torque_pd] or [dynamixel] per-joint
keys) and the controller choices, each reading its tables and refusing a bad value with
the file and key (config/hand.py's ``load_hand`` calls them).
"""

from __future__ import annotations

import math
from typing import Any

from grasp_ctrl.config.hand_types import (
    CAN_INTERFACES,
    CAN_KEYS,
    DXL_MAX_PROFILE,
    DYNAMIXEL_JOINT_KEYS,
    MAX_ANGLE_RAD,
    MAX_FINGER_BASE_M,
    MAX_FINGER_LINK_M,
    MAX_OFFSET_M,
    MIN_CLOSING_COMPONENT,
    TORQUE_PD_KEYS,
    ArmConfig,
    CollisionBox,
    DynamixelConfig,
    FingerConfig,
    JointConfig,
    TorquePDConfig,
    Vec3,
)
from grasp_ctrl.config.identifiers import check_identifier
from grasp_ctrl.config.servos import MODELS as SERVO_MODELS
from grasp_ctrl.config.servos import ServoModel
from grasp_ctrl.config.toml_reader import Table

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
