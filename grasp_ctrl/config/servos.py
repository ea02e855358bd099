"""Dynamixel X-series servo models: the register units the bus needs and the data-sheet
facts the controller and the simulated worlds need, in one table by model name (the hand
file's ``[dynamixel] model``).

Model numbers as the servos report them on PING (XC330-M288-T, XC330-T288-T and XL330-M288-T
checked against the ROBOTIS e-manual; the others from the same tables, unverified here).
Torque and speed facts are given only where taken from the data sheet: XC330-M288-T, stall
torque 0.93 N m at 1.8 A and 5 V, no-load speed 103 rpm; PWM limit 885 (X330 series).

Ratings (what a hand file may ask of a servo; config/hand_sections.py refuses more): the stall current at
the recommended voltage, and the control-table ranges of Current Limit(38), Velocity Limit(44)
(which bounds Goal Velocity(104) and Profile Velocity(112)) and Position P/I/D Gain(84/82/80), from
the ROBOTIS e-Manual (emanual.robotis.com/docs/en/dxl/x/MODEL/: its specifications and control
table). A figure the e-Manual pages did not give is None here and not checked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TypedDict

from grasp_ctrl.errors import UsageError


@dataclass(frozen=True)
class ServoModel:
    name: str
    model_number: int
    amp_per_current_unit: float  # Present/Goal Current, Current Limit unit
    max_current_limit: int  # largest Current Limit register value
    has_current_control: bool = True
    stall_torque_nm: float | None = None  # data sheet, at the rated voltage
    stall_current_a: float | None = None
    no_load_speed_rpm: float | None = None
    pwm_limit: int = 885  # full PWM duty in register units
    pulses_per_rev: int = 4096
    # ratings: stall current at this (the recommended) voltage; register ranges
    stall_voltage_v: float | None = None
    max_velocity_limit: int | None = None  # Velocity Limit(44) range: bounds Goal and Profile Velocity
    velocity_unit_rpm: float = 0.229  # Velocity Limit / Goal / Profile Velocity unit (velocity-based profile)
    max_position_gain: int | None = None  # Position P/I/D Gain(84/82/80) range 0 .. this

    @property
    def max_current_a(self) -> float:
        """The Current Limit register's largest value in A."""
        return self.max_current_limit * self.amp_per_current_unit

    @property
    def known_torque(self) -> bool:
        return self.stall_torque_nm is not None and self.stall_current_a is not None

    @property
    def torque_per_amp_nm(self) -> float:
        """Stall torque / stall current (N m/A): the current-based torque limit's scale."""
        torque, current = self.stall_torque_nm, self.stall_current_a
        if torque is None or current is None:  # not known_torque
            raise UsageError(f"servo model {self.name}: no stall torque and current known here")
        return torque / current

    @property
    def no_load_speed_rad_s(self) -> float:
        if self.no_load_speed_rpm is None:
            raise UsageError(f"servo model {self.name}: no no-load speed known here")
        return self.no_load_speed_rpm * 2.0 * math.pi / 60.0

    def kp_nm_per_rad(self, p_gain: float) -> float:
        """Position-mode stiffness: the P term's PWM duty, (P/128) per encoder pulse out of the
        PWM limit; a full duty at stall gives the stall torque."""
        if self.stall_torque_nm is None:
            raise UsageError(f"servo model {self.name}: no stall torque known here")
        pulses_per_rad = self.pulses_per_rev / (2.0 * math.pi)
        return (p_gain / 128.0) / self.pwm_limit * pulses_per_rad * self.stall_torque_nm

    def kv_nm_s_per_rad(self, d_gain: float) -> float:
        """Position-mode damping: (D/16) per encoder pulse per millisecond of PWM duty."""
        if self.stall_torque_nm is None:
            raise UsageError(f"servo model {self.name}: no stall torque known here")
        pulses_per_rad = self.pulses_per_rev / (2.0 * math.pi)
        return (d_gain / 16.0) / self.pwm_limit * pulses_per_rad * 1e-3 * self.stall_torque_nm


class _Ratings(TypedDict):
    """Register ranges shared by a servo series (ServoModel's fields of the same names)."""

    max_velocity_limit: int
    max_position_gain: int


# The X330 series: Velocity Limit 0 ~ 2,047 and position gains 0 ~ 16,383 on every X330 page of the
# e-Manual; XM430: Velocity Limit 0 ~ 1,023 (the XM430 pages' shared Velocity Limit table) and
# position gains 0 ~ 16,383 (their shared Position PID Gain table).
_X330: _Ratings = {"max_velocity_limit": 2047, "max_position_gain": 16383}
_XM430: _Ratings = {"max_velocity_limit": 1023, "max_position_gain": 16383}

MODELS: dict[str, ServoModel] = {
    m.name: m
    for m in (
        ServoModel(
            "XC330-M288-T",
            1240,
            0.001,
            2352,
            stall_torque_nm=0.93,
            stall_current_a=1.8,
            no_load_speed_rpm=103.0,
            stall_voltage_v=5.0,
            **_X330,
        ),  # checked against the e-manual table
        # Stall currents below: the e-Manual's specifications at the recommended voltage (their
        # stall torques and speeds are left out: the simulation reads torque facts only where
        # checked). Current Limit ranges: the control tables (XC330-M181-T 0 ~ 2,352, XC330-T288-T
        # and -T181-T 0 ~ 910; this table had 1,750 for all three before).
        ServoModel("XC330-M181-T", 1230, 0.001, 2352, stall_current_a=1.8, stall_voltage_v=5.0, **_X330),
        ServoModel("XC330-T288-T", 1220, 0.001, 910, stall_current_a=0.8, stall_voltage_v=11.1, **_X330),
        ServoModel("XC330-T181-T", 1210, 0.001, 910, stall_current_a=0.8, stall_voltage_v=11.1, **_X330),
        ServoModel("XL330-M288-T", 1200, 0.001, 1750, stall_current_a=1.47, stall_voltage_v=5.0, **_X330),
        # XL330-M077-T: stall current not found in the e-Manual pages read; the Current Limit range is checked
        ServoModel("XL330-M077-T", 1190, 0.001, 1750, **_X330),
        ServoModel("XM430-W350-T", 1020, 0.00269, 1193, stall_current_a=2.3, stall_voltage_v=12.0, **_XM430),
        # XM430-W210-T: stall current not read from its e-Manual page here; the Current Limit range is checked
        ServoModel("XM430-W210-T", 1030, 0.00269, 1193, **_XM430),
    )
}


def servo_model(name: str) -> ServoModel:
    try:
        return MODELS[name]
    except KeyError:
        raise UsageError(f"servo model {name!r}: unknown (one of {', '.join(MODELS)})") from None


def model_by_number(number: int) -> ServoModel | None:
    for m in MODELS.values():
        if m.model_number == number:
            return m
    return None
