"""The Allegro Hand v4's CAN frames: ids, byte layouts, scaling, and the joints' conventions.

Facts from Wonik Robotics / SimLab's ROS driver ``simlabrobotics/allegro_hand_ros_v4`` (BSD-3):
``allegro_hand_driver/src/candrv/candef.h`` (command and request ids), ``pcan.cpp`` (the frame
layouts, the id shift) and ``AllegroHandDrv.cpp`` (the replies' layouts and the scaling). Only
those facts are used here; the code is this project's.

- Every frame is a standard (11-bit) frame; its id is ``(command << 2) | device_id``, the device id
  in the two low bits (``pcan.cpp``: ``canSendMsg``; a reply's command is ``(id & ~3) >> 2``).
- ``SYSTEM_ON`` / ``SYSTEM_OFF`` (0x40 / 0x41): no data. The driver turns the system off at start,
  sets the report period, then turns it on.
- ``SET_TORQUE`` (0x60 + finger): four int16 little-endian PWM values, the finger's joints 0-3.
- ``SET_PERIOD`` (0x81): three int16 little-endian periods in ms: joint positions, IMU,
  temperature; 0 stops that report (the driver asks for positions every 3 ms).
- Requests are remote (RTR) frames without data: ``HAND_INFO`` 0x80, ``SERIAL`` 0x88,
  ``FINGER_POSE`` 0x20 + finger, ``IMU`` 0x30, ``TEMPERATURE`` 0x38 + sensor (four sensors). The
  hand answers (or reports periodically) with a data frame of the same command:
  - finger pose: four int16 little-endian joint positions, ``333.3 / 65536`` degree per count;
  - hand info: hardware version (uint16 LE, bytes 0-1; 4 on a v4), firmware version (uint16 LE,
    bytes 2-3), hand type (byte 4: 0 right, else left), temperature in degC (byte 5), status
    (byte 6: bit 0 servo on, bit 1 high-temperature fault, bit 2 internal communication fault);
  - serial: eight ASCII characters;
  - temperature: int32 little-endian degC.
- Torque: PWM = torque (N m) x 1200 on a v4 (``_tau_cov_const``; 800 on a v3), truncated to an
  integer, within +-1200 at 12 V (``PWM_LIMIT_GLOBAL_12V``). Here both numbers are the hand
  file's ``[torque_pd] pwm_per_nm`` and ``pwm_limit``.

Joint conventions: the hand file's joint ``servo_id`` is ``finger x 4 + joint`` (the driver's
joint order: index, middle, ring ("pinky"), thumb). The v4 driver applies no encoder offset or
direction; the hand file's ``offset_rad`` and ``sign`` (defaults 0 and +1, as the driver) map
them: ``q = sign x (counts x RAD_PER_COUNT - offset_rad)`` and ``pwm = sign x tau x pwm_per_nm``
(one sign for encoder and motor: the v3 calibration files give them equal on every joint).

Decoding takes frames from the wire: anything malformed (wrong length, a remote or extended
frame where a data frame is due, an unknown command) raises ``ProtocolError``, never anything else.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.errors import UsageError

# Commands (candef.h)
CMD_SYSTEM_ON = 0x40
CMD_SYSTEM_OFF = 0x41
CMD_SET_TORQUE = 0x60  # + finger 0-3
CMD_SET_POSE = 0xE0  # + finger 0-3 (the hand's own position mode; not used here)
CMD_SET_PERIOD = 0x81
CMD_CONFIG = 0x68  # device id / RS-485 baud rate (not used here)
# Requests (remote frames) and the replies' commands (candef.h)
RTR_HAND_INFO = 0x80
RTR_SERIAL = 0x88
RTR_FINGER_POSE = 0x20  # + finger 0-3
RTR_IMU = 0x30
RTR_TEMPERATURE = 0x38  # + sensor 0-3

N_FINGERS = 4
JOINTS_PER_FINGER = 4
N_JOINTS = N_FINGERS * JOINTS_PER_FINGER
N_TEMPERATURE_SENSORS = 4
MAX_STD_ID = 0x7FF
DEVICE_ID_MASK = 0x3
# Joint position: 333.3 / 65536 degree per count (AllegroHandDrv.cpp, _parseMessage)
RAD_PER_COUNT = 333.3 / 65536.0 * math.pi / 180.0
INT16_MIN, INT16_MAX = -32768, 32767
# The hand info's status bits (AllegroHandDrv.cpp)
STATUS_SERVO_ON = 0x01
STATUS_HIGH_TEMPERATURE = 0x02
STATUS_INTERNAL_COMM_FAULT = 0x04

_I16x4 = struct.Struct("<4h")
_I16x3 = struct.Struct("<3h")
_U16x2 = struct.Struct("<2H")
_I32 = struct.Struct("<i")


class ProtocolError(ValueError):
    """A frame that is not what the Allegro protocol says it should be."""


@dataclass(frozen=True)
class CanFrame:
    """One classic CAN frame, independent of python-can (hardware/allegro/bus.py converts)."""

    arbitration_id: int
    data: bytes = b""
    is_remote: bool = False
    is_extended: bool = False
    is_error: bool = False  # an error frame from the controller (bus errors, bus-off)
    timestamp: float = 0.0  # s, the receiver's clock (0: unknown)

    @property
    def command(self) -> int:
        return (self.arbitration_id & ~DEVICE_ID_MASK) >> 2

    @property
    def device_id(self) -> int:
        return self.arbitration_id & DEVICE_ID_MASK


@dataclass(frozen=True)
class HandInfo:
    hardware_version: int
    firmware_version: int
    right_hand: bool
    temperature_c: int
    status: int

    @property
    def servo_on(self) -> bool:
        return bool(self.status & STATUS_SERVO_ON)

    @property
    def high_temperature(self) -> bool:
        return bool(self.status & STATUS_HIGH_TEMPERATURE)

    @property
    def internal_comm_fault(self) -> bool:
        return bool(self.status & STATUS_INTERNAL_COMM_FAULT)

    def faults(self) -> list[str]:
        out = []
        if self.high_temperature:
            out.append("high-temperature fault")
        if self.internal_comm_fault:
            out.append("internal communication fault")
        return out


@dataclass(frozen=True)
class FingerPose:
    finger: int  # 0-3
    counts: tuple[int, int, int, int]


@dataclass(frozen=True)
class Temperature:
    sensor: int  # 0-3
    celsius: int


Reply = FingerPose | HandInfo | Temperature | str  # str: the serial number


# ---- ids ------------------------------------------------------------------------------------
def wire_id(command: int, device_id: int = 0) -> int:
    """The 11-bit frame id of ``command`` for the hand with ``device_id`` (0-3)."""
    if not 0 <= device_id <= DEVICE_ID_MASK:
        raise ValueError(f"device id 0-3 (got {device_id})")
    arb = (command << 2) | device_id
    if not 0 <= arb <= MAX_STD_ID:
        raise ValueError(f"command 0x{command:x} does not fit a standard frame id")
    return arb


def _finger(finger: int) -> int:
    if not 0 <= finger < N_FINGERS:
        raise ValueError(f"finger 0-3 (got {finger})")
    return finger


# ---- host -> hand -------------------------------------------------------------------------
def system_on(device_id: int = 0) -> CanFrame:
    return CanFrame(wire_id(CMD_SYSTEM_ON, device_id))


def system_off(device_id: int = 0) -> CanFrame:
    return CanFrame(wire_id(CMD_SYSTEM_OFF, device_id))


def set_torque(finger: int, pwm: tuple[int, int, int, int] | list[int], device_id: int = 0) -> CanFrame:
    """One finger's four PWM values (each an int16)."""
    values = [int(v) for v in pwm]
    if len(values) != JOINTS_PER_FINGER or any(not INT16_MIN <= v <= INT16_MAX for v in values):
        raise ValueError(f"four int16 PWM values (got {pwm})")
    return CanFrame(wire_id(CMD_SET_TORQUE + _finger(finger), device_id), _I16x4.pack(*values))


def set_period(position_ms: int, imu_ms: int = 0, temperature_ms: int = 0, device_id: int = 0) -> CanFrame:
    """The hand's report periods in ms (0 stops a report)."""
    values = (position_ms, imu_ms, temperature_ms)
    if any(not 0 <= v <= INT16_MAX for v in values):
        raise ValueError(f"periods 0-32767 ms (got {values})")
    return CanFrame(wire_id(CMD_SET_PERIOD, device_id), _I16x3.pack(*values))


def request(command: int, device_id: int = 0) -> CanFrame:
    """A remote frame asking for ``command``'s data (RTR_*)."""
    return CanFrame(wire_id(command, device_id), b"", is_remote=True)


def request_finger_pose(finger: int, device_id: int = 0) -> CanFrame:
    return request(RTR_FINGER_POSE + _finger(finger), device_id)


def request_temperature(sensor: int, device_id: int = 0) -> CanFrame:
    if not 0 <= sensor < N_TEMPERATURE_SENSORS:
        raise ValueError(f"temperature sensor 0-3 (got {sensor})")
    return request(RTR_TEMPERATURE + sensor, device_id)


# ---- hand -> host (the emulator writes these) -------------------------------------------------
def finger_pose(finger: int, counts: tuple[int, int, int, int] | list[int], device_id: int = 0) -> CanFrame:
    values = [int(v) for v in counts]
    if len(values) != JOINTS_PER_FINGER or any(not INT16_MIN <= v <= INT16_MAX for v in values):
        raise ValueError(f"four int16 position counts (got {counts})")
    return CanFrame(wire_id(RTR_FINGER_POSE + _finger(finger), device_id), _I16x4.pack(*values))


def hand_info(info: HandInfo, device_id: int = 0) -> CanFrame:
    data = _U16x2.pack(info.hardware_version, info.firmware_version) + bytes(
        [0 if info.right_hand else 1, info.temperature_c & 0xFF, info.status & 0xFF, 0]
    )
    return CanFrame(wire_id(RTR_HAND_INFO, device_id), data)


def serial_number(text: str, device_id: int = 0) -> CanFrame:
    raw = text.encode("ascii")
    if len(raw) != 8:
        raise ValueError(f"eight ASCII characters (got {text!r})")
    return CanFrame(wire_id(RTR_SERIAL, device_id), raw)


def temperature(sensor: int, celsius: int, device_id: int = 0) -> CanFrame:
    if not 0 <= sensor < N_TEMPERATURE_SENSORS:
        raise ValueError(f"temperature sensor 0-3 (got {sensor})")
    return CanFrame(wire_id(RTR_TEMPERATURE + sensor, device_id), _I32.pack(int(celsius)))


# ---- decoding ---------------------------------------------------------------------------------
def _data_frame(frame: CanFrame, what: str, length: int | tuple[int, ...]) -> bytes:
    if frame.is_error:
        raise ProtocolError(f"{what}: an error frame")
    if frame.is_extended or not 0 <= frame.arbitration_id <= MAX_STD_ID:
        raise ProtocolError(f"{what}: not a standard frame id (0x{frame.arbitration_id:x})")
    if frame.is_remote:
        raise ProtocolError(f"{what}: a remote frame where data is due")
    data = bytes(frame.data)
    lengths = (length,) if isinstance(length, int) else length
    if len(data) not in lengths:
        raise ProtocolError(f"{what}: {len(data)} data bytes (expected {' or '.join(map(str, lengths))})")
    return data


def decode_reply(frame: CanFrame) -> Reply:
    """A frame from the hand as what it carries; ``ProtocolError`` for anything else."""
    cmd = frame.command
    if RTR_FINGER_POSE <= cmd < RTR_FINGER_POSE + N_FINGERS:
        counts = _I16x4.unpack(_data_frame(frame, "finger pose", 8))
        return FingerPose(cmd - RTR_FINGER_POSE, (counts[0], counts[1], counts[2], counts[3]))
    if cmd == RTR_HAND_INFO:
        data = _data_frame(frame, "hand info", (7, 8))
        hw, fw = _U16x2.unpack_from(data)
        return HandInfo(hw, fw, data[4] == 0, data[5], data[6])
    if cmd == RTR_SERIAL:
        data = _data_frame(frame, "serial number", 8)
        if not all(32 <= b < 127 for b in data):
            raise ProtocolError("serial number: not printable ASCII")
        return data.decode("ascii")
    if RTR_TEMPERATURE <= cmd < RTR_TEMPERATURE + N_TEMPERATURE_SENSORS:
        data = _data_frame(frame, "temperature", (4, 8))
        return Temperature(cmd - RTR_TEMPERATURE, _I32.unpack_from(data)[0])
    raise ProtocolError(f"unknown reply 0x{cmd:02x} (frame id 0x{frame.arbitration_id:03x})")


def decode_torque(frame: CanFrame) -> tuple[int, tuple[int, int, int, int]]:
    """(finger, four PWM values) of a SET_TORQUE frame (the emulator's side)."""
    cmd = frame.command
    if not CMD_SET_TORQUE <= cmd < CMD_SET_TORQUE + N_FINGERS:
        raise ProtocolError(f"not a torque command (0x{cmd:02x})")
    pwm = _I16x4.unpack(_data_frame(frame, "torque", 8))
    return cmd - CMD_SET_TORQUE, (pwm[0], pwm[1], pwm[2], pwm[3])


def decode_period(frame: CanFrame) -> tuple[int, int, int]:
    """(position, IMU, temperature) report periods in ms of a SET_PERIOD frame."""
    if frame.command != CMD_SET_PERIOD:
        raise ProtocolError(f"not a period command (0x{frame.command:02x})")
    a, b, c = _I16x3.unpack(_data_frame(frame, "period", 6))
    return a, b, c


# ---- the hand file's joints on the bus --------------------------------------------------------
@dataclass(frozen=True)
class JointMap:
    """The hand file's joints (their order) on the bus: each joint's finger and slot, its
    offset and sign, and the torque scaling and limits in PWM units."""

    finger: np.ndarray  # (n,) int
    slot: np.ndarray  # (n,) int, the joint within its finger's frames
    offset_rad: np.ndarray
    sign: np.ndarray  # +-1.0
    pwm_per_nm: float
    pwm_limit: float
    torque_limit_nm: np.ndarray  # each joint's (the hand file's), within pwm_limit / pwm_per_nm
    device_id: int = 0

    @classmethod
    def from_hand(cls, hand: HandConfig) -> JointMap:
        if hand.torque_pd is None:
            raise UsageError(f"hand {hand.name!r} ({hand.path}): no [torque_pd] table (actuator = {hand.actuator!r})")
        tp = hand.torque_pd
        ids = [j.servo_id for j in hand.joints]
        bad = [f"{j.name} ({j.servo_id})" for j in hand.joints if not 0 <= j.servo_id < N_JOINTS]
        if bad:
            raise UsageError(
                f"{hand.path}: servo_id on the Allegro's CAN bus is finger x 4 + joint, 0-15; not: {', '.join(bad)}"
            )
        limits = np.array([j.torque_limit_nm or 0.0 for j in hand.joints], dtype=float)
        return cls(
            finger=np.array([i // JOINTS_PER_FINGER for i in ids], dtype=int),
            slot=np.array([i % JOINTS_PER_FINGER for i in ids], dtype=int),
            offset_rad=np.array([j.offset_rad for j in hand.joints], dtype=float),
            sign=np.array([float(j.sign) for j in hand.joints]),
            pwm_per_nm=tp.pwm_per_nm,
            pwm_limit=tp.pwm_limit,
            torque_limit_nm=np.minimum(limits, tp.pwm_limit / tp.pwm_per_nm),
            device_id=tp.can_device_id,
        )

    @property
    def fingers(self) -> tuple[int, ...]:
        """The fingers that carry at least one of the hand file's joints."""
        return tuple(sorted(set(self.finger.tolist())))

    def joints_rad(self, counts_by_finger: np.ndarray) -> np.ndarray:
        """(4, 4) counts (finger, slot) -> the hand file's joint angles (rad)."""
        raw = counts_by_finger[self.finger, self.slot] * RAD_PER_COUNT
        return self.sign * (raw - self.offset_rad)

    def counts(self, q_rad: np.ndarray) -> np.ndarray:
        """The hand file's joint angles -> (4, 4) int16 counts (joints not in the file: 0)."""
        out = np.zeros((N_FINGERS, JOINTS_PER_FINGER), dtype=np.int64)
        raw = np.asarray(q_rad, dtype=float) * self.sign + self.offset_rad
        out[self.finger, self.slot] = np.clip(np.rint(raw / RAD_PER_COUNT), INT16_MIN, INT16_MAX)
        return out

    def clamp_torque(self, tau_nm: np.ndarray) -> np.ndarray:
        """Each joint's torque within its limit; a non-finite torque becomes 0."""
        tau = np.asarray(tau_nm, dtype=float)
        tau = np.where(np.isfinite(tau), tau, 0.0)
        return np.clip(tau, -self.torque_limit_nm, self.torque_limit_nm)

    def pwm(self, tau_nm: np.ndarray) -> np.ndarray:
        """The hand file's joint torques (N m) -> (4, 4) PWM values, each within its joint's
        limit (clamped first, then truncated toward zero as the driver casts); unlisted joints 0."""
        tau = self.clamp_torque(tau_nm)
        out = np.zeros((N_FINGERS, JOINTS_PER_FINGER), dtype=np.int64)
        out[self.finger, self.slot] = np.trunc(self.sign * tau * self.pwm_per_nm)
        return out

    def torque_nm(self, pwm_by_finger: np.ndarray) -> np.ndarray:
        """(4, 4) PWM values -> the hand file's joint torques (N m)."""
        return self.sign * pwm_by_finger[self.finger, self.slot] / self.pwm_per_nm

    def torque_frames(self, tau_nm: np.ndarray) -> list[CanFrame]:
        """The four SET_TORQUE frames for the joints' torques (clamped)."""
        return self.pwm_frames(self.pwm(tau_nm))

    def pwm_frames(self, pwm: np.ndarray) -> list[CanFrame]:
        """The four SET_TORQUE frames of (4, 4) PWM values (``pwm``'s output)."""
        return [set_torque(f, pwm[f].tolist(), self.device_id) for f in range(N_FINGERS)]

    def zero_torque_frames(self) -> list[CanFrame]:
        return [set_torque(f, [0, 0, 0, 0], self.device_id) for f in range(N_FINGERS)]
