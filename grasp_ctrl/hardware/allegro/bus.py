"""The CAN bus of an Allegro hand: python-can, opened from the hand file's ``[torque_pd]``.

``CanLink`` is what the backend needs of a bus (send a frame, take one, close); ``PythonCanLink``
is python-can's bus behind it: ``socketcan`` (Linux; bring the interface up at 1 Mbit/s first, see
docs/hardware.md), ``pcan`` (PEAK's PCAN-Basic, which sets the bit rate itself) or ``virtual``
(python-can's in-process bus: the emulator and the tests). python-can is an optional extra
(``pip install -e '.[can]'``): it is imported only when a bus is opened, and its absence is one line.
"""

from __future__ import annotations

from typing import Any, Protocol

from grasp_ctrl.config.hand import TorquePDConfig
from grasp_ctrl.errors import HardwareError, UsageError
from grasp_ctrl.hardware.allegro.protocol import CanFrame

INSTALL_HINT = "pip install -e '.[can]'"


class CanLink(Protocol):
    """A CAN bus as the Allegro backend uses it."""

    def send(self, frame: CanFrame) -> None:
        """Put ``frame`` on the bus; ``HardwareError`` when the controller refuses it (bus-off)."""
        ...

    def recv(self, timeout_s: float) -> CanFrame | None:
        """The next frame (error frames included), or None after ``timeout_s`` (0: do not wait)."""
        ...

    def close(self) -> None: ...


def require_python_can() -> Any:
    """The ``can`` module, or a one-line error naming the extra."""
    try:
        import can
    except ImportError:
        raise UsageError(f"the Allegro hand's CAN backend needs python-can: {INSTALL_HINT}") from None
    return can


def describe(cfg: TorquePDConfig, channel: str | None = None) -> str:
    return f"{cfg.interface} {channel or cfg.channel}"


class PythonCanLink:
    """A python-can ``Bus`` as a ``CanLink``."""

    def __init__(self, bus: Any, name: str) -> None:
        self.can = require_python_can()
        self.bus = bus
        self.name = name
        self.closed = False

    @classmethod
    def open(cls, cfg: TorquePDConfig, channel: str | None = None) -> PythonCanLink:
        can = require_python_can()
        name = describe(cfg, channel)
        kwargs: dict[str, Any] = {"interface": cfg.interface, "channel": channel or cfg.channel}
        if cfg.interface == "pcan":
            kwargs["bitrate"] = cfg.bitrate  # PCAN-Basic sets the bit rate; socketcan's is `ip link`'s
        if cfg.interface == "virtual":
            kwargs["receive_own_messages"] = False
        try:
            bus = can.Bus(**kwargs)
        except (can.CanError, OSError, ValueError, ImportError) as exc:
            raise HardwareError(
                f"CAN bus {name}: cannot open: {exc} (docs/hardware.md, 'Allegro hand (CAN)')"
            ) from None
        return cls(bus, name)

    def send(self, frame: CanFrame) -> None:
        msg = self.can.Message(
            arbitration_id=frame.arbitration_id,
            data=frame.data,
            is_remote_frame=frame.is_remote,
            is_extended_id=frame.is_extended,
            is_error_frame=frame.is_error,
            dlc=len(frame.data),
        )
        try:
            self.bus.send(msg, timeout=0.01)
        except (self.can.CanError, OSError) as exc:
            raise HardwareError(f"CAN bus {self.name}: send failed: {exc}", reason="hardware_error") from None

    def recv(self, timeout_s: float) -> CanFrame | None:
        try:
            msg = self.bus.recv(timeout=timeout_s)
        except (self.can.CanError, OSError) as exc:
            raise HardwareError(f"CAN bus {self.name}: receive failed: {exc}", reason="hardware_error") from None
        if msg is None:
            return None
        return CanFrame(
            arbitration_id=int(msg.arbitration_id),
            data=bytes(msg.data[: msg.dlc]) if not msg.is_remote_frame else b"",
            is_remote=bool(msg.is_remote_frame),
            is_extended=bool(msg.is_extended_id),
            is_error=bool(msg.is_error_frame),
            timestamp=float(msg.timestamp or 0.0),
        )

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.bus.shutdown()


def open_link(cfg: TorquePDConfig, channel: str | None = None) -> PythonCanLink:
    """The hand file's bus (``channel`` overrides ``[torque_pd] channel``)."""
    return PythonCanLink.open(cfg, channel)
