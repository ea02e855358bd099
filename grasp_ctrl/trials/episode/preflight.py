"""Pre-flight check of the hand and the fingertips before trials on a real (or
emulated) hand, and the operator's go-ahead.

Every servo must answer its ping with the configured model and report no
hardware error; every fingertip must stream valid frames and be tareable: over
one tare window its frames pass validation and its pdc stays within the contact
threshold of the window's mean (the baseline taring would set: a fingertip whose
pdc moves more, pressed or knocked while taring, would read as in contact). A failure
is one line naming the servo or fingertip. Only then is the operator asked to
confirm the arm's start pose (``--yes`` answers for scripted use).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.errors import FrameError, GraspCtrlError, HardwareError
from grasp_ctrl.tactile.frames import validate_frames
from grasp_ctrl.tactile.layout import PDC

FRAME_TIMEOUT_S = 2.0


class NotConfirmed(GraspCtrlError):
    """The operator did not confirm the start; nothing was run."""


@dataclass(frozen=True)
class PreflightReport:
    servos: list[str]  # "name (id N)"
    fingertips: list[str]  # "name (sensor N): pdc within +-X"

    def summary(self) -> str:
        return (
            f"pre-flight: {len(self.servos)} servos answered, no hardware errors; "
            f"{len(self.fingertips)} fingertips streaming and tareable ({'; '.join(self.fingertips)})"
        )


def check_servos(dxl: Any) -> list[str]:
    """Ping every servo (naming any missing or of the wrong model), then its error status."""
    dxl.check_servos()
    errors = dxl.read_hardware_errors()
    if errors:
        raise HardwareError(
            f"pre-flight: servo hardware error: {dxl._describe(errors)}; power-cycle or run `hand-check --recover`"
        )
    return [f"{j.name} (id {j.servo_id})" for j in dxl.joints]


def check_fingertips(
    sensors: Any, hand: HandConfig, next_sample: Callable[[], None], timeout_s: float = FRAME_TIMEOUT_S
) -> list[str]:
    """Frames from every fingertip (``wait_for_frames`` names a silent one), then one tare
    window of ``tactile.tare_frames`` samples (``next_sample`` waits for the next)."""
    sensors.wait_for_frames(timeout_s, min_frames=1)
    ids = [f.sensor_id for f in hand.fingers]
    window = []
    for _ in range(hand.tactile.tare_frames):
        next_sample()
        latest = sensors.read_latest()
        window.append([latest[sid].values for sid in ids])
    frames = np.asarray(window, dtype=float)  # (k, n_tips, 44)
    limit = hand.tactile.contact_pdc_threshold
    out = []
    for i, f in enumerate(hand.fingers):
        who = f"fingertip {f.name!r} (sensor {f.sensor_id})"
        try:
            validate_frames(frames[:, i])
        except FrameError as exc:
            raise HardwareError(f"pre-flight: {who} cannot be tared: {exc}") from None
        pdc = frames[:, i, PDC]
        moves = float(np.max(np.abs(pdc - pdc.mean())))
        if moves > limit:
            raise HardwareError(
                f"pre-flight: {who} cannot be tared: its pdc moves {moves:.0f} counts from its mean "
                f"over {len(frames)} frames (contact threshold {limit:g}); is it touching something?"
            )
        out.append(f"{f.name} (sensor {f.sensor_id}): pdc within +-{moves:.0f}")
    return out


def preflight_hardware(hand: HandConfig, port: str | None = None, sensor_port: str | None = None) -> PreflightReport:
    """The real hand: servos on the bus (torque untouched), fingertips on their ports."""
    from grasp_ctrl.hardware.dynamixel import DynamixelHand
    from grasp_ctrl.tactile_link.serial_sensors import SerialSensors

    dxl = DynamixelHand(hand, port, handle_signals=False)
    dxl.bus.open()
    dxl.connected = True
    try:
        servos = check_servos(dxl)
    finally:
        dxl.close_port_only()
    sensors = SerialSensors.from_hand(hand, port=sensor_port)
    sensors.start()
    try:
        tips = check_fingertips(sensors, hand, lambda: time.sleep(hand.dt))
    finally:
        sensors.close()
    return PreflightReport(servos, tips)


def preflight_emulated(hand: HandConfig, obj: Any, seed: int, variation: Any = None) -> PreflightReport:
    """The emulated rig of ``run --emulate``, on a world of the first object (before any trial),
    drawn under ``variation`` (sim/variation.py; None: nominal) as its first trial is."""
    from grasp_ctrl.emulators.world_rig import emulated_backends
    from grasp_ctrl.sim.mujoco_backends import make_world
    from grasp_ctrl.sim.registry import world_params

    world = make_world(hand, obj, seed, world_params("mujoco", variation))
    hand_backend, sensors = emulated_backends(world, hand)
    try:
        hand_backend.connect()
        sensors.start()
        servos = check_servos(hand_backend.dxl)

        def next_sample() -> None:
            world.step()

        tips = check_fingertips(sensors, hand, next_sample)
    finally:
        try:
            sensors.close()
        finally:
            hand_backend.close()
    return PreflightReport(servos, tips)


def confirm_start(yes: bool, ask: Callable[[str], str] = input, say: Callable[[str], None] | None = None) -> None:
    """The operator's go-ahead for the arm pose; ``yes`` answers it (scripted runs)."""
    question = "Is the arm at its start pose, the object in place and the workspace clear? [y/N] "
    if yes:
        if say:
            say(question + "y (--yes)")
        return
    try:
        answer = ask(question).strip().lower()
    except EOFError:
        answer = ""
    if answer not in ("y", "yes"):
        raise NotConfirmed("start not confirmed: no trial was run (answer y, or pass --yes)")
