"""The seams between the controller and the hardware (real or mocked).

The controller and the trial runner only talk to these interfaces, so the
mock world, the Dynamixel hand and the serial sensors are interchangeable.
All quantities are SI; joint vectors follow the hand file's joint order.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np

#: How long a start-up waits for every fingertip's first frames before naming the silent ones
#: (generous: a loaded host delays them; a sensor that is really silent is still named).
FIRST_FRAMES_TIMEOUT_S = 5.0


class JointState(NamedTuple):  # immutable, and cheap to make every tick
    q: np.ndarray  # rad
    dq: np.ndarray  # rad/s
    current_a: np.ndarray  # A (signed, as reported)
    t: float  # s, clock time of the read


@runtime_checkable
class HandBackend(Protocol):
    """A position-controlled hand. ``write_goals`` must never send a goal outside
    the configured joint limits (implementations clamp)."""

    def connect(self) -> None: ...
    def read(self) -> JointState: ...
    def write_goals(self, q_goal: np.ndarray) -> None: ...
    def set_torque(self, enabled: bool) -> None: ...
    def check_health(self) -> None:
        """Raise HardwareError if a servo reports a fault."""
        ...

    def close(self) -> None: ...


@runtime_checkable
class ArmBackend(Protocol):
    """Moves the hand's palm in the world (reach, straight vertical lift and lower)."""

    def connect(self) -> None: ...
    def command(self, p_world: np.ndarray) -> None:
        """Set the palm position target; the arm moves there at its speed limit."""
        ...

    def position(self) -> np.ndarray: ...
    def stop(self) -> None: ...
    def close(self) -> None: ...


@dataclass(frozen=True)
class TactileFrame:
    sensor_id: int
    seq: int
    t_recv: float  # s, clock time the frame was received
    values: np.ndarray  # (44,) raw counts, BioTac order


@runtime_checkable
class SensorBackend(Protocol):
    """Fingertip sensors. ``read_latest`` never blocks: it returns the newest
    valid frame per sensor id received so far (absent ids have no frame yet)."""

    def start(self) -> None: ...
    def read_latest(self) -> dict[int, TactileFrame]: ...
    def stats(self) -> dict[str, int]: ...
    def close(self) -> None: ...


class Clock(Protocol):
    def now(self) -> float: ...
