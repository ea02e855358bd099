"""Pre-flight check of the hand and the fingertips before trials on a real (or
emulated) hand, and the operator's go-ahead.

Every servo must answer its ping with the configured model and report no
hardware error; every fingertip must stream valid frames and be tareable: over
one tare window its frames pass validation and its pdc stays within the contact
threshold of the window's mean (the baseline taring would set: a fingertip whose
pdc moves more, pressed or knocked while taring, would read as in contact). A failure
is one line naming the servo or fingertip. Only then is the operator asked to
confirm the arm's start pose (``--yes`` answers for scripted use).

It also budgets the servo bus from the hand file (emulators/bus_timing.py): a tick's worst
bus time (state sync read, goal sync write, health poll, each read's tail held up to the USB
adapter's latency timer) that takes more than half of the control tick leaves too little for
sensing and the controller, and a warning names the problem and the fix (``latency_timer_ms
= 1``, or its sysfs file); the run goes on, and a realtime dry run shows the deadline misses.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.sensor_layout import PDC
from grasp_ctrl.errors import FrameError, GraspCtrlError, HardwareError
from grasp_ctrl.hardware.base import FIRST_FRAMES_TIMEOUT_S
from grasp_ctrl.tactile.frames import validate_frames

# The share of a control tick the servo bus may take; the rest is sensing, estimator, controller.
BUS_SHARE = 0.5
SYSFS_USB_SERIAL = "/sys/bus/usb-serial/devices"


class NotConfirmed(GraspCtrlError):
    """The operator did not confirm the start; nothing was run."""


@dataclass(frozen=True)
class PreflightReport:
    servos: list[str]  # "name (id N)"; a CAN hand's joints: "name (CAN joint N)"
    fingertips: list[str]  # "name (sensor N): pdc within +-X"
    warnings: tuple[str, ...] = ()  # problems that do not stop the run (the bus budget)
    can_bus: str | None = None  # a torque-controlled hand on CAN: its bus ("socketcan can0")

    def summary(self) -> str:
        if self.can_bus is None:
            hand = f"{len(self.servos)} servos answered, no hardware errors"
        else:
            hand = f"{len(self.servos)} joints reported on CAN bus {self.can_bus}, no hand faults"
        line = (
            f"pre-flight: {hand}; "
            f"{len(self.fingertips)} fingertips streaming and tareable ({'; '.join(self.fingertips)})"
        )
        return "\n".join([line, *(f"pre-flight: warning: {w}" for w in self.warnings)])


def _sysfs_file(port: str) -> str:
    """The latency_timer file to name in a fix (the port's own where it is a ttyUSB name)."""
    name = Path(port).name
    return f"{SYSFS_USB_SERIAL}/{name if name.startswith('ttyUSB') else 'ttyUSB0'}/latency_timer"


def bus_budget_warning(hand: HandConfig, hand_file: str | None = None, adapter_ms: int | None = None) -> str | None:
    """One line naming why the servo bus cannot keep the control tick, and the fix; None when it
    can. ``adapter_ms``: the adapter's own latency timer where it differs from the hand file's
    and cannot be set (the real hand's sysfs file)."""
    from grasp_ctrl.emulators.bus_timing import tick_bus_time_s

    d = hand.dynamixel
    latency_ms = adapter_ms if adapter_ms is not None else d.latency_timer_ms
    bus = tick_bus_time_s(len(hand.joints), d.baud, latency_ms / 1000.0, d.fast_sync_read)
    tick_ms = hand.dt * 1000.0
    problems = []
    if bus.worst_s > BUS_SHARE * hand.dt:
        wire_ms = (bus.worst_s - 2 * bus.latency_timer_s) * 1000.0  # a health-poll tick reads twice
        where = f"[dynamixel] latency_timer_ms in {hand_file}" if hand_file else "[dynamixel] latency_timer_ms"
        if adapter_ms is not None:
            where = f"{_sysfs_file(d.port)}, which could not be set to the hand file's {d.latency_timer_ms}"
        cause = f"{wire_ms:.1f} ms on the wire at {d.baud} baud"
        if latency_ms > 1:
            cause += (
                f", plus up to {latency_ms} ms in the USB adapter per sync read: latency timer {latency_ms} ms, {where}"
            )
        if bus.worst_s >= hand.dt:
            verdict = "more than the tick itself, so the loop will miss its deadlines"
        else:
            rest_ms = tick_ms - bus.worst_s * 1000.0
            verdict = f"more than half the tick, leaving {rest_ms:.1f} ms for sensing and the controller: expect deadline misses"
        if latency_ms > 1:
            fix = (
                f"set latency_timer_ms = 1 in the hand file (written to the adapter on connect), or on Linux: "
                f"echo 1 | sudo tee {_sysfs_file(d.port)} (or the udev rule in docs/hardware.md)"
            )
        else:
            fix = "a faster bus: set the servos' Baud Rate and [dynamixel] baud to 4000000"
        problems.append(
            f"servo bus too slow for the {tick_ms:g} ms control tick: up to {bus.worst_s * 1000:.1f} ms of bus time "
            f"a tick ({cause}), {verdict}; fix: {fix}"
        )
    if latency_ms > d.packet_timeout_ms:
        problems.append(
            f"replies held up to {latency_ms} ms by the USB adapter outlast packet_timeout_ms = "
            f"{d.packet_timeout_ms:g}, so reads time out and are retried; fix: latency_timer_ms = 1"
        )
    return "; ".join(problems) or None


def adapter_latency_ms(port: str, configured_ms: int, sysfs_root: str = SYSFS_USB_SERIAL) -> int | None:
    """The USB adapter's latency timer where it differs from ``configured_ms`` and its sysfs file
    is not writable (so connecting will not set it); None otherwise (or no such file)."""
    from grasp_ctrl.hardware.dynamixel.port import latency_timer_path

    path = latency_timer_path(port, sysfs_root)
    if path is None:
        return None
    try:
        current = int(path.read_text().strip())
    except (OSError, ValueError):
        return None
    if current == configured_ms or os.access(path, os.W_OK):
        return None
    return current


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
    sensors: Any, hand: HandConfig, next_sample: Callable[[], None], timeout_s: float = FIRST_FRAMES_TIMEOUT_S
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


def preflight_hardware(
    hand: HandConfig, port: str | None = None, sensor_port: str | None = None, hand_file: str | None = None
) -> PreflightReport:
    """The real hand: servos on the bus (torque untouched), fingertips on their ports; the bus
    budget from the hand file and the adapter's latency timer (``hand_file``: named in a warning)."""
    from grasp_ctrl.hardware.dynamixel import DynamixelHand

    if not hand.servo_driven:  # a torque-controlled hand on CAN: its own check, then the fingertips
        from grasp_ctrl.hardware.allegro.bus import describe

        assert hand.torque_pd is not None
        servos = _check_can_hand(hand, port)
        tips = _check_serial_fingertips(hand, sensor_port)
        return PreflightReport(servos, tips, can_bus=describe(hand.torque_pd, port))
    dxl = DynamixelHand(hand, port, handle_signals=False)
    dxl.bus.open()
    dxl.connected = True
    try:
        servos = check_servos(dxl)
    finally:
        dxl.close_port_only()
    tips = _check_serial_fingertips(hand, sensor_port)
    adapter = adapter_latency_ms(dxl.port_name, hand.dynamixel.latency_timer_ms)
    warning = bus_budget_warning(hand, hand_file, adapter)
    return PreflightReport(servos, tips, (warning,) if warning else ())


def _check_serial_fingertips(hand: HandConfig, sensor_port: str | None) -> list[str]:
    """``check_fingertips`` on the real fingertips' serial stream, on the wall clock."""
    from grasp_ctrl.tactile_link.serial_sensors import SerialSensors

    sensors = SerialSensors.from_hand(hand, port=sensor_port)
    sensors.start()
    try:
        return check_fingertips(sensors, hand, lambda: time.sleep(hand.dt))
    finally:
        sensors.close()


def _check_can_hand(hand: HandConfig, channel: str | None) -> list[str]:
    """The Allegro on CAN: it reports every joint and no fault, then goes limp again (zero torque,
    system off)."""
    from grasp_ctrl.hardware.allegro import AllegroCANHand
    from grasp_ctrl.hardware.allegro.pd_loop import PDLoop

    can = AllegroCANHand(hand, channel, handle_signals=False, threaded=False)
    can.connect()
    try:
        can.request_health()
        time.sleep(0.05)
        if isinstance(can.loop, PDLoop):  # (stepped here: threaded=False)
            can.loop.poll(0.0)
        can.check_health()
    finally:
        can.safe_stop("torque_off")
        can.close()
    return [f"{j.name} (CAN joint {j.servo_id})" for j in hand.joints]


def preflight_emulated(
    hand: HandConfig,
    obj: Any,
    seed: int,
    variation: Any = None,
    realtime: bool = False,
    hand_file: str | None = None,
    backend_name: str | None = None,
) -> PreflightReport:
    """The emulated rig of ``run --emulate``, on a world of the first object (before any trial),
    drawn under ``variation`` (sim/variation.py; None: nominal) as its first trial is;
    ``realtime``: on the bus's and the bridge's real time, the world stepped every tick of
    wall time. The bus budget is the hand file's (``hand_file``: named in a warning).
    ``backend_name``: the emulated entry (default: the Dynamixel hand's); a hand backend with a
    ``preflight`` method checks its own joints (the Allegro on CAN)."""
    from grasp_ctrl.rigs.registry import EMULATED_HAND, backend

    emulated = backend(backend_name or EMULATED_HAND)
    world = emulated.make_world()(hand, obj, seed, emulated.world_params(variation))
    hand_backend, sensors = emulated.make_backends(realtime)(world, hand)
    try:
        hand_backend.connect()
        sensors.start()
        own = getattr(hand_backend, "preflight", None)
        servos = own() if own is not None else check_servos(hand_backend.dxl)

        def next_sample() -> None:
            if not realtime:
                world.step()
                return
            hand_backend.before_world_step()
            world.step()
            hand_backend.after_world_step()
            sensors.after_world_step()
            time.sleep(hand.dt)  # the bridge sends the new frames on its own clock

        if hand_backend.trial_clock is not None:
            hand_backend.trial_clock.start()
        tips = check_fingertips(sensors, hand, next_sample)
    finally:
        try:
            sensors.close()
        finally:
            hand_backend.close()
    warning = bus_budget_warning(hand, hand_file) if hand.servo_driven else None
    can_bus = getattr(hand_backend, "can_bus", None)  # the Allegro's emulation: its virtual bus
    return PreflightReport(servos, tips, (warning,) if warning else (), can_bus=can_bus)


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
