"""Dynamixel X-series servo models: the register units the bus needs and the data-sheet
facts the controller and the simulated worlds need, in one table by model name (the hand
file's ``[dynamixel] model``).

Model numbers as the servos report them on PING (XC330-M288-T, XC330-T288-T and XL330-M288-T
checked against the ROBOTIS e-manual; the others from the same tables, unverified here).
Torque and speed facts are given only where taken from the data sheet: XC330-M288-T, stall
torque 0.93 N m at 1.8 A and 5 V, no-load speed 103 rpm; PWM limit 885 (X330 series).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

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

    @property
    def known_torque(self) -> bool:
        return self.stall_torque_nm is not None and self.stall_current_a is not None

    @property
    def torque_per_amp_nm(self) -> float:
        """Stall torque / stall current (N m/A): the current-based torque limit's scale."""
        if not self.known_torque:
            raise UsageError(f"servo model {self.name}: no stall torque and current known here")
        return self.stall_torque_nm / self.stall_current_a  # type: ignore[operator]

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


MODELS: dict[str, ServoModel] = {
    m.name: m
    for m in (
        ServoModel(
            "XC330-M288-T", 1240, 0.001, 2352, stall_torque_nm=0.93, stall_current_a=1.8, no_load_speed_rpm=103.0
        ),  # checked against the e-manual table
        ServoModel("XC330-M181-T", 1230, 0.001, 1750),
        ServoModel("XC330-T288-T", 1220, 0.001, 1750),
        ServoModel("XC330-T181-T", 1210, 0.001, 1750),
        ServoModel("XL330-M288-T", 1200, 0.001, 1750),
        ServoModel("XL330-M077-T", 1190, 0.001, 1750),
        ServoModel("XM430-W350-T", 1020, 0.00269, 1193),
        ServoModel("XM430-W210-T", 1030, 0.00269, 1193),
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
