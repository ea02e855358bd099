"""The whole hardware path without hardware: ``run --backend dynamixel --emulate``.

The mock world is the physics behind two emulators on pseudo-terminals:

- the hand: ``EmulatedDynamixelHand`` (world_hand.py), the real ``DynamixelHand``
  backend speaking Protocol 2.0 to the servo-chain emulator (ping, configuration,
  fast sync read, sync write, hardware-error polling, safe stop);
- the fingertips: ``EmulatedTactileSensors`` below, the real ``SerialSensors``
  reader (protocol v1 decoding, CRC, sequence numbers, stale detection) fed by
  the tactile-bridge emulator, which sends the world's frames.

Both run on the world's simulated clock: each control tick publishes the world's
state to the emulators and waits until the backends have it, so a trial is as
reproducible as on the mock, scored from the world's ground truth, and logged the
same way. The arm is the world's (a real arm is another program's business).

``realtime=True`` (``run --backend dynamixel --emulate --realtime``): a wall-clock dry run.
The servo chain takes the bus's real time (world_hand.py, bus_timing.py) and the bridge
streams a frame per fingertip every 10 ms of wall time from its own thread, each frame
reaching the reader after its bytes' time on a UART at the hand file's tactile baud rate; the
trial runner steps the world to keep up with the wall clock and calls each backend's
``before_world_step`` / ``after_world_step``. Both backends stamp with one ``TrialClock``
(``trial_clock``): the world's time base, on the wall clock once the loop starts it.
"""

from __future__ import annotations

import time

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.sensor_layout import COUNT_MAX
from grasp_ctrl.emulators.tactile_bridge import TactileBridgeEmulator
from grasp_ctrl.emulators.wall_clock import TrialClock
from grasp_ctrl.emulators.world_hand import EmulatedDynamixelHand, WorldClock
from grasp_ctrl.hardware.base import FIRST_FRAMES_TIMEOUT_S, Clock, TactileFrame
from grasp_ctrl.sim.world_api import World
from grasp_ctrl.tactile_link.serial_sensors import SerialSensors

# How long (real time) a tick waits for the reader thread to decode the frames it sent.
FRAME_WAIT_S = 0.5


class EmulatedTactileSensors:
    """``SerialSensors`` over a pty, fed one sample of the world's frames per control tick
    (``realtime``: the bridge streams the world's latest frames every 10 ms of wall time)."""

    def __init__(self, world: World, hand: HandConfig, realtime: bool = False, clock: TrialClock | None = None) -> None:
        self.world = world
        self.realtime = realtime
        self.trial_clock = (clock or TrialClock(world.t)) if realtime else None
        self.row = {sid: i for i, sid in enumerate(world.sensor_ids)}
        self._raw = np.array(world.raw, dtype=float)  # the frames the bridge sends (realtime: as published)
        self.bridge = TactileBridgeEmulator(
            list(world.sensor_ids),
            source=self._frame,
            mode=hand.tactile.mode,
            rate_hz=hand.rate_hz,
            wire_baud=hand.tactile.baud if realtime else None,
        )
        frames_clock: Clock = self.trial_clock if self.trial_clock is not None else WorldClock(world)
        self.serial = SerialSensors.from_hand(hand, port=self.bridge.port, clock=frames_clock, reconnect=False)
        self._k = 0

    def _frame(self, sensor_id: int, _k: int) -> np.ndarray:
        raw = self._raw if self.realtime else self.world.raw
        return np.clip(np.rint(raw[self.row[sensor_id]]), 0, COUNT_MAX)

    def after_world_step(self) -> None:
        """Realtime: the bridge's thread sends these frames from now on (one reference swap,
        so it never reads a half-written array)."""
        self._raw = np.array(self.world.raw, dtype=float)

    def send(self) -> None:
        """Put the world's current frames on the wire and wait until they are decoded
        (a frame that does not arrive leaves the older one: the stale check decides)."""
        before = self.serial.frame_counts()
        self.bridge.send_sample(self._k)
        self._k += 1
        deadline = time.monotonic() + FRAME_WAIT_S
        while True:
            counts = self.serial.frame_counts()
            if all(counts[s] > before[s] for s in before) or time.monotonic() > deadline:
                return
            time.sleep(2e-5)

    def start(self) -> None:
        self.serial.start()
        if self.realtime:
            self.bridge.start()
            self.serial.wait_for_frames(FIRST_FRAMES_TIMEOUT_S, min_frames=1)
        else:
            self.send()

    def read_latest(self) -> dict[int, TactileFrame]:
        if not self.realtime:
            self.send()
        return self.serial.read_latest()

    def check_stale(self, now: float | None = None) -> None:
        self.serial.check_stale(now)

    def wait_for_frames(self, timeout_s: float, min_frames: int = 1) -> None:
        self.serial.wait_for_frames(timeout_s, min_frames)

    def frame_counts(self) -> dict[int, int]:
        return self.serial.frame_counts()

    def stats(self) -> dict[str, int]:
        return self.serial.stats()

    def close(self) -> None:
        try:
            self.serial.close()
        finally:
            self.bridge.close()


def emulated_backends(
    world: World, hand: HandConfig, realtime: bool = False
) -> tuple[EmulatedDynamixelHand, EmulatedTactileSensors]:
    """The hand and sensor backends of one emulated trial (runner.run_sim_trial's ``make_backends``);
    ``realtime``: on the bus's and the bridge's real time (the runner steps the world on the wall clock)."""
    clock = TrialClock(world.t) if realtime else None  # one clock for both
    return EmulatedDynamixelHand(world, hand, realtime, clock), EmulatedTactileSensors(world, hand, realtime, clock)


def realtime_backends(world: World, hand: HandConfig) -> tuple[EmulatedDynamixelHand, EmulatedTactileSensors]:
    """``emulated_backends`` on real time (a module-level function: picklable, unlike a partial of a lambda)."""
    return emulated_backends(world, hand, realtime=True)
