"""A chain of emulated Dynamixel servos behind a pseudo-terminal.

``DynamixelChainEmulator(ids).start()`` opens a pty (``os.openpty``) and serves
Protocol 2.0 on it from a background thread; point any serial client (the
real ``dynamixel_sdk``) at ``emulator.port``. Faults can be injected while it
runs: missing servos, corrupted or dropped replies, hardware error bits, a
blocked joint that overloads. Everything received is recorded so tests can
assert on what the host really sent (e.g. that no goal left the limits).

With ``timing`` (a ``BusTiming``: baud rate and USB latency timer) the chain takes the bus's
real time (bus_timing.py): a reply starts once the request's last byte is on the wire and the
first answering servo's Return Delay Time has passed, goes out at the baud rate and reaches
the host in USB packets as an FTDI adapter sends them (a full packet, or the latency timer's
expiry). The reply is written in one piece when its last packet would arrive: the host cannot
use a reply before its end, and one write a reply keeps the emulator's own wake-ups (CPU time
a real bus does not cost the host) out of the measurement. A request acts on the servos when
it arrives. Without ``timing`` every reply is written at once (lockstep with a simulated
clock). ``replies`` keeps the recent timed replies (request end, first and last USB packet,
bytes).

Run standalone (another process, like a real bus):
    python -m grasp_ctrl.emulators.dxl_chain --ids 0-15
prints the pty path on the first line and serves until SIGINT/SIGTERM.
"""

from __future__ import annotations

import argparse
import os
import select
import signal
import sys
import threading
import time
import tty
from collections import Counter, deque
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    import numpy as np

    from grasp_ctrl.config.hand import HandConfig

from grasp_ctrl.emulators import dxl_protocol as p
from grasp_ctrl.emulators.bus_timing import (
    PACKET_OVERHEAD,
    BusTiming,
    FtdiReceiveBuffer,
    reply_schedule,
    return_delay_s,
    wire_time_s,
)
from grasp_ctrl.emulators.dxl_servo import RETURN_DELAY, EmulatedServo

# How long the serving thread waits for a request when nothing is due (bounds the reaction to stop()).
IDLE_WAIT_S = 0.05


class TimedReply(NamedTuple):
    """One reply of a timed chain: when its request ended on the wire, when its first and
    last USB packet reached the host, its size."""

    t_request_end: float
    t_first: float
    t_last: float
    n_bytes: int


class DynamixelChainEmulator:
    def __init__(
        self,
        ids: Iterable[int],
        model_number: int = 1240,
        initial_counts: dict[int, float] | None = None,
        timing: BusTiming | None = None,
    ) -> None:
        self.servos: dict[int, EmulatedServo] = {}
        for i in ids:
            s = EmulatedServo(int(i), model_number=model_number)
            if initial_counts and i in initial_counts:
                s.position_counts = float(initial_counts[i])
                s.reset_ram()
            self.servos[int(i)] = s
        self.lock = threading.RLock()
        self.missing: set[int] = set()
        self.fast_sync_read_supported = True  # False: like old firmware, ignore FAST_SYNC_READ
        self.external_physics = False  # True: a simulator sets the present state (set_present)
        self.instructions: Counter[int] = Counter()
        self.sync_write_count = 0
        self.parser = p.PacketParser()
        self._corrupt: dict[int | None, int] = {}
        self._drop: dict[int | None, int] = {}
        self._master = -1
        self._slave = -1
        self.port = ""
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._last_step = time.monotonic()
        self.timing = timing
        self.replies: deque[TimedReply] = deque(maxlen=4096)
        self._adapter: FtdiReceiveBuffer | None = None
        self._bus_free = 0.0  # when the line is free for the next request (timed)
        self._outbox: deque[tuple[float, bytes]] = deque()  # (reaches the host at, bytes), in time order

    @classmethod
    def for_hand(
        cls, hand: HandConfig, q_rad: Sequence[float] | np.ndarray | None = None, timing: BusTiming | None = None
    ) -> DynamixelChainEmulator:
        """A chain with the hand's servo ids and model, resting at ``q_rad`` (default: the open
        posture); ``timing``: take the bus's real time (e.g. ``BusTiming.for_hand(hand)``)."""
        import numpy as np

        from grasp_ctrl.hardware.dynamixel.calibration import Calibration

        joints = hand.joints
        q = np.array([j.open_rad for j in joints] if q_rad is None else q_rad, dtype=float)
        counts = Calibration.from_joints(joints).to_counts_float(q)
        model = hand.dynamixel.servo  # config/servos.py, or the hand file's [servo_models.NAME]
        return cls(
            [j.servo_id for j in joints],
            model_number=model.model_number if model else 1240,
            initial_counts={j.servo_id: float(c) for j, c in zip(joints, counts)},
            timing=timing,
        )

    # ---- lifecycle -------------------------------------------------------------
    def start(self) -> DynamixelChainEmulator:
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo, no line editing: a clean byte pipe
        self.port = os.ttyname(self._slave)
        self._stop.clear()
        self._last_step = time.monotonic()
        if self.timing is not None:
            # the adapter's timer has been ticking since it was plugged in
            self._adapter = FtdiReceiveBuffer(self.timing, anchor=self._last_step)
            self._bus_free = self._last_step
            self._outbox.clear()
        serve = self._serve if self.timing is None else self._serve_timed
        self._thread = threading.Thread(target=serve, name="dxl-emulator", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        for fd in (self._master, self._slave):
            if fd >= 0:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._master = self._slave = -1

    def __enter__(self) -> DynamixelChainEmulator:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ---- fault injection ---------------------------------------------------------
    def set_missing(self, dxl_id: int, missing: bool = True) -> None:
        with self.lock:
            (self.missing.add if missing else self.missing.discard)(dxl_id)

    def corrupt_next(self, n: int = 1, dxl_id: int | None = None) -> None:
        """Flip a byte in the next ``n`` replies (of ``dxl_id``, or of anyone)."""
        with self.lock:
            self._corrupt[dxl_id] = self._corrupt.get(dxl_id, 0) + n

    def drop_next(self, n: int = 1, dxl_id: int | None = None) -> None:
        """Send nothing for the next ``n`` replies (of ``dxl_id``, or of anyone)."""
        with self.lock:
            self._drop[dxl_id] = self._drop.get(dxl_id, 0) + n

    def inject_hardware_error(self, dxl_id: int, bits: int = 0x20) -> None:
        with self.lock:
            self.servos[dxl_id].raise_hardware_error(bits)

    def block_joint(self, dxl_id: int, at_counts: float | None) -> None:
        with self.lock:
            self.servos[dxl_id].blocked_at = at_counts

    def servo(self, dxl_id: int) -> EmulatedServo:
        return self.servos[dxl_id]

    # ---- hardware-in-the-loop: let a simulator be the physics ------------------------
    def goals(self) -> dict[int, tuple[int, bool]]:
        """Goal position (counts) and torque flag of every servo, as last written by the host."""
        with self.lock:
            return {i: (s.get((116, 4), True), s.torque_on) for i, s in self.servos.items()}

    def set_present(self, dxl_id: int, counts: float, velocity_counts_s: float = 0.0, current_raw: float = 0.0) -> None:
        """Publish a simulated state (use with ``external_physics = True``); current in
        Present Current register units (1 mA on X330 models)."""
        with self.lock:
            s = self.servos[dxl_id]
            s.position_counts = float(counts)
            s._publish(velocity_counts_s, current_raw)

    # ---- serving -------------------------------------------------------------------
    def _serve(self) -> None:
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([self._master], [], [], 0.05)
            except (OSError, ValueError):
                return
            with self.lock:
                self._step_physics()
            if not ready:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:
                return
            if not data:
                continue
            with self.lock:
                for pkt, dxl_id in self.parser.feed(data):
                    reply = self._handle(pkt, dxl_id)
                    if reply:
                        try:
                            os.write(self._master, reply)
                        except OSError:
                            return

    def _serve_timed(self) -> None:
        """As ``_serve``, but each reply is written when the bus and the USB adapter would
        have delivered it."""
        while not self._stop.is_set():
            wait = IDLE_WAIT_S
            if self._outbox:
                wait = min(wait, max(0.0, self._outbox[0][0] - time.monotonic()))
            try:
                ready, _, _ = select.select([self._master], [], [], wait)
            except (OSError, ValueError):
                return
            with self.lock:
                self._step_physics()
            if ready:
                try:
                    data = os.read(self._master, 4096)
                except OSError:
                    return
                if data:
                    self._receive(data, time.monotonic())
            now = time.monotonic()
            while self._outbox and self._outbox[0][0] <= now:
                _, chunk = self._outbox.popleft()
                try:
                    os.write(self._master, chunk)
                except OSError:
                    return

    def _receive(self, data: bytes, t: float) -> None:
        """Handle the packets in ``data`` (arrived at ``t``); schedule their replies from when
        each request's last byte is on the wire."""
        assert self.timing is not None
        for pkt, dxl_id in self.parser.feed(data):
            n = PACKET_OVERHEAD + (len(pkt.params) if pkt is not None else 0)
            self._bus_free = max(t, self._bus_free) + wire_time_s(n, self.timing.baud)
            with self.lock:
                reply = self._handle(pkt, dxl_id)
                delay = self._return_delay(pkt, dxl_id)
            if reply:
                self._schedule_reply(self._bus_free, reply, delay)

    def _return_delay(self, pkt: p.Packet | None, dxl_id: int) -> float:
        """The Return Delay Time of the servo that answers first (a sync read's first id)."""
        first = dxl_id
        if pkt is not None and pkt.inst in (p.INST_SYNC_READ, p.INST_FAST_SYNC_READ) and len(pkt.params) > 4:
            first = pkt.params[4]
        elif pkt is not None and pkt.dxl_id == p.BROADCAST_ID and self.servos:
            first = min(self.servos)
        s = self.servos.get(first)
        return return_delay_s(s.get(RETURN_DELAY)) if s is not None else 0.0

    def _schedule_reply(self, t_request_end: float, reply: bytes, return_delay: float) -> None:
        assert self.timing is not None and self._adapter is not None
        flushes = reply_schedule(self.timing, self._adapter, t_request_end, len(reply), return_delay)
        self._bus_free = max(self._bus_free, t_request_end + return_delay + len(reply) * self.timing.byte_s)
        self._outbox.append((flushes[-1][0], reply))
        self.replies.append(TimedReply(t_request_end, flushes[0][0], flushes[-1][0], len(reply)))

    def _step_physics(self) -> None:
        now = time.monotonic()
        dt = now - self._last_step
        self._last_step = now
        if self.external_physics:
            return
        for s in self.servos.values():
            s.step(dt)

    def _present(self, dxl_id: int) -> EmulatedServo | None:
        s = self.servos.get(dxl_id)
        return None if s is None or dxl_id in self.missing else s

    def _take(self, table: dict[int | None, int], dxl_id: int) -> bool:
        for key in (dxl_id, None):
            if table.get(key, 0) > 0:
                table[key] -= 1
                return True
        return False

    def _emit(self, dxl_id: int, status: bytes) -> bytes:
        if self._take(self._drop, dxl_id):
            return b""
        if self._take(self._corrupt, dxl_id):
            b = bytearray(status)
            b[-3] ^= 0x5A  # a payload byte: the CRC no longer matches
            return bytes(b)
        return status

    def _handle(self, pkt: p.Packet | None, dxl_id: int) -> bytes:
        if pkt is None:  # CRC error: the addressed servo says so
            s = self._present(dxl_id)
            return self._emit(dxl_id, p.build_status(dxl_id, p.ERR_CRC | s.error_byte_alert)) if s else b""
        self.instructions[pkt.inst] += 1
        inst, prm = pkt.inst, pkt.params
        if inst == p.INST_SYNC_WRITE:
            self.sync_write_count += 1
            return self._sync_write(prm)
        if inst == p.INST_FAST_SYNC_READ and not self.fast_sync_read_supported:
            return b""
        if inst in (p.INST_SYNC_READ, p.INST_FAST_SYNC_READ):
            return self._sync_read(prm, fast=inst == p.INST_FAST_SYNC_READ)
        if pkt.dxl_id == p.BROADCAST_ID:
            if inst == p.INST_PING:
                return b"".join(self._single(i, pkt) for i in sorted(self.servos))
            if inst == p.INST_WRITE:  # broadcast write: apply everywhere, no reply
                for i in self.servos:
                    if self._present(i):
                        self._single(i, pkt)
            return b""
        return self._single(pkt.dxl_id, pkt)

    def _single(self, dxl_id: int, pkt: p.Packet) -> bytes:
        s = self._present(dxl_id)
        if s is None:
            return b""
        inst, prm = pkt.inst, pkt.params
        if inst == p.INST_PING:
            params = bytes([s.model_number & 0xFF, s.model_number >> 8, 52])
            return self._emit(dxl_id, p.build_status(dxl_id, s.error_byte_alert, params))
        if inst == p.INST_READ:
            if len(prm) != 4:
                return self._emit(dxl_id, p.build_status(dxl_id, p.ERR_DATA_LENGTH | s.error_byte_alert))
            addr, length = _u16(prm, 0), _u16(prm, 2)
            err, data = s.read(addr, length)
            return self._emit(dxl_id, p.build_status(dxl_id, err | s.error_byte_alert, data))
        if inst == p.INST_WRITE:
            if len(prm) < 3:
                return self._emit(dxl_id, p.build_status(dxl_id, p.ERR_DATA_LENGTH | s.error_byte_alert))
            err = s.write(_u16(prm, 0), prm[2:])
            if pkt.dxl_id == p.BROADCAST_ID:
                return b""
            return self._emit(dxl_id, p.build_status(dxl_id, err | s.error_byte_alert))
        if inst == p.INST_REBOOT:
            reply = self._emit(dxl_id, p.build_status(dxl_id, s.error_byte_alert))
            s.reset_ram()
            return reply
        return self._emit(dxl_id, p.build_status(dxl_id, p.ERR_INSTRUCTION | s.error_byte_alert))

    def _sync_write(self, prm: bytes) -> bytes:
        if len(prm) < 4:
            return b""
        addr, length = _u16(prm, 0), _u16(prm, 2)
        body = prm[4:]
        for k in range(0, len(body) - length, length + 1):
            s = self._present(body[k])
            if s is not None:
                s.write(addr, body[k + 1 : k + 1 + length])
        return b""

    def _sync_read(self, prm: bytes, fast: bool) -> bytes:
        if len(prm) < 5:
            return b""
        addr, length = _u16(prm, 0), _u16(prm, 2)
        ids = list(prm[4:])
        if not fast:
            out = []
            for i in ids:
                s = self._present(i)
                if s is None:
                    break  # the chain stalls at a silent servo
                err, data = s.read(addr, length)
                out.append(self._emit(i, p.build_status(i, err | s.error_byte_alert, data)))
            return b"".join(out)
        # Fast sync read: one status packet, ID 0xFE, per servo ERR ID DATA CRC;
        # each servo appends its part and the CRC of the packet so far, so the
        # last servo's CRC is the packet's CRC. The chain stops at a silent servo.
        parts: list[bytes] = []
        for i in ids:
            s = self._present(i)
            if s is None:
                break
            err, data = s.read(addr, length)
            parts.append(bytes([err | s.error_byte_alert, i]) + (data if len(data) == length else bytes(length)))
        if not parts:
            return b""
        body = bytearray([p.INST_STATUS])
        length_field = 1 + len(parts) * (length + 4)
        crc = p.crc16(p.HEADER + bytes([p.BROADCAST_ID, length_field & 0xFF, length_field >> 8]))
        crc = p.crc16(body, crc)
        for part in parts:
            crc = p.crc16(part, crc)
            seg_crc = bytes([crc & 0xFF, crc >> 8])
            body += part + seg_crc
            crc = p.crc16(seg_crc, crc)
        stuffed = p.stuff(bytes(body[:-2]))
        if len(stuffed) == len(body) - 2:
            reply = p.HEADER + bytes([p.BROADCAST_ID, length_field & 0xFF, length_field >> 8]) + bytes(body)
        else:  # stuffing changed the length: frame and checksum again
            total_len = len(stuffed) + 2
            pkt = p.HEADER + bytes([p.BROADCAST_ID, total_len & 0xFF, total_len >> 8]) + stuffed
            crc = p.crc16(pkt)
            reply = pkt + bytes([crc & 0xFF, crc >> 8])
        return self._emit(ids[0], reply)


def _u16(b: bytes, i: int) -> int:
    return b[i] | (b[i + 1] << 8)


def parse_ids(text: str) -> list[int]:
    """'0-15' or '0,1,2' or '0-3,8' -> ids."""
    out: list[int] = []
    for part in text.split(","):
        part = part.strip()
        if "-" in part:
            a, b = part.split("-", 1)
            out.extend(range(int(a), int(b) + 1))
        elif part:
            out.append(int(part))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m grasp_ctrl.emulators.dxl_chain", description=__doc__.split("\n\n")[0])
    ap.add_argument("--ids", default="0-15", help="servo ids, e.g. 0-15 or 0,1,2 (default 0-15, the LEAP Hand)")
    ap.add_argument("--model-number", type=int, default=1240, help="model number the servos report (default 1240)")
    ap.add_argument("--missing", default="", help="ids that do not answer")
    ap.add_argument("--hand", help="hand file: use its ids and model, start at its open posture (overrides --ids)")
    ap.add_argument(
        "--realtime",
        action="store_true",
        help="take the bus's real time: wire time at the baud rate (the hand file's, else --baud), "
        "return delay, the USB latency timer (the hand file's latency_timer_ms, else --latency-timer-ms)",
    )
    ap.add_argument("--baud", type=int, default=4_000_000, help="with --realtime and no --hand (default 4000000)")
    ap.add_argument("--latency-timer-ms", type=int, default=None, help="with --realtime: the USB latency timer")
    args = ap.parse_args(argv)
    if args.latency_timer_ms is not None and not 1 <= args.latency_timer_ms <= 255:
        ap.error("--latency-timer-ms: from 1 to 255")
    if args.baud <= 0:
        ap.error("--baud: a positive baud rate")
    if args.hand:
        from grasp_ctrl.config.hand import load_hand

        hand = load_hand(args.hand)
        timing = BusTiming.for_hand(hand) if args.realtime else None
        if timing is not None and args.latency_timer_ms is not None:
            timing = BusTiming(timing.baud, args.latency_timer_ms / 1000.0)
        emu = DynamixelChainEmulator.for_hand(hand, timing=timing).start()
    else:
        latency_ms = args.latency_timer_ms if args.latency_timer_ms is not None else 1
        timing = BusTiming(args.baud, latency_ms / 1000.0) if args.realtime else None
        emu = DynamixelChainEmulator(parse_ids(args.ids), model_number=args.model_number, timing=timing).start()
    for i in parse_ids(args.missing):
        emu.set_missing(i)
    print(emu.port, flush=True)
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    try:
        while not done.wait(0.2):
            pass
    except KeyboardInterrupt:
        pass
    emu.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
