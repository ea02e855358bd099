"""X-series (XC330 / XL330 / XM430) Protocol 2.0 control table and units.

Addresses and sizes from the ROBOTIS e-manual's X-series control table.
"""

from __future__ import annotations

import math

# The servo models (register units and data-sheet facts) live with the configuration, where
# the controller and the simulated worlds read them too.
from grasp_ctrl.config.servos import MODELS, ServoModel, model_by_number  # noqa: F401  (re-exported)

# EEPROM (writable with torque off only)
ADDR_MODEL_NUMBER = 0  # 2
ADDR_RETURN_DELAY_TIME = 9  # 1 (x2 us)
ADDR_OPERATING_MODE = 11  # 1
ADDR_TEMPERATURE_LIMIT = 31  # 1 (1 degC)
ADDR_MAX_VOLTAGE_LIMIT = 32  # 2 (0.1 V)
ADDR_MIN_VOLTAGE_LIMIT = 34  # 2 (0.1 V)
ADDR_CURRENT_LIMIT = 38  # 2
ADDR_MAX_POSITION_LIMIT = 48  # 4
ADDR_MIN_POSITION_LIMIT = 52  # 4
# RAM
ADDR_TORQUE_ENABLE = 64  # 1
ADDR_HARDWARE_ERROR_STATUS = 70  # 1
ADDR_POSITION_D_GAIN = 80  # 2
ADDR_POSITION_I_GAIN = 82  # 2
ADDR_POSITION_P_GAIN = 84  # 2
ADDR_GOAL_CURRENT = 102  # 2
ADDR_PROFILE_ACCELERATION = 108  # 4
ADDR_PROFILE_VELOCITY = 112  # 4
ADDR_GOAL_POSITION = 116  # 4
ADDR_PRESENT_CURRENT = 126  # 2  \
ADDR_PRESENT_VELOCITY = 128  # 4   } read together, one sync read per tick
ADDR_PRESENT_POSITION = 132  # 4  /
ADDR_PRESENT_INPUT_VOLTAGE = 144  # 2 (0.1 V)
ADDR_PRESENT_TEMPERATURE = 146  # 1 (1 degC)
VOLT_PER_UNIT = 0.1
STATE_START = ADDR_PRESENT_CURRENT
STATE_LENGTH = 10

MODE_CURRENT_BASED_POSITION = 5

# Hardware Error Status bits (address 70).
HARDWARE_ERROR_BITS: dict[int, str] = {
    0x01: "input_voltage",
    0x04: "overheating",
    0x08: "motor_encoder",
    0x10: "electrical_shock",
    0x20: "overload",
}

COUNTS_PER_REV = 4096
CENTER_COUNTS = 2048
RAD_PER_COUNT = 2.0 * math.pi / COUNTS_PER_REV
RAD_S_PER_VELOCITY_UNIT = 0.229 * 2.0 * math.pi / 60.0  # 0.229 rpm per unit


def hardware_error_names(bits: int) -> list[str]:
    names = [name for bit, name in HARDWARE_ERROR_BITS.items() if bits & bit]
    unknown = bits & ~sum(HARDWARE_ERROR_BITS)
    if unknown:
        names.append(f"unknown_bits_0x{unknown:02x}")
    return names
