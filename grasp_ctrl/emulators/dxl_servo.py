"""One emulated X-series servo: control table memory and motor physics.

The control table addresses are those of the ROBOTIS X-series (XC330/XL330/
XM430) Protocol 2.0 table. EEPROM (addresses < 64) is writable only with
torque off, as on the real servo. The motor tracks its goal position like a
current-based position controller: a proportional current demand, clipped to
the current limit (and to Goal Current in mode 5), drives the velocity; a
blocked joint saturates the current and, after a while, trips the overload
bit of Hardware Error Status, which turns the torque off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

# (address, size) of the fields the emulator gives behaviour to.
MODEL_NUMBER = (0, 2)
FIRMWARE_VERSION = (6, 1)
ID = (7, 1)
BAUD_RATE = (8, 1)
RETURN_DELAY = (9, 1)
DRIVE_MODE = (10, 1)
OPERATING_MODE = (11, 1)
HOMING_OFFSET = (20, 4)
TEMPERATURE_LIMIT = (31, 1)
MAX_VOLTAGE_LIMIT = (32, 2)
MIN_VOLTAGE_LIMIT = (34, 2)
CURRENT_LIMIT = (38, 2)
VELOCITY_LIMIT = (44, 4)
MAX_POSITION_LIMIT = (48, 4)
MIN_POSITION_LIMIT = (52, 4)
SHUTDOWN = (63, 1)
TORQUE_ENABLE = (64, 1)
LED = (65, 1)
STATUS_RETURN_LEVEL = (68, 1)
HARDWARE_ERROR_STATUS = (70, 1)
POSITION_D_GAIN = (80, 2)
POSITION_I_GAIN = (82, 2)
POSITION_P_GAIN = (84, 2)
GOAL_CURRENT = (102, 2)
PROFILE_ACCELERATION = (108, 4)
PROFILE_VELOCITY = (112, 4)
GOAL_POSITION = (116, 4)
MOVING = (122, 1)
PRESENT_CURRENT = (126, 2)
PRESENT_VELOCITY = (128, 4)
PRESENT_POSITION = (132, 4)
PRESENT_INPUT_VOLTAGE = (144, 2)
PRESENT_TEMPERATURE = (146, 1)

EEPROM_END = 64
TABLE_SIZE = 147 + 1
READ_ONLY = {MODEL_NUMBER[0], MODEL_NUMBER[0] + 1, FIRMWARE_VERSION[0], HARDWARE_ERROR_STATUS[0]} | set(
    range(MOVING[0], TABLE_SIZE)
)

MODE_CURRENT = 0
MODE_POSITION = 3
MODE_EXTENDED_POSITION = 4
MODE_CURRENT_POSITION = 5

HW_OVERLOAD = 0x20

VELOCITY_UNIT_RAD_S = 0.229 * 2.0 * math.pi / 60.0
COUNTS_PER_RAD = 4096 / (2.0 * math.pi)


@dataclass
class MotorModel:
    """Crude but monotone: current demand grows with the position error, speed with current."""

    current_per_count_ma: float = 4.0  # proportional current demand per count of error
    speed_per_ma_counts_s: float = 20.0  # counts/s of speed per mA of (unsaturated) current
    max_speed_counts_s: float = 8000.0  # ~12 rad/s no-load speed
    overload_after_s: float = 1.0  # saturated current this long against a block -> overload


@dataclass
class EmulatedServo:
    dxl_id: int
    model_number: int = 1240
    position_counts: float = 2048.0
    motor: MotorModel = field(default_factory=MotorModel)
    mem: bytearray = field(default_factory=lambda: bytearray(TABLE_SIZE))
    blocked_at: float | None = None  # a wall the joint cannot pass (counts)
    saturated_for_s: float = 0.0
    goal_history: list[int] = field(default_factory=list)  # every goal position written

    def __post_init__(self) -> None:
        self.factory_defaults()

    # ---- memory -------------------------------------------------------------
    def factory_defaults(self) -> None:
        self.mem[:] = bytes(TABLE_SIZE)
        self.set(MODEL_NUMBER, self.model_number)
        self.set(FIRMWARE_VERSION, 52)
        self.set(ID, self.dxl_id)
        self.set(BAUD_RATE, 1)
        self.set(RETURN_DELAY, 250)
        self.set(OPERATING_MODE, MODE_POSITION)
        self.set(TEMPERATURE_LIMIT, 70)  # degC; X330 e-manual defaults
        self.set(MAX_VOLTAGE_LIMIT, 140)  # 0.1 V
        self.set(MIN_VOLTAGE_LIMIT, 55)
        self.set(CURRENT_LIMIT, 1750)
        self.set(VELOCITY_LIMIT, 445)
        self.set(MAX_POSITION_LIMIT, 4095)
        self.set(MIN_POSITION_LIMIT, 0)
        self.set(SHUTDOWN, 0x34)  # overload, electrical shock, overheating
        self.set(STATUS_RETURN_LEVEL, 2)
        self.set(POSITION_P_GAIN, 800)
        self.set(GOAL_CURRENT, 1750)
        self.reset_ram()

    def reset_ram(self) -> None:
        """What a reboot does: RAM back to defaults, EEPROM kept, errors cleared."""
        self.set(TORQUE_ENABLE, 0)
        self.set(HARDWARE_ERROR_STATUS, 0)
        self.set(GOAL_CURRENT, self.get(CURRENT_LIMIT))
        self.set(GOAL_POSITION, int(round(self.position_counts)))
        self.set(PRESENT_INPUT_VOLTAGE, 120)
        self.set(PRESENT_TEMPERATURE, 30)
        self.saturated_for_s = 0.0
        self._publish(0.0, 0.0)

    def get(self, field_: tuple[int, int], signed: bool = False) -> int:
        addr, size = field_
        return int.from_bytes(self.mem[addr : addr + size], "little", signed=signed)

    def set(self, field_: tuple[int, int], value: int) -> None:
        addr, size = field_
        self.mem[addr : addr + size] = int(value).to_bytes(size, "little", signed=value < 0)

    def read(self, addr: int, length: int) -> tuple[int, bytes]:
        if length < 1 or addr + length > TABLE_SIZE:
            return 0x07, b""
        return 0, bytes(self.mem[addr : addr + length])

    def write(self, addr: int, data: bytes) -> int:
        """Apply a WRITE; returns the status result code (0 = ok)."""
        end = addr + len(data)
        if not data or end > TABLE_SIZE:
            return 0x07
        if any(a in READ_ONLY for a in range(addr, end)):
            return 0x07
        if addr < EEPROM_END and self.get(TORQUE_ENABLE):
            return 0x07  # EEPROM is locked while torque is on
        ga, gs = GOAL_POSITION
        if addr <= ga and end >= ga + gs:
            goal = int.from_bytes(data[ga - addr : ga - addr + gs], "little", signed=True)
            self.goal_history.append(goal)
            mode = self.get(OPERATING_MODE)
            # Only Position Control Mode enforces the position-limit registers
            # (current-based position mode is multi-turn and does not).
            if mode == MODE_POSITION and not (
                self.get(MIN_POSITION_LIMIT, True) <= goal <= self.get(MAX_POSITION_LIMIT, True)
            ):
                return 0x06  # data limit: the servo refuses it
        ta = TORQUE_ENABLE[0]
        if addr <= ta < end and data[ta - addr] and self.get(HARDWARE_ERROR_STATUS):
            return 0x01  # cannot enable torque until the error is cleared by a reboot
        self.mem[addr:end] = data
        if addr <= ta < end and data[ta - addr]:
            # Enabling torque latches the present position as the goal if none was set.
            self.saturated_for_s = 0.0
        return 0

    # ---- physics -------------------------------------------------------------
    @property
    def torque_on(self) -> bool:
        return bool(self.get(TORQUE_ENABLE))

    def step(self, dt: float) -> None:
        if dt <= 0.0:
            return
        dt = min(dt, 0.05)  # a stall of the host does not teleport the joint
        if not self.torque_on:
            self._publish(0.0, 0.0)
            return
        limit_ma = float(self.get(CURRENT_LIMIT))
        if self.get(OPERATING_MODE) == MODE_CURRENT_POSITION:
            limit_ma = min(
                limit_ma, float(self.get(GOAL_CURRENT, True)) if self.get(GOAL_CURRENT, True) > 0 else limit_ma
            )
        err = self.get(GOAL_POSITION, True) - self.position_counts
        demand = self.motor.current_per_count_ma * err
        current = max(-limit_ma, min(limit_ma, demand))
        speed = max(
            -self.motor.max_speed_counts_s,
            min(self.motor.max_speed_counts_s, current * self.motor.speed_per_ma_counts_s),
        )
        new_pos = self.position_counts + speed * dt
        # Never overshoot the goal within one step.
        if (err > 0 and new_pos > self.position_counts + err) or (err < 0 and new_pos < self.position_counts + err):
            new_pos = self.position_counts + err
        blocked = False
        if self.blocked_at is not None:
            if self.position_counts <= self.blocked_at < new_pos or self.position_counts >= self.blocked_at > new_pos:
                new_pos = self.blocked_at
            blocked = new_pos == self.blocked_at and abs(err) > 1.0
        if blocked:
            current = math.copysign(limit_ma, err)  # pushing the wall at full current
            self.saturated_for_s += dt
        else:
            self.saturated_for_s = 0.0
        velocity = (new_pos - self.position_counts) / dt
        self.position_counts = new_pos
        self._publish(velocity, current)
        if self.saturated_for_s >= self.motor.overload_after_s:
            self.raise_hardware_error(HW_OVERLOAD)

    def raise_hardware_error(self, bits: int) -> None:
        self.set(HARDWARE_ERROR_STATUS, self.get(HARDWARE_ERROR_STATUS) | bits)
        if bits & self.get(SHUTDOWN):
            self.set(TORQUE_ENABLE, 0)
            self._publish(0.0, 0.0)

    def _publish(self, velocity_counts_s: float, current_ma: float) -> None:
        self.set(PRESENT_POSITION, int(round(self.position_counts)))
        rpm_units = velocity_counts_s / COUNTS_PER_RAD / VELOCITY_UNIT_RAD_S
        self.set(PRESENT_VELOCITY, int(round(rpm_units)))
        self.set(PRESENT_CURRENT, int(round(current_ma)))
        self.set(MOVING, 1 if abs(velocity_counts_s) > 1.0 else 0)

    @property
    def error_byte_alert(self) -> int:
        return 0x80 if self.get(HARDWARE_ERROR_STATUS) else 0
