"""The Allegro's whole CAN path without a hand: ``AllegroCANHand`` + the emulator + the MuJoCo world.

``EmulatedAllegroHand(world, hand)`` has the HandBackend interface, and every read and write goes
through the real backend: ``AllegroCANHand`` -> its PD loop -> python-can's virtual bus -> the
Allegro emulator (emulators/allegro_can.py). The world is the physics, in lockstep with simulated
time, one PD period per control tick:

- ``read``: the emulator reports the world's joint angles (``q_measured``, quantised to the
  hand's counts) as the four finger-pose frames, and the backend's loop takes them;
- ``write_goals``: the goal goes to the loop, which runs one period at the world's time: its PD
  torques (clamped, in PWM units) go out as the four torque frames; the emulator takes them and
  they drive the world.

How torques drive the world (decision record 0016). The MuJoCo scene of a ``torque_pd`` hand
already is the host's PD: each joint's position actuator has the hand file's ``kp_nm_per_rad``,
``kd_nm_s_per_rad`` as its ``kv`` and ``torque_limit_nm`` as its force range, integrated at
MuJoCo's 2 ms step (the host loop modelled as continuous). So each received torque ``tau`` sets the
actuator's goal to the angle at which that PD gives exactly ``tau`` at the world's present state:

    goal = q + (tau + kd dq) / kp      (q, dq: the world's, calibrated angles)

For the length of the world's step (one control period) the world's PD then evolves from the
torque the host sent, as a hand holding the host's last torque and the host's next ones would.
Where the host's torque is clamped, the recovered goal is the one whose torque is the clamp now;
the world's PD eases off as the joint moves within the step, where the host's would stay clamped
until its next frame. System off, or zero torque on every joint (torque off, a fault), switches
the world's actuators off: the joints go limp.

``realtime=True`` (``run --backend allegro_can --emulate --realtime``): the wall-clock dry run.
The backend's PD loop runs in its own process at ``[torque_pd] rate_hz`` (333 Hz) on the wall
clock, as on a real hand (hardware/allegro/pd_process.py), and the emulated hand in another
(emulators/allegro_can_process.py), the two on a socket pair; the emulator streams the joint
positions every report period (3 ms). (Where child processes cannot run, both are threads of
this process on python-can's virtual bus.) The trial runner steps the world on the wall clock and calls ``before_world_step`` (the
torques the emulator received last drive the world's next step, as above) and ``after_world_step``
(the emulator reports the world's new angles from then on); ``read`` and ``write_goals`` are the
backend's alone (the latest positions, the goal handed to the loop). Joint states are stamped with
the trial's clock (``clock``, a ``TrialClock``, shared with the fingertips). ``bus_figures`` gives
the record the PD loop's periods from the trial's first world step on (``pd_loop``: p50, p90,
p99, max against the 3 ms budget, and the periods missed).
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import time
from typing import Any

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.emulators.allegro_can import AllegroCANEmulator, virtual_link
from grasp_ctrl.emulators.allegro_can_process import AllegroCANEmulatorProcess
from grasp_ctrl.emulators.wall_clock import TrialClock
from grasp_ctrl.emulators.world_hand import WorldClock
from grasp_ctrl.errors import HardwareError, UsageError
from grasp_ctrl.hardware.allegro.child import SocketLink, processes_supported, socket_pair
from grasp_ctrl.hardware.allegro.hand import AllegroCANHand
from grasp_ctrl.hardware.allegro.pd_loop import PDLoop
from grasp_ctrl.hardware.allegro.protocol import JointMap
from grasp_ctrl.hardware.base import JointState
from grasp_ctrl.sim.world_api import World

# How long (real time) a tick waits for the emulator's thread to take the torque frames.
FRAME_WAIT_S = 0.5
_channels = itertools.count()


def implied_goal(q: np.ndarray, dq: np.ndarray, tau_nm: np.ndarray, kp: np.ndarray, kd: np.ndarray) -> np.ndarray:
    """The goal at which the PD ``kp (goal - q) - kd dq`` gives ``tau_nm`` at (q, dq)."""
    return q + (tau_nm + kd * dq) / kp


class EmulatedAllegroHand:
    def __init__(self, world: World, hand: HandConfig, realtime: bool = False, clock: TrialClock | None = None) -> None:
        if hand.torque_pd is None:
            raise UsageError(f"hand {hand.name!r}: the Allegro CAN emulation drives a torque_pd hand")
        self.world = world
        self.hand = hand
        self.realtime = realtime
        # realtime: the trial's wall clock (started by the loop); lockstep: the world's clock
        self.trial_clock = (clock or TrialClock(world.t)) if realtime else None
        self._stepped = False  # realtime: the world has stepped (the PD figures count from then)
        self.map = JointMap.from_hand(hand)
        self.kp = np.array([j.kp_nm_per_rad or 0.0 for j in hand.joints])
        self.kd = np.array([j.kd_nm_s_per_rad or 0.0 for j in hand.joints])
        if np.any(self.kp <= 0):
            raise UsageError(f"hand {hand.name!r}: the CAN emulation needs kp_nm_per_rad > 0 on every joint")
        self.channel = f"allegro-emulated-{os.getpid()}-{next(_channels)}"
        # realtime: the PD loop and the hand each in a process, on a socket pair
        self.cross_process = realtime and processes_supported()
        self.emu: AllegroCANEmulator | AllegroCANEmulatorProcess
        self._host_end: SocketLink | None = None
        if self.cross_process:
            hand_end, host_end = socket_pair()
            self.emu = AllegroCANEmulatorProcess(hand_end, self.map, self._q())
            self._host_end = SocketLink(host_end, f"socketpair {self.channel}")
        else:
            self.emu = AllegroCANEmulator(
                virtual_link(self.channel, f"emulated Allegro on {self.channel}"),
                self.map,
                self._q(),
                stream=realtime,
            )
        self.can: AllegroCANHand | None = None
        kind = "socketpair" if self.cross_process else "virtual"
        self.can_bus = f"{kind} {self.channel} (emulated)"  # what the pre-flight names

    def _q(self) -> np.ndarray:
        return np.asarray(self.world.q_measured, dtype=float)

    def connect(self) -> None:
        tp = self.hand.torque_pd
        assert tp is not None
        kind = "socketpair" if self.cross_process else "virtual"  # (the bus's name in what it reports)
        virtual = dataclasses.replace(self.hand, torque_pd=dataclasses.replace(tp, interface=kind))
        try:
            self.emu.start()
            self.can = AllegroCANHand(
                virtual,
                self.channel,
                clock=self.trial_clock if self.trial_clock is not None else WorldClock(self.world),
                link=self._host_end or virtual_link(self.channel, f"virtual {self.channel}"),
                handle_signals=False,
                threaded=self.realtime,  # realtime: the PD loop's own process (or thread), on the wall clock
                connect_timeout_s=2.0,  # the emulator is a thread or process on a possibly busy host
            )
            self.can.connect()
        except BaseException:
            self.emu.close()
            if self._host_end is not None:
                self._host_end.close()
            raise
        if not self.realtime:
            self._run_period()

    # ---- the world's side ----------------------------------------------------------------------
    def _publish(self) -> None:
        assert isinstance(self.emu, AllegroCANEmulator)  # (lockstep: in this process)
        self.emu.set_positions(self._q())
        self.emu.send_positions()

    def _run_period(self) -> None:
        """One PD period at the world's time; the torques it sent drive the world."""
        assert self.can is not None and isinstance(self.can.loop, PDLoop)
        loop = self.can.loop
        c = loop.counters
        before_sent = c.torque_frames + c.zero_torque_frames
        before_taken = self.emu.torque_frames
        loop.cycle(float(self.world.t))
        sent = c.torque_frames + c.zero_torque_frames - before_sent
        end = time.monotonic() + FRAME_WAIT_S
        while self.emu.torque_frames - before_taken < sent:
            if time.monotonic() > end:
                raise HardwareError("the Allegro emulator did not receive the torque frames")
            time.sleep(2e-5)
        self._drive_world()

    def _drive_world(self) -> None:
        w = self.world
        tau = self.emu.torque_nm()
        dq = np.asarray(getattr(w, "dq", np.zeros_like(tau)), dtype=float)
        w.command_goal(implied_goal(self._q(), dq, tau, self.kp, self.kd))
        # zero torque on every joint (torque off, or a fault) is a limp hand, not a PD about q
        w.torque_on = bool(self.emu.system_on) and bool(np.any(self.emu.pwm))

    # ---- realtime: the runner steps the world on the wall clock ----------------------------------
    def before_world_step(self) -> None:
        """The torques the emulator received last drive the world's next step."""
        if not self._stepped and self.can is not None and self.can.loop is not None:
            self._stepped = True
            self.can.loop.reset_periods()  # the record's PD figures: the trial's, not the start-up's
        self._drive_world()

    def after_world_step(self) -> None:
        """The emulator reports the world's new angles from now on (its own 3 ms stream)."""
        self.emu.set_positions(self._q())

    def bus_figures(self) -> dict[str, Any]:
        """The link a realtime record was measured on and its PD loop's periods (the trial
        runner's ``timings.loop``)."""
        # a socket pair between processes or python-can's in-process bus: no wire time either way
        out: dict[str, Any] = {"bus": "can socketpair" if self.cross_process else "can virtual"}
        if self.can is not None and self.can.loop is not None:
            out["pd_loop"] = self.can.loop.period_figures()
        return out

    # ---- HandBackend -----------------------------------------------------------------------------
    def read(self) -> JointState:
        assert self.can is not None and self.can.loop is not None, "connect() first"
        if self.realtime:  # the loop's latest set of positions (its process or thread takes the frames)
            return self.can.read()
        assert isinstance(self.can.loop, PDLoop)
        self._publish()
        self.can.loop.poll(0.0)
        return self.can.read()

    def write_goals(self, q_goal: np.ndarray) -> None:
        assert self.can is not None, "connect() first"
        self.can.write_goals(q_goal)
        if not self.realtime:  # realtime: the loop drives to it from its next period
            self._run_period()

    def set_torque(self, enabled: bool) -> None:
        assert self.can is not None, "connect() first"
        self.can.set_torque(enabled)

    def check_health(self) -> None:
        assert self.can is not None, "connect() first"
        self.can.check_health()

    def preflight(self) -> list[str]:
        """The pre-flight's view (trials/episode/preflight.py): every joint reported, no fault."""
        assert self.can is not None and self.can.loop is not None, "connect() first"
        self.can.check_health()
        return [f"{j.name} (CAN joint {j.servo_id})" for j in self.hand.joints]

    def close(self) -> None:
        # The world does not step during close, so an 'open' ramp could not complete here; the
        # trial runner's settle phase already applied the safe action in the world. Zero torque,
        # system off, then release the emulator.
        try:
            if self.can is not None and self.can.connected:
                self.can.safe_stop("torque_off")
                self.can.close()
                # the last frames (zero torque, system off) reach the world
                end = time.monotonic() + FRAME_WAIT_S
                while self.emu.system_on and time.monotonic() < end:
                    time.sleep(1e-4)
                self._drive_world()
        finally:
            self.emu.close()


def allegro_emulated_backends(world: World, hand: HandConfig, realtime: bool = False) -> tuple[object, object]:
    """The hand and sensor backends of one emulated Allegro trial: the CAN path above and the
    fingertips' serial path (emulators/world_rig.py); ``realtime``: both on one wall clock."""
    from grasp_ctrl.emulators.world_rig import EmulatedTactileSensors

    clock = TrialClock(world.t) if realtime else None  # one clock for both
    hand_backend = EmulatedAllegroHand(world, hand, realtime, clock)
    return hand_backend, EmulatedTactileSensors(world, hand, realtime, clock)


def allegro_realtime_backends(world: World, hand: HandConfig) -> tuple[object, object]:
    """``allegro_emulated_backends`` on the wall clock (module level: picklable)."""
    return allegro_emulated_backends(world, hand, realtime=True)
