"""Servo configuration shared by the hand and the arm (EEPROM needs torque off)."""

from __future__ import annotations

from collections.abc import Sequence

from grasp_ctrl.config.hand import DynamixelConfig, JointConfig
from grasp_ctrl.hardware.dynamixel import control_table as ct
from grasp_ctrl.hardware.dynamixel.bus import DynamixelBus
from grasp_ctrl.hardware.dynamixel.calibration import Calibration


def current_units(amps: float, model: ct.ServoModel | None) -> int:
    unit = model.amp_per_current_unit if model else 0.001
    top = model.max_current_limit if model else 1750
    return max(1, min(top, int(round(amps / unit))))


def configure_servos(
    bus: DynamixelBus,
    joints: Sequence[JointConfig],
    model: ct.ServoModel | None,
    dxl: DynamixelConfig | None = None,
) -> None:
    """Torque off, then per servo: return delay 0, current-based position mode,
    current limit, position limits (from the joint limits through the
    calibration), goal current, profile and (optionally) gains. Every write is
    checked; a refusal raises HardwareError naming the joint and register."""
    lo, hi = Calibration.from_joints(list(joints)).limit_counts()
    for k, j in enumerate(joints):
        i = j.servo_id
        limit = current_units(j.current_limit_a, model)
        bus.write(i, ct.ADDR_TORQUE_ENABLE, 1, 0)
        bus.write(i, ct.ADDR_RETURN_DELAY_TIME, 1, 0)
        bus.write(i, ct.ADDR_OPERATING_MODE, 1, ct.MODE_CURRENT_BASED_POSITION)
        bus.write(i, ct.ADDR_CURRENT_LIMIT, 2, limit)
        bus.write(i, ct.ADDR_MAX_POSITION_LIMIT, 4, int(hi[k]))
        bus.write(i, ct.ADDR_MIN_POSITION_LIMIT, 4, int(lo[k]))
        bus.write(i, ct.ADDR_GOAL_CURRENT, 2, limit)
        if dxl is None:
            continue
        bus.write(i, ct.ADDR_PROFILE_ACCELERATION, 4, dxl.profile_acceleration)
        bus.write(i, ct.ADDR_PROFILE_VELOCITY, 4, dxl.profile_velocity)
        for addr, gain in (
            (ct.ADDR_POSITION_P_GAIN, dxl.position_p_gain),
            (ct.ADDR_POSITION_I_GAIN, dxl.position_i_gain),
            (ct.ADDR_POSITION_D_GAIN, dxl.position_d_gain),
        ):
            if gain is not None:
                bus.write(i, addr, 2, min(16383, int(round(gain * j.gain_scale))))
