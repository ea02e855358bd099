"""Serial port setup for a Dynamixel bus: short packet timeout, USB latency timer.

The SDK computes a reply deadline as ``bytes * tx_time_per_byte + 2 *
LATENCY_TIMER + 2`` ms with ``LATENCY_TIMER = 16``: every silent or lost reply
costs ~34 ms, three whole control ticks. ``ShortTimeoutPortHandler`` replaces
the constant part with a configured margin (a few ms is plenty once the FTDI
latency timer is 1 ms).

It also replaces the SDK's busy polling (``read`` with timeout 0 in a tight
loop, burning a core and starving other threads of the GIL) with a ``select``
wait of at most 1 ms when no byte has arrived yet.
"""

from __future__ import annotations

import os
import select
from pathlib import Path

from dynamixel_sdk import PortHandler


class ShortTimeoutPortHandler(PortHandler):
    def __init__(self, port_name: str, margin_ms: float) -> None:
        super().__init__(port_name)
        self.margin_ms = float(margin_ms)

    def setPacketTimeout(self, packet_length: int) -> None:  # noqa: N802 (SDK name)
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = self.tx_time_per_byte * packet_length + self.margin_ms

    def readPort(self, length: int) -> bytes:  # noqa: N802 (SDK name)
        data = self.ser.read(length)
        if data:
            return data
        remaining_ms = self.packet_timeout - self.getTimeSinceStart()
        if remaining_ms > 0:
            try:
                select.select([self.ser.fileno()], [], [], min(remaining_ms, 1.0) / 1000.0)
            except (OSError, ValueError, AttributeError):
                return data
            data = self.ser.read(length)
        return data


def latency_timer_path(port: str, sysfs_root: str = "/sys/bus/usb-serial/devices") -> Path | None:
    """The FTDI latency_timer file of a /dev/ttyUSBn port (through by-id links), if any."""
    try:
        name = Path(os.path.realpath(port)).name
    except OSError:
        return None
    path = Path(sysfs_root) / name / "latency_timer"
    return path if path.exists() else None


def set_low_latency(port: str, value_ms: int = 1, sysfs_root: str = "/sys/bus/usb-serial/devices") -> str:
    """Set the USB latency timer to ``value_ms`` where the port has one; returns what happened."""
    path = latency_timer_path(port, sysfs_root)
    if path is None:
        return "no latency timer (not a USB serial adapter): skipped"
    try:
        current = int(path.read_text().strip())
    except (OSError, ValueError) as exc:
        return f"latency timer unreadable ({exc}): skipped"
    if current == value_ms:
        return f"latency timer {current} ms"
    try:
        path.write_text(f"{value_ms}\n")
    except OSError as exc:
        return (
            f"latency timer is {current} ms and could not be set to {value_ms} ({exc.strerror}); "
            f"run: echo {value_ms} | sudo tee {path}"
        )
    return f"latency timer set {current} -> {value_ms} ms"
