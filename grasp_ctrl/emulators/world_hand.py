"""Hardware in the loop without hardware: DynamixelHand + emulator + the mock world.

``EmulatedDynamixelHand(world, hand)`` has the MockHand constructor and the
HandBackend interface, but every read and write goes through the real
backend code path: ``DynamixelHand`` -> dynamixel_sdk -> pty -> the Protocol
2.0 emulator. The emulator runs with ``external_physics``: the mock world is
the physics. Each ``read`` publishes the world's joint state (position,
velocity, current) on the emulated servos; each ``write_goals`` waits until the
emulator has taken the sync write and hands the goals it received (quantised
to counts) to the world. So a controller trial on the mock world exercises
calibration, clamping, the step limit and the bus exactly as on a real hand.
On the MuJoCo world (``run --backend dynamixel --emulate``) the servos publish the
angles its joint calibration offsets leave them (``q_measured``) and their goals
go back through ``command_goal``: the offsets stay inside the world.

``realtime=True`` (``run --backend dynamixel --emulate --realtime``): the chain takes the bus's
real time (baud rate, return delay, USB latency timer: bus_timing.py) and the hand no longer
waits on the world. The trial runner steps the world on the wall clock and calls
``before_world_step`` (the goals the servos hold now move the world) and ``after_world_step``
(the servos report the world's new state); ``read`` and ``write_goals`` are the bus
transactions alone, as on a real hand. Joint states are stamped with the trial's wall clock
(``clock``, a ``TrialClock``), not the world's step.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.emulators.bus_timing import BusTiming
from grasp_ctrl.emulators.dxl_chain import DynamixelChainEmulator
from grasp_ctrl.emulators.wall_clock import TrialClock
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.base import JointState
from grasp_ctrl.hardware.dynamixel import DynamixelHand
from grasp_ctrl.hardware.dynamixel.calibration import Calibration
from grasp_ctrl.hardware.dynamixel.control_table import RAD_PER_COUNT
from grasp_ctrl.sim.world_api import World


class WorldClock:
    """A world's simulated time as a clock (what frames and joint states are stamped with)."""

    def __init__(self, world: World) -> None:
        self.world = world

    def now(self) -> float:
        return float(self.world.t)


def _present_current_a(world: World) -> np.ndarray:
    """The servos' present current (A)."""
    return np.asarray(world.joint_current_a)


def _measured_q(world: World) -> np.ndarray:
    """The joint angles the servos report (calibrated: the world's offsets stay inside it)."""
    return np.asarray(world.q_measured, dtype=float)


def _command(world: World, q_goal: np.ndarray) -> None:
    """The goals the servos received (calibrated angles) to the world."""
    world.command_goal(q_goal)


# The reply deadline of the emulated hand: the emulator is a thread on a possibly busy host.
RELAXED_TIMEOUT_MS = 50.0


class EmulatedDynamixelHand:
    def __init__(self, world: World, hand: HandConfig, realtime: bool = False, clock: TrialClock | None = None) -> None:
        self.world = world
        self.hand = hand
        self.realtime = realtime
        self.trial_clock = (clock or TrialClock(world.t)) if realtime else None
        self.timing = BusTiming.for_hand(hand) if realtime else None
        self.cal = Calibration.from_joints(hand.joints)
        self.ids = [j.servo_id for j in hand.joints]
        self.emu = DynamixelChainEmulator.for_hand(hand, _measured_q(world), timing=self.timing)
        self.emu.external_physics = True
        self.dxl: DynamixelHand | None = None
        self._q_prev = _measured_q(world).copy()

    def connect(self) -> None:
        self.emu.start()
        self._publish()
        # The emulator is a thread on a possibly busy host, not a servo answering in
        # microseconds: give it a generous reply deadline so a trial is not aborted
        # by the scheduler (the timing path itself is covered by the backend's tests).
        # In realtime the deadline also outlasts two latency-timer periods, so a long timer
        # shows as slow ticks and deadline misses (what the dry run measures), not as
        # retries; the pre-flight names a packet_timeout_ms shorter than the timer.
        d = self.hand.dynamixel
        timeout_ms = max(RELAXED_TIMEOUT_MS, d.packet_timeout_ms)
        if self.realtime:
            timeout_ms = max(timeout_ms, 2.0 * d.latency_timer_ms + RELAXED_TIMEOUT_MS)
        relaxed = dataclasses.replace(
            self.hand, dynamixel=dataclasses.replace(d, packet_timeout_ms=timeout_ms, retries=5)
        )
        clock = self.trial_clock if self.trial_clock is not None else WorldClock(self.world)
        self.dxl = DynamixelHand(relaxed, self.emu.port, clock=clock, handle_signals=False)
        self.dxl.connect()
        self._pull_goals()

    def _publish(self) -> None:
        w = self.world
        q = _measured_q(w)
        dq = (q - self._q_prev) / w.dt
        self._q_prev = q.copy()
        current_a = _present_current_a(w)
        counts = self.cal.to_counts_float(q)
        amp_unit = self.dxl.amp_per_unit if self.dxl else 0.001
        for k, i in enumerate(self.ids):
            s = self.cal.sign[k]
            self.emu.set_present(i, counts[k], s * dq[k] / RAD_PER_COUNT, s * current_a[k] / amp_unit)

    def _pull_goals(self) -> None:
        goals = self.emu.goals()
        counts = np.array([goals[i][0] for i in self.ids], dtype=float)
        _command(self.world, self.cal.to_rad(counts))
        self.world.torque_on = all(goals[i][1] for i in self.ids)

    def _wait_for_sync_write(self, before: int, timeout_s: float = 0.5) -> None:
        end = time.monotonic() + timeout_s
        while self.emu.sync_write_count <= before:
            if time.monotonic() > end:
                raise HardwareError("emulator did not receive the sync write")
            time.sleep(2e-5)

    # ---- realtime: the runner steps the world on the wall clock -------------------------
    def bus_figures(self) -> dict[str, float]:
        """The bus a realtime record was measured on (the trial runner's ``timings.loop``)."""
        d = self.hand.dynamixel
        return {"latency_timer_ms": d.latency_timer_ms, "baud": d.baud}

    def before_world_step(self) -> None:
        """The goals (and torque) the servos hold now drive the world's next step."""
        self._pull_goals()

    def after_world_step(self) -> None:
        """The servos report the world's state from now on."""
        self._publish()

    # ---- HandBackend --------------------------------------------------------------------
    def read(self) -> JointState:
        assert self.dxl is not None, "connect() first"
        if not self.realtime:
            self._publish()
        return self.dxl.read()

    def write_goals(self, q_goal: np.ndarray) -> None:
        assert self.dxl is not None, "connect() first"
        if self.realtime:  # a sync write has no reply: the servos take it off the wire
            self.dxl.write_goals(q_goal)
            return
        before = self.emu.sync_write_count
        self.dxl.write_goals(q_goal)
        self._wait_for_sync_write(before)
        self._pull_goals()

    def set_torque(self, enabled: bool) -> None:
        assert self.dxl is not None, "connect() first"
        self.dxl.set_torque(enabled)
        if not self.realtime:
            self._pull_goals()

    def check_health(self) -> None:
        assert self.dxl is not None, "connect() first"
        self.dxl.check_health()

    def close(self) -> None:
        # The world does not step during close, so an 'open' ramp could not
        # complete here; the trial runner's settle phase already applied the
        # safe action in the world. Torque off, then release the emulator.
        try:
            if self.dxl is not None and self.dxl.connected:
                self.dxl.safe_stop("torque_off")
                self.dxl.close_port_only()
        finally:
            self.emu.stop()
