"""An emulator of the fingertip sensor bridge on a pseudo-terminal.

``TactileBridgeEmulator`` opens a pty (``os.openpty``), exposes its slave end under
a stable path (a symlink, so an emulated unplug/replug keeps the port name like a
``/dev/serial/by-id`` link does) and streams protocol v1 frames from a thread at
``rate_hz`` per fingertip. Values come from a ``FrameSource``: ``SyntheticSource``
(periodic presses through the simulated BioTac) or ``RecordingSource`` (the robotic_finger CSV, which has pdc
and e1..e19; the pac, tdc and tac channels are filled in plausibly).

Faults: per-frame bit flips (1..3 bits, always caught by the CRC) and truncation,
garbage bursts between frames, pauses of some fingertips (``pause``), unplugging
(``disconnect``) and plugging back (``replug``). ``sent`` logs every frame put on
the wire with whether it went out intact, so tests can check what the reader lost.
``wire_baud``: each frame reaches the reader when its last byte would on a UART at that
rate (10 bits a byte, the frames of one sample back to back), not all at once.
POSIX only (pseudo-terminals).
"""

from __future__ import annotations

import errno
import os
import tempfile
import threading
import time
import tty
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grasp_ctrl.config.sensor_layout import COUNT_MAX, ELECTRODES, FRAME_LEN, PAC, PDC, TAC, TDC
from grasp_ctrl.emulators.bus_timing import wire_time_s
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR
from grasp_ctrl.sim.biotac.model import BioTacSensorModel
from grasp_ctrl.tactile_link.protocol import SEQ_MODULO, encode_binary, encode_text

#: (sensor_id, sample index) -> (44,) raw counts.
FrameSource = Callable[[int, int], np.ndarray]


def _fill_other_channels(frame: np.ndarray, pdc_rate: float, rng: np.random.Generator) -> None:
    """pac: vibration around mid-scale that grows with pdc change; tdc/tac: a warm sensor."""
    frame[PAC] = 2048 + rng.normal(0.0, 6.0, 22) + np.clip(pdc_rate, -400, 400) * rng.normal(1.0, 0.2, 22)
    frame[TDC] = 2700 + rng.normal(0.0, 2.0)
    frame[TAC] = 2048 + rng.normal(0.0, 3.0)


def _to_counts(frame: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(frame), 0, COUNT_MAX).astype(np.int64)


class SyntheticSource:
    """Slow presses on each fingertip's pad through the simulated BioTac (the same forward
    model as the mock world and the synthetic training data, ``sim/biotac/model.py``):
    electrodes under the pad drop, the ones away from it rise, pdc rises. Each fingertip is
    its own simulated sensor (baselines, gains, noise), stepped once per call."""

    def __init__(
        self,
        seed: int = 0,
        rate_hz: float = 100.0,
        period_s: float = 3.0,
        peak_force_n: float = 2.0,
        free_s: float = 1.0,
    ) -> None:
        self.rate_hz = rate_hz
        self.free_s = free_s
        self.period_s = period_s
        self.peak_force_n = peak_force_n
        self.seed = seed
        self._sensors: dict[int, BioTacSensorModel] = {}

    def press(self, sensor_id: int, k: int) -> float:
        """Press depth 0..1 of fingertip ``sensor_id`` at sample ``k``: free for the first
        ``free_s`` (time to tare), then a press every ``period_s``, phase-shifted per tip."""
        t = k / self.rate_hz - self.free_s - 0.37 * (sensor_id % 8)
        return max(0.0, np.sin(2 * np.pi * t / self.period_s)) ** 2 if t > 0 else 0.0

    def __call__(self, sensor_id: int, k: int) -> np.ndarray:
        sensor = self._sensors.get(sensor_id)
        if sensor is None:
            sensor = BioTacSensorModel(1, np.random.default_rng((self.seed, sensor_id)))
            self._sensors[sensor_id] = sensor
        depth = self.press(sensor_id, k)
        # the press leans a little along the finger as it comes and goes
        sway = 0.2 * np.sin(2 * np.pi * k / (self.rate_hz * self.period_s))
        f_sensor = self.peak_force_n * depth * np.array([[sway, 0.0, 1.0]])
        frame = sensor.frames(
            PAD_POINT_SENSOR[None],
            f_sensor,
            PAD_NORMAL_SENSOR[None],
            np.array([depth > 0.0]),
            np.zeros(1),
            1.0 / self.rate_hz,
        )
        return frame[0].astype(np.int64)


class RecordingSource:
    """Replays rows of a CSV with columns ``pdc, e1..e19`` (e.g. robotic_finger_tidy.csv),
    looping; each fingertip starts at a different row so the tips do not move in lockstep."""

    def __init__(
        self, path: str | Path, seed: int = 0, max_rows: int | None = None, skip_bad_rows: bool = False
    ) -> None:
        from grasp_ctrl.errors import UsageError
        from grasp_ctrl.files.csv_rows import Column, read_rows

        cols = [Column(f"e{i}", 0.0, 4095.0) for i in range(1, 20)] + [Column("pdc", 0.0, 4095.0)]
        try:
            rows = read_rows(path, cols, skip_bad_rows=skip_bad_rows).values
        except UsageError as exc:  # the callers report ValueError naming the flag
            raise ValueError(str(exc)) from None
        if max_rows is not None:
            rows = rows[:max_rows]
        if not len(rows):
            raise ValueError(f"{path}: recording has no rows")
        self._data = np.asarray(rows)  # (n, 20): e1..e19, pdc
        self.seed = seed
        self._rngs: dict[int, np.random.Generator] = {}

    def __len__(self) -> int:
        return len(self._data)

    def _row(self, sensor_id: int, k: int) -> np.ndarray:
        n = len(self._data)
        return self._data[(k + sensor_id * n // 5) % n]

    def __call__(self, sensor_id: int, k: int) -> np.ndarray:
        rng = self._rngs.setdefault(sensor_id, np.random.default_rng((self.seed, sensor_id)))
        row = self._row(sensor_id, k)
        frame = np.empty(FRAME_LEN)
        frame[ELECTRODES] = row[:19]
        frame[PDC] = row[19]
        _fill_other_channels(frame, row[19] - self._row(sensor_id, k - 1)[19], rng)
        return _to_counts(frame)


@dataclass(frozen=True)
class FaultConfig:
    corrupt_prob: float = 0.0  # per frame: flip 1..3 random bits
    truncate_prob: float = 0.0  # per frame: send only a prefix
    garbage_prob: float = 0.0  # per tick: a burst of random bytes between frames
    garbage_max_bytes: int = 64


@dataclass(frozen=True)
class SentFrame:
    sensor_id: int
    seq: int
    intact: bool
    t_sent: float


class TactileBridgeEmulator:
    """Streams protocol v1 frames for ``sensor_ids`` on a pty; see the module docstring.

    The pty exists from construction (open the reader first, then ``start``, to
    catch every frame); ``port`` is the path to open.
    """

    def __init__(
        self,
        sensor_ids: Sequence[int],
        source: FrameSource | None = None,
        *,
        rate_hz: float = 100.0,
        mode: str = "binary",
        faults: FaultConfig = FaultConfig(),
        seed: int = 0,
        link_dir: str | Path | None = None,
        link_name: str = "tactile0",
        wire_baud: int | None = None,
    ) -> None:
        if mode not in ("binary", "text"):
            raise ValueError(f"mode must be binary or text, got {mode!r}")
        if wire_baud is not None and wire_baud <= 0:
            raise ValueError(f"wire_baud must be positive, got {wire_baud!r}")
        self.wire_baud = wire_baud
        self.sensor_ids = tuple(sensor_ids)
        self.source: FrameSource = source or SyntheticSource(seed=seed, rate_hz=rate_hz)
        self.rate_hz = float(rate_hz)
        self.mode = mode
        self.faults = faults
        self._rng = np.random.default_rng(seed)
        self._own_dir = link_dir is None
        self._dir = Path(tempfile.mkdtemp(prefix="tactile_bridge_")) if link_dir is None else Path(link_dir)
        self.port = str(self._dir / link_name)
        self.sent: list[SentFrame] = []
        self.bytes_dropped = 0  # bytes the pty would not take (nobody reading)
        self._seq = {s: 0 for s in self.sensor_ids}
        self._paused_until: dict[int, float] = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._master: int | None = None
        self._slave: int | None = None
        self.plug()

    # -------------------------------------------------------------- the "cable"

    def plug(self) -> None:
        """Create the pty and point ``port`` at it (also used by ``replug``)."""
        with self._lock:
            if self._master is not None:
                return
            master, slave = os.openpty()
            tty.setraw(slave)  # no echo, no line editing: a byte pipe like a USB CDC port
            os.set_blocking(master, False)
            link = Path(self.port)
            tmp = link.with_name(link.name + ".new")
            if tmp.is_symlink() or tmp.exists():
                tmp.unlink()
            tmp.symlink_to(os.ttyname(slave))
            os.replace(tmp, link)
            self._master, self._slave = master, slave

    def disconnect(self) -> None:
        """Unplug: close the pty (the reader's next read fails) and remove the port path."""
        with self._lock:
            master, slave, self._master, self._slave = self._master, self._slave, None, None
            try:
                Path(self.port).unlink()
            except FileNotFoundError:
                pass
        for fd in (master, slave):
            if fd is not None:
                os.close(fd)

    def replug(self) -> None:
        self.plug()

    @property
    def plugged(self) -> bool:
        return self._master is not None

    # -------------------------------------------------------------- streaming

    def start(self) -> TactileBridgeEmulator:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="tactile-bridge-emulator", daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None

    def close(self) -> None:
        self.stop()
        self.disconnect()
        if self._own_dir:
            try:
                self._dir.rmdir()
            except OSError:
                pass

    def __enter__(self) -> TactileBridgeEmulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def pause(self, seconds: float, sensor_ids: Sequence[int] | None = None) -> None:
        """Send nothing for these fingertips (default: all) for ``seconds``; their seq keeps counting."""
        until = time.monotonic() + seconds
        with self._lock:
            for s in sensor_ids if sensor_ids is not None else self.sensor_ids:
                self._paused_until[s] = until

    def send_sample(self, k: int) -> None:
        """Send sample ``k`` of every fingertip now, without the streaming thread: for a
        caller that paces the stream itself (the mock world, one sample per step)."""
        self._tick(k, time.monotonic())

    def _run(self) -> None:
        period = 1.0 / self.rate_hz
        next_t = time.monotonic()
        k = 0
        while not self._stop.is_set():
            now = time.monotonic()
            if now < next_t:
                self._stop.wait(next_t - now)
                continue
            self._tick(k, now)
            k += 1
            next_t += period
            if now - next_t > 10 * period:  # fell far behind (machine stalled): do not burst
                next_t = now

    def _tick(self, k: int, now: float) -> None:
        f = self.faults
        rng = self._rng
        pieces: list[bytes] = []
        frames: list[tuple[int, int, bool]] = []
        for sid in self.sensor_ids:
            seq = self._seq[sid]
            self._seq[sid] = (seq + 1) % SEQ_MODULO
            if self._paused_until.get(sid, 0.0) > now:
                continue
            values = self.source(sid, k)
            data = encode_binary(sid, seq, values) if self.mode == "binary" else encode_text(sid, seq, values)
            intact = True
            if f.corrupt_prob and rng.random() < f.corrupt_prob:
                buf = bytearray(data)
                for bit in rng.choice(8 * len(buf), size=int(rng.integers(1, 4)), replace=False):
                    buf[bit // 8] ^= 1 << (bit % 8)
                data, intact = bytes(buf), False
            elif f.truncate_prob and rng.random() < f.truncate_prob:
                data, intact = data[: int(rng.integers(1, len(data)))], False
            pieces.append(data)
            frames.append((sid, seq, intact))
        if f.garbage_prob and rng.random() < f.garbage_prob:
            burst = rng.integers(0, 256, int(rng.integers(1, f.garbage_max_bytes + 1)), dtype=np.uint8).tobytes()
            pieces.insert(int(rng.integers(0, len(pieces) + 1)), burst)
        if not pieces:
            return
        if self.wire_baud is None:
            ok = self._write(b"".join(pieces))
        else:  # each piece when its last byte is off the wire
            ok, sent = True, 0
            for piece in pieces:
                sent += len(piece)
                wait = now + wire_time_s(sent, self.wire_baud) - time.monotonic()
                if wait > 0 and self._stop.wait(wait):
                    return
                ok = self._write(piece) and ok
        self.sent.extend(SentFrame(sid, seq, intact and ok, now) for sid, seq, intact in frames)

    def _write(self, data: bytes) -> bool:
        """Write everything or report that some bytes were dropped (full pty or unplugged)."""
        with self._lock:
            fd = self._master
            if fd is None:
                self.bytes_dropped += len(data)
                return False
            view = memoryview(data)
            deadline = time.monotonic() + 0.005
            while view:
                try:
                    n = os.write(fd, view)
                    view = view[n:]
                except BlockingIOError:
                    if time.monotonic() > deadline:
                        break
                    time.sleep(0.0005)
                except OSError as exc:
                    if exc.errno in (errno.EIO, errno.EBADF):
                        break
                    raise
            self.bytes_dropped += len(view)
            return not view

    # -------------------------------------------------------------- ground truth for tests

    def intact_sent(self) -> set[tuple[int, int]]:
        return {(s.sensor_id, s.seq) for s in self.sent if s.intact}

    def corrupted_sent(self) -> set[tuple[int, int]]:
        return {(s.sensor_id, s.seq) for s in self.sent if not s.intact}
