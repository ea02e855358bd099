"""The live tactile monitor behind ``python launch.py sensors``.

Tares every fingertip on a no-contact window, then runs at the hand's control
rate: contact gate on tared pdc, the force estimate of the fingertips in contact
(when a policy is loaded), stream statistics, stale/disconnect state. Renders a
table every ``refresh_s``; optionally records every valid frame to CSV.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TextIO

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.sensor_layout import PDC
from grasp_ctrl.errors import HardwareError, SensorStaleError
from grasp_ctrl.estimators.base import Estimate, ForceEstimator
from grasp_ctrl.estimators.pipeline import TactilePipeline
from grasp_ctrl.tactile_link.recorder import FrameRecorder
from grasp_ctrl.tactile_link.serial_sensors import SerialSensors


class _NoEstimate:
    """Stands in when no policy loads: the monitor still tares and gates contact."""

    name = "none"
    has_variance = False

    def estimate(self, tared: np.ndarray, fingers: Sequence[str]) -> Estimate:
        return Estimate(f_sensor=np.zeros((len(tared), 3)))


@dataclass
class TipView:
    name: str
    sensor_id: int
    pdc_tared: float = float("nan")
    contact: bool = False
    f_sensor: np.ndarray | None = None
    age_s: float = float("nan")
    rate_hz: float = 0.0


@dataclass
class Monitor:
    hand: HandConfig
    sensors: SerialSensors
    estimator: ForceEstimator | None = None
    recorder: FrameRecorder | None = None
    out: TextIO | None = None  # default: sys.stdout at the time of printing
    refresh_s: float = 0.5
    redraw: bool = False  # clear the terminal between tables (interactive use)
    fault: str = ""  # the current stale/disconnect message, if any
    faults_seen: int = 0
    tips: list[TipView] = field(default_factory=list)
    stop: threading.Event = field(default_factory=threading.Event)  # set by Ctrl-C: finish cleanly

    def __post_init__(self) -> None:
        self.tips = [TipView(f.name, f.sensor_id) for f in self.hand.fingers]
        # Frames from the serial link are validated by its decoder already.
        self.pipeline = TactilePipeline.from_hand(self.hand, self.estimator or _NoEstimate(), validate=False)

    # ---------------------------------------------------------------- phases

    def take_tare(self, timeout_s: float | None = None, silent_s: float = 1.0) -> None:
        """Average ``tare_frames`` frames per fingertip (keep the fingertips free of contact).

        Fails when, once the stream has begun, a fingertip sends nothing for ``silent_s`` (a
        stale sensor) or when the window is not full after ``timeout_s`` (a slow or silent link;
        default: 2 s and ten times the window at the hand's rate, as a loaded machine slows it)."""
        need = self.hand.tactile.tare_frames
        if timeout_s is None:
            timeout_s = 2.0 + 10.0 * need / self.hand.rate_hz
        per_tip: dict[int, list[np.ndarray]] = {t.sensor_id: [] for t in self.tips}
        deadline = time.monotonic() + timeout_s
        last_frame: dict[int, float] = {}  # empty until the first frame of any fingertip
        while any(len(v) < need for v in per_tip.values()):
            if self.stop.is_set():
                return
            now = time.monotonic()
            for f in self._drain():
                if not last_frame:
                    last_frame = {t.sensor_id: now for t in self.tips}
                per_tip[f.sensor_id].append(np.asarray(f.values, dtype=float))
                last_frame[f.sensor_id] = now
            silent = [
                t
                for t in self.tips
                if last_frame and len(per_tip[t.sensor_id]) < need and now - last_frame[t.sensor_id] > silent_s
            ]
            if silent or now > deadline:
                short = ", ".join(
                    f"{t.name} ({len(per_tip[t.sensor_id])}/{need})"
                    for t in (silent or self.tips)
                    if len(per_tip[t.sensor_id]) < need
                )
                why = f"no frame for {silent_s:g} s" if silent else f"too few tactile frames within {timeout_s:g} s"
                down = self.sensors.disconnect_message()
                raise SensorStaleError(f"taring: {why}: {short}" + (f"; {down}" if down else ""))
            self.stop.wait(0.005)
        window = np.stack([np.stack(per_tip[t.sensor_id][-need:]) for t in self.tips], axis=1)
        self.pipeline.set_baseline(window)

    def run(self, seconds: float | None) -> None:
        """Monitor until ``seconds`` have passed or ``stop`` is set (Ctrl-C)."""
        dt = 1.0 / self.hand.rate_hz
        t0 = time.monotonic()
        next_tick = t0
        next_draw = t0 + self.refresh_s
        self._rate_base = (t0, self.sensors.frame_counts())
        while not self.stop.is_set() and (seconds is None or time.monotonic() - t0 < seconds):
            self._drain()
            self.tick()
            now = time.monotonic()
            if now >= next_draw:
                self.render(now - t0)
                next_draw += self.refresh_s
            next_tick += dt
            self.stop.wait(max(0.0, next_tick - time.monotonic()))
        self._drain()
        self.render(time.monotonic() - t0)  # the final state, however short the run

    # ---------------------------------------------------------------- one tick

    def tick(self) -> None:
        now = self.sensors.now()
        try:
            self.sensors.check_stale(now)
            self.fault = ""
        except HardwareError as exc:
            if not self.fault:
                self.faults_seen += 1
            self.fault = str(exc)
        latest = self.sensors.read_latest()
        if len(latest) < len(self.tips):
            return
        raw = np.stack([np.asarray(latest[t.sensor_id].values, dtype=float) for t in self.tips])
        out = self.pipeline.step(raw)
        tared, contact = out.tared, out.in_contact
        forces: dict[int, np.ndarray] = {}
        if self.estimator is not None:
            forces = {int(i): out.f_sensor[i] for i in np.flatnonzero(contact)}
        for i, tip in enumerate(self.tips):
            tip.pdc_tared = float(tared[i, PDC])
            tip.contact = bool(contact[i])
            tip.f_sensor = forces.get(i)
            tip.age_s = now - latest[tip.sensor_id].t_recv

    def _drain(self) -> list:
        frames = self.sensors.drain_frames()
        if self.recorder is not None:
            self.recorder.write(frames)
        return frames

    # ---------------------------------------------------------------- display

    def _update_rates(self) -> None:
        """Frames per second per fingertip since the previous table."""
        now, counts = time.monotonic(), self.sensors.frame_counts()
        t_prev, prev = getattr(self, "_rate_base", (now, counts))
        if now - t_prev > 1e-3:
            for tip in self.tips:
                tip.rate_hz = (counts[tip.sensor_id] - prev[tip.sensor_id]) / (now - t_prev)
        self._rate_base = (now, counts)

    def render(self, t: float) -> None:
        self._update_rates()
        lines = []
        if self.redraw:
            lines.append("\x1b[H\x1b[J")
        lines.append(f"t = {t:6.1f} s   {self.stats_line()}")
        for port, status in self.sensors.port_status().items():
            lines.append(f"  port {port}: {status}")
        head = f"  {'finger':8s} {'id':>3s} {'contact':>7s} {'pdc':>8s} {'age ms':>7s} {'Hz':>6s}"
        if self.estimator is not None:
            head += f"  {'fx N':>7s} {'fy N':>7s} {'fz N':>7s} {'|f| N':>7s}"
        lines.append(head)
        for tip in self.tips:
            row = (
                f"  {tip.name:8s} {tip.sensor_id:3d} {'yes' if tip.contact else 'no':>7s} "
                f"{tip.pdc_tared:8.1f} {tip.age_s * 1e3:7.1f} {tip.rate_hz:6.1f}"
            )
            if self.estimator is not None:
                if tip.f_sensor is not None:
                    f = tip.f_sensor
                    row += f"  {f[0]:7.2f} {f[1]:7.2f} {f[2]:7.2f} {np.linalg.norm(f):7.2f}"
                else:
                    row += f"  {'-':>7s} {'-':>7s} {'-':>7s} {'-':>7s}"
            lines.append(row)
        if self.fault:
            lines.append(f"  FAULT: {self.fault}")
        if self.recorder is not None:
            lines.append(f"  recording {self.recorder.path}: {self.recorder.rows} frames")
        print("\n".join(lines), file=self.out or sys.stdout, flush=True)

    def stats_line(self) -> str:
        s = self.sensors.stats()
        return (
            f"frames {s['frames']}  crc_err {s['crc_errors']}  len_err {s['length_errors']}  "
            f"range_err {s['range_errors']}  fmt_err {s['format_errors']}  resyncs {s['resyncs']}  "
            f"seq_gaps {s['seq_gaps']} (lost {s['seq_lost']})  disconnects {s['disconnects']}  "
            f"reconnects {s['reconnects']}"
        )
