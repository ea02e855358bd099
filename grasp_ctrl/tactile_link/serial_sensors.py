"""``SerialSensors``: the fingertip sensors over pyserial (protocol v1, binary or text).

One background reader thread per port decodes the stream and keeps only the newest
valid frame per fingertip, stamped with the receive time; ``read_latest`` copies
that dict under a lock and never blocks the control tick. The control loop calls
``check_stale(now)`` every tick: it raises ``SensorStaleError`` (reason
``sensor_stale``) while a port is unplugged (naming the port and its
fingertips) and naming every fingertip with no valid frame for longer than
``stale_after_s``; both end the trial so the controller can fault safely.

An unplugged port (read error) is closed and, when ``reconnect`` is on, reopened
every ``reconnect_interval_s`` until it comes back; the decoder then restarts
(sequence history is forgotten so a restarted bridge does not count as a gap).
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import serial

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.errors import HardwareError, SensorStaleError
from grasp_ctrl.hardware.base import TactileFrame
from grasp_ctrl.tactile_link.decoder import DecoderStats, make_decoder

READ_TIMEOUT_S = 0.05  # how long one blocking read waits; bounds the reaction to close()

OpenPort = Callable[[str, int], Any]  # (port, baud) -> an open pyserial-like object


def open_pyserial(port: str, baud: int) -> serial.SerialBase:
    """Open a port (a device path or any pyserial URL) for the reader thread."""
    kwargs: dict[str, Any] = {"baudrate": baud, "timeout": READ_TIMEOUT_S}
    if "://" not in port:
        kwargs["exclusive"] = True  # a second reader would silently steal half the bytes
    return serial.serial_for_url(port, **kwargs)


@dataclass
class _PortState:
    port: str
    sensor_ids: tuple[int, ...]
    decoder: Any
    ser: Any = None
    connected: bool = False
    error: str | None = None  # why the port is down, while it is
    reopen_error: str | None = None  # why the last reconnect attempt failed
    disconnects: int = 0
    reconnects: int = 0
    thread: threading.Thread | None = None
    unexpected_ids: set[int] = field(default_factory=set)


class SerialSensors:
    """A ``SensorBackend`` reading protocol v1 from one or more serial ports.

    ``ports`` maps each port to the sensor ids (protocol ``finger`` numbers) it carries.
    ``names`` maps sensor ids to finger names for messages. ``clock`` gives the receive
    timestamps and the default ``now`` of ``check_stale`` (a callable or an object with
    ``now()``; default ``time.monotonic``). ``keep_history`` > 0 also keeps up to that
    many received frames for ``drain_frames`` (recording).
    """

    def __init__(
        self,
        ports: Mapping[str, Sequence[int]],
        *,
        mode: str = "binary",
        baud: int = 1_000_000,
        stale_after_s: float = 0.05,
        names: Mapping[int, str] | None = None,
        reconnect: bool = True,
        reconnect_interval_s: float = 0.2,
        clock: Any = None,
        keep_history: int = 0,
        open_port: OpenPort = open_pyserial,
    ) -> None:
        if not ports:
            raise ValueError("SerialSensors needs at least one port")
        make_decoder(mode)  # validates the mode early
        self.mode = mode
        self.baud = int(baud)
        self.stale_after_s = float(stale_after_s)
        self.reconnect = reconnect
        self.reconnect_interval_s = float(reconnect_interval_s)
        self._now: Callable[[], float] = (
            time.monotonic if clock is None else (clock.now if hasattr(clock, "now") else clock)
        )
        self._open_port = open_port
        self._ports = [_PortState(p, tuple(ids), make_decoder(mode)) for p, ids in ports.items()]
        all_ids = [i for p in self._ports for i in p.sensor_ids]
        if len(set(all_ids)) != len(all_ids):
            raise ValueError(f"a sensor id appears on more than one port: {dict(ports)}")
        self.sensor_ids: tuple[int, ...] = tuple(sorted(all_ids))
        self.names = {i: (names or {}).get(i, f"sensor{i}") for i in self.sensor_ids}
        self._lock = threading.Lock()
        self._latest: dict[int, TactileFrame] = {}
        self._counts: dict[int, int] = {i: 0 for i in self.sensor_ids}
        self._history: deque[TactileFrame] | None = deque(maxlen=keep_history) if keep_history > 0 else None
        self._history_dropped = 0
        self._unexpected_frames = 0
        self._stop = threading.Event()
        self._t_start: float | None = None

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_hand(cls, hand: HandConfig, port: str | None = None, **kwargs: Any) -> SerialSensors:
        """Ports, mode, baud and stale limit from the hand file's ``[tactile]`` table.

        ``port`` (e.g. ``--port``) puts every fingertip on that one port.
        """
        t = hand.tactile
        ports: dict[str, list[int]] = {}
        for f in hand.fingers:
            ports.setdefault(port or t.port_for(f.name), []).append(f.sensor_id)
        kwargs.setdefault("mode", t.mode)
        kwargs.setdefault("baud", t.baud)
        kwargs.setdefault("stale_after_s", t.stale_after_s)
        kwargs.setdefault("reconnect", t.reconnect)
        return cls(ports, names={f.sensor_id: f.name for f in hand.fingers}, **kwargs)

    # ------------------------------------------------------------------ SensorBackend

    def start(self) -> None:
        """Open every port (fails at once with a clear message) and start the readers."""
        if self._t_start is not None:
            return
        opened = []
        try:
            for ps in self._ports:
                ps.ser = self._open(ps)
                opened.append(ps)
        except HardwareError:
            for ps in opened:
                self._close_port(ps)
            raise
        self._t_start = self._now()
        for ps in self._ports:
            ps.connected = True
            ps.thread = threading.Thread(target=self._reader, args=(ps,), name=f"tactile-{ps.port}", daemon=True)
            ps.thread.start()

    def read_latest(self) -> dict[int, TactileFrame]:
        with self._lock:
            return dict(self._latest)

    def stats(self) -> dict[str, int]:
        total = DecoderStats().as_dict()
        for ps in self._ports:
            for k, v in ps.decoder.stats.as_dict().items():
                total[k] += v
        total.update(
            unexpected_sensor_frames=self._unexpected_frames,
            disconnects=sum(ps.disconnects for ps in self._ports),
            reconnects=sum(ps.reconnects for ps in self._ports),
            ports_connected=sum(ps.connected for ps in self._ports),
            ports=len(self._ports),
            history_dropped=self._history_dropped,
        )
        return total

    def close(self) -> None:
        self._stop.set()
        for ps in self._ports:
            ser = ps.ser
            if ser is not None and hasattr(ser, "cancel_read"):
                try:
                    ser.cancel_read()
                except Exception:  # noqa: BLE001 - the port may already be gone
                    pass
        for ps in self._ports:
            if ps.thread is not None:
                ps.thread.join(timeout=1.0)
            self._close_port(ps)
            ps.connected = False

    def __enter__(self) -> SerialSensors:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ health, for the control loop

    def check_stale(self, now: float | None = None) -> None:
        """Call every control tick. Raises ``SensorStaleError`` (reason ``sensor_stale``):
        while a port is disconnected (its fingertips send nothing; the message names
        the port and why), else naming each fingertip whose newest valid frame is
        older than ``stale_after_s`` (or that has sent none since ``start``)."""
        if self._t_start is None:
            raise HardwareError("tactile sensors: check_stale called before start()")
        now = self._now() if now is None else now
        for ps in self._ports:
            if not ps.connected:
                raise SensorStaleError(self.disconnect_message(ps))
        stale = []
        with self._lock:
            for sid in self.sensor_ids:
                frame = self._latest.get(sid)
                age = now - (frame.t_recv if frame is not None else self._t_start)
                if age > self.stale_after_s:
                    what = (
                        f"no valid frame for {age * 1e3:.0f} ms"
                        if frame
                        else f"no valid frame since start ({age * 1e3:.0f} ms)"
                    )
                    stale.append(f"{self.names[sid]} (sensor {sid} on {self._port_of(sid)}): {what}")
        if stale:
            raise SensorStaleError(
                f"tactile fingertip stale (limit {self.stale_after_s * 1e3:.0f} ms): " + "; ".join(stale)
            )

    def disconnect_message(self, ps: _PortState | None = None) -> str:
        """Why the (first) disconnected port is down, as one line; empty when all are up."""
        down = [ps] if ps is not None else [p for p in self._ports if not p.connected]
        if not down:
            return ""
        p = down[0]
        fingers = ", ".join(self.names[i] for i in p.sensor_ids)
        then = "reconnecting" if self.reconnect and not self._stop.is_set() else "not reconnecting (reconnect is off)"
        if p.reopen_error:
            then += f" (last attempt: {p.reopen_error})"
        return f"tactile port {p.port} disconnected ({p.error or 'closed'}); fingertips {fingers} have no data; {then}"

    def now(self) -> float:
        """The time on the clock that stamps ``t_recv``."""
        return self._now()

    @property
    def connected(self) -> bool:
        return all(ps.connected for ps in self._ports)

    def port_status(self) -> dict[str, str]:
        """port -> "connected" or the reason it is down."""
        return {ps.port: ("connected" if ps.connected else f"disconnected: {ps.error}") for ps in self._ports}

    def frame_counts(self) -> dict[int, int]:
        with self._lock:
            return dict(self._counts)

    def drain_frames(self) -> list[TactileFrame]:
        """Every frame received since the last call (needs ``keep_history`` > 0)."""
        if self._history is None:
            raise ValueError("drain_frames needs SerialSensors(keep_history=N)")
        with self._lock:
            out = list(self._history)
            self._history.clear()
        return out

    def wait_for_frames(self, timeout_s: float, min_frames: int = 1) -> None:
        """Block (outside the control loop) until every fingertip has sent ``min_frames``;
        raises ``SensorStaleError`` naming those that did not within ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        while True:
            counts = self.frame_counts()
            missing = [sid for sid in self.sensor_ids if counts[sid] < min_frames]
            if not missing:
                return
            if time.monotonic() >= deadline:
                down = self.disconnect_message()
                names = ", ".join(
                    f"{self.names[s]} (sensor {s} on {self._port_of(s)}, {counts[s]} frames)" for s in missing
                )
                raise SensorStaleError(
                    f"tactile fingertips sent too few valid frames within {timeout_s:g} s: {names}"
                    + (f"; {down}" if down else "")
                )
            time.sleep(0.005)

    # ------------------------------------------------------------------ reader thread

    def _port_of(self, sid: int) -> str:
        return next(ps.port for ps in self._ports if sid in ps.sensor_ids)

    def _open(self, ps: _PortState) -> Any:
        try:
            ser = self._open_port(ps.port, self.baud)
        except (serial.SerialException, OSError, ValueError) as exc:
            ps.reopen_error = str(exc)
            raise HardwareError(f"tactile port {ps.port}: cannot open ({exc})", reason="hardware_error") from None
        try:
            ser.reset_input_buffer()  # bytes queued before we opened carry no usable receive time
        except (serial.SerialException, OSError):
            pass
        return ser

    def _close_port(self, ps: _PortState) -> None:
        ser, ps.ser = ps.ser, None
        if ser is not None:
            try:
                ser.close()
            except Exception:  # noqa: BLE001 - closing a vanished device may fail; it is gone either way
                pass

    def _reader(self, ps: _PortState) -> None:
        while not self._stop.is_set():
            if ps.ser is None:
                if not self._try_reopen(ps):
                    self._stop.wait(self.reconnect_interval_s)
                continue
            try:
                data = ps.ser.read(1)
                if data:
                    waiting = ps.ser.in_waiting
                    if waiting:
                        data += ps.ser.read(waiting)
            except (serial.SerialException, OSError, TypeError, AttributeError) as exc:
                # TypeError/AttributeError: pyserial's state after a close() from another thread.
                if self._stop.is_set():
                    break
                ps.error = f"read failed: {exc}"
                ps.connected = False
                ps.disconnects += 1
                self._close_port(ps)
                if not self.reconnect:
                    break
                self._stop.wait(self.reconnect_interval_s)  # a flapping device must not spin the CPU
                continue
            if data:
                self._deliver(ps, data, self._now())

    def _try_reopen(self, ps: _PortState) -> bool:
        try:
            ps.ser = self._open(ps)
        except HardwareError:
            return False
        ps.decoder.reset()
        ps.connected = True
        ps.error = ps.reopen_error = None
        ps.reconnects += 1
        return True

    def _deliver(self, ps: _PortState, data: bytes, t_recv: float) -> None:
        frames = ps.decoder.feed(data)
        if not frames:
            return
        with self._lock:
            for f in frames:
                if f.finger not in ps.sensor_ids:
                    self._unexpected_frames += 1
                    ps.unexpected_ids.add(f.finger)
                    continue
                values = f.values
                values.flags.writeable = False  # shared with every reader of read_latest
                tf = TactileFrame(sensor_id=f.finger, seq=f.seq, t_recv=t_recv, values=values)
                self._latest[f.finger] = tf
                self._counts[f.finger] += 1
                if self._history is not None:
                    if len(self._history) == self._history.maxlen:
                        self._history_dropped += 1
                    self._history.append(tf)


def as_array(frames: Mapping[int, TactileFrame], sensor_ids: Sequence[int]) -> np.ndarray:
    """(n, 44) float raw frames in ``sensor_ids`` order (all must be present)."""
    return np.stack([np.asarray(frames[s].values, dtype=float) for s in sensor_ids])
