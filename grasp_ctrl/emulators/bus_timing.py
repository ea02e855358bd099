"""How long a Dynamixel bus transaction takes on real hardware, for the emulators and the pre-flight.

Three costs make a round trip (Protocol 2.0 over a U2D2-style FTDI USB adapter):

- the wire: every byte is 10 bits on the line (start, 8 data, stop), so ``n`` bytes take
  ``10 n / baud`` seconds, the request on its way out and the reply on its way back;
- the servo's Return Delay Time (control table address 9, unit 2 us; factory default 250 =
  500 us, ``configure_servos`` sets 0) between the request's last byte and the reply;
- the USB adapter's receive buffer: the FTDI chip sends what it received to the host when a
  USB packet is full (62 payload bytes: 64 less 2 modem-status bytes) or when its latency
  timer expires (default 16 ms, 1 ms once ``latency_timer_ms`` is written to sysfs). The timer
  restarts whenever the chip sends a packet, and an idle chip sends a status-only packet at
  each expiry, so the timer ticks every ``L`` from the last packet sent: a reply's tail waits
  for the next tick, up to ``L`` (back-to-back transactions lock to the tick and wait nearly
  all of it, which is why a 16 ms timer caps a read-write loop near 60 Hz).

``FtdiReceiveBuffer`` is that buffer's schedule; ``tick_bus_time_s`` the worst bus time of one
control tick of ``DynamixelHand`` (one state sync read, one goal sync write and, every
``health_poll_s``, a hardware-error sync read), which the pre-flight compares with the tick.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from grasp_ctrl.config.hand import HandConfig

BITS_PER_BYTE = 10  # 1 start + 8 data + 1 stop
RETURN_DELAY_UNIT_S = 2e-6  # Return Delay Time register unit
FTDI_PACKET_PAYLOAD = 62  # bytes of data in one full-speed USB packet from an FTDI chip
CONFIGURED_RETURN_DELAY = 0  # what configure_servos writes (hardware/dynamixel/setup.py)

# Packet sizes (bytes on the wire, no byte stuffing): header 4, id 1, length 2, instruction 1, crc 2.
PACKET_OVERHEAD = 10
STATE_BYTES = 10  # present current 2 + velocity 4 + position 4, read every tick
GOAL_BYTES = 4  # goal position


def wire_time_s(n_bytes: int, baud: int) -> float:
    """Seconds that ``n_bytes`` take on a UART line at ``baud`` (10 bits a byte)."""
    return BITS_PER_BYTE * n_bytes / baud


def return_delay_s(register: int) -> float:
    """The Return Delay Time register (address 9) in seconds."""
    return register * RETURN_DELAY_UNIT_S


def sync_read_request_bytes(n_servos: int) -> int:
    """SYNC_READ / FAST_SYNC_READ: address 2, length 2, one id per servo."""
    return PACKET_OVERHEAD + 4 + n_servos


def sync_read_reply_bytes(n_servos: int, length: int, fast: bool = True) -> int:
    """A fast sync read answers in one packet (per servo: error, id, data, crc); a plain one
    with one status packet per servo (error byte and data each)."""
    if fast:
        return PACKET_OVERHEAD - 2 + n_servos * (length + 4)
    return n_servos * (PACKET_OVERHEAD + 1 + length)


def sync_write_bytes(n_servos: int, length: int) -> int:
    """SYNC_WRITE: address 2, length 2, per servo its id and data; no reply."""
    return PACKET_OVERHEAD + 4 + n_servos * (1 + length)


@dataclass(frozen=True)
class BusTiming:
    """The real time of one bus: its baud rate and its USB adapter's latency timer."""

    baud: int
    latency_timer_s: float
    usb_packet_payload: int = FTDI_PACKET_PAYLOAD

    def __post_init__(self) -> None:
        if self.baud <= 0 or not self.latency_timer_s > 0 or self.usb_packet_payload < 1:
            raise ValueError(f"bus timing needs baud > 0 and a latency timer > 0 (got {self!r})")

    @classmethod
    def for_hand(cls, hand: HandConfig) -> BusTiming:
        d = hand.dynamixel
        return cls(baud=d.baud, latency_timer_s=d.latency_timer_ms / 1000.0)

    @property
    def byte_s(self) -> float:
        return wire_time_s(1, self.baud)


@dataclass
class FtdiReceiveBuffer:
    """The adapter's receive side: bytes from the servos wait in its buffer until a USB packet
    is full or the latency timer expires; ``flushes`` gives when each USB packet reaches the host.

    ``anchor`` is the last time the chip sent a packet (its timer expires every
    ``latency_timer_s`` after it); it carries over from one transaction to the next."""

    timing: BusTiming
    anchor: float = 0.0
    _pending: int = field(default=0, repr=False)

    def next_expiry(self, t: float) -> float:
        """The first timer expiry strictly after ``t``."""
        period = self.timing.latency_timer_s
        k = math.floor((t - self.anchor) / period) + 1
        return self.anchor + max(k, 1) * period

    def flushes(self, byte_times: list[float]) -> list[tuple[float, int]]:
        """(time, byte count) of every USB packet that carries bytes arriving at ``byte_times``
        (sorted: when each byte's stop bit ends on the wire)."""
        out: list[tuple[float, int]] = []
        payload = self.timing.usb_packet_payload
        first = 0.0  # when the buffer's oldest byte arrived
        for t in byte_times:
            if self._pending:
                expiry = self.next_expiry(first)
                if expiry <= t:  # the timer fired before this byte: the buffer went out then
                    out.append((expiry, self._pending))
                    self.anchor, self._pending = expiry, 0
            if not self._pending:
                first = t
            self._pending += 1
            if self._pending == payload:  # a full packet goes at once and restarts the timer
                out.append((t, payload))
                self.anchor, self._pending = t, 0
        if self._pending:
            expiry = self.next_expiry(first)
            out.append((expiry, self._pending))
            self.anchor, self._pending = expiry, 0
        return out


def reply_schedule(
    timing: BusTiming, adapter: FtdiReceiveBuffer, t_request_end: float, n_reply: int, return_delay: float
) -> list[tuple[float, int]]:
    """When a reply of ``n_reply`` bytes reaches the host: the servo waits ``return_delay``
    after the request's last byte, sends at the baud rate, the adapter buffers."""
    start = t_request_end + return_delay
    byte = timing.byte_s
    return adapter.flushes([start + (i + 1) * byte for i in range(n_reply)])


@dataclass(frozen=True)
class TickBusTime:
    """The bus time of one control tick, worst case (every reply's tail waits the whole timer)."""

    state_read_s: float  # one sync read of current, velocity, position
    goal_write_s: float  # one sync write of goal positions
    health_read_s: float  # one sync read of Hardware Error Status, every health_poll_s
    latency_timer_s: float

    @property
    def worst_s(self) -> float:
        """A tick that also polls the servos' health."""
        return self.state_read_s + self.goal_write_s + self.health_read_s


def tick_bus_time_s(
    n_servos: int,
    baud: int,
    latency_timer_s: float,
    fast_sync_read: bool = True,
    return_delay: float = return_delay_s(CONFIGURED_RETURN_DELAY),
) -> TickBusTime:
    """Worst-case bus time of ``DynamixelHand``'s tick over ``n_servos`` servos."""

    def read_s(length: int) -> float:
        wire = wire_time_s(sync_read_request_bytes(n_servos), baud)
        wire += wire_time_s(sync_read_reply_bytes(n_servos, length, fast_sync_read), baud)
        delays = return_delay if fast_sync_read else n_servos * return_delay
        return wire + delays + latency_timer_s

    return TickBusTime(
        state_read_s=read_s(STATE_BYTES),
        goal_write_s=wire_time_s(sync_write_bytes(n_servos, GOAL_BYTES), baud),
        health_read_s=read_s(1),
        latency_timer_s=latency_timer_s,
    )
