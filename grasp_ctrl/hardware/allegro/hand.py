"""``AllegroCANHand``: the HandBackend of an Allegro v4 on CAN, with the joint PD loop on the host.

The controller's interface is the Dynamixel hand's (hardware/base.py): ``read`` gives the latest
joint positions and velocities, ``write_goals`` hands a goal to the PD loop (pd_loop.py), which
turns it into torques at the hand's rate. Goals are clamped to ``[safety] max_joint_step_rad``
from the previous goal and to the joint limits, and the torques to each joint's
``torque_limit_nm``, so no frame ever carries a torque outside the hand file's limits.

Start-up (the order of SimLab's driver, AllegroHandDrv.cpp ``init``): system off, ask for the hand
information and the serial number, set the report periods (joint positions every 1000 / rate_hz
ms, rounded: 3 ms at 333 Hz), system on; then one full set of joint positions, and the present
pose (within the limits) becomes the goal, so nothing jumps.

Where the loop runs: in its own process (pd_process.py), which owns the bus, for a bus opened
from the hand file (socketcan, pcan) or a socket end (``SocketLink``: the emulated hand on the
wall clock); there its periods do not wait for this process's interpreter lock. In a thread of
this process for python-can's in-process ``virtual`` bus and any other link object handed in
(the tests), or where child processes cannot run; stepped by the owner with ``threaded=False``.

Safety: use it as a context manager (or call ``close``). A fault of the link (no positions for
``position_stale_s``, an error frame or bus-off, a failed send, an over-temperature report or the
hand's own fault bits) latches the loop into zero torque at once: without trusted positions no PD
can hold or open the hand. ``check_health`` raises it as ``hardware_error``. Any other end (normal
exit, an exception, Ctrl-C, SIGTERM) applies ``[safety] on_fault`` while the loop is healthy:
``open`` (drive to the open posture within the step limit, then zero torque), ``hold`` (hold the
present pose while this program runs) or ``torque_off`` (zero torque). ``close`` always ends with
zero torque, system off and the reports stopped: the host is the PD loop, so no torque outlives it.
"""

from __future__ import annotations

import time

import numpy as np

from grasp_ctrl.config.hand import SAFE_ACTIONS, HandConfig
from grasp_ctrl.errors import HardwareError, UsageError
from grasp_ctrl.hardware.allegro.bus import CanLink, describe, open_link
from grasp_ctrl.hardware.allegro.child import SocketLink, processes_supported
from grasp_ctrl.hardware.allegro.pd_loop import (
    HEALTH_POLL_S,
    PDLoop,
    health_frames,
    position_period_ms,
    send_stop_frames,
    start_frames,
)
from grasp_ctrl.hardware.allegro.pd_process import PDProcess, PDSpec
from grasp_ctrl.hardware.allegro.protocol import JointMap
from grasp_ctrl.hardware.base import Clock, JointState
from grasp_ctrl.hardware.exit_hooks import ExitHooks
from grasp_ctrl.numeric.limits import limited_goal

CONNECT_TIMEOUT_S = 1.0
__all__ = ["AllegroCANHand", "HEALTH_POLL_S", "position_period_ms"]


class MonotonicClock:
    def now(self) -> float:
        return time.monotonic()


class AllegroCANHand:
    """HandBackend over python-can. Joint vectors follow ``hand.joints`` order.

    ``channel`` overrides ``[torque_pd] channel``; ``link`` replaces the bus (tests, the emulated
    hand); ``threaded=False`` leaves the PD loop to the owner's ``loop.cycle`` calls (lockstep);
    ``pd_process``: the loop in its own process (None: where it can, see the module's doc)."""

    def __init__(
        self,
        hand: HandConfig,
        channel: str | None = None,
        clock: Clock | None = None,
        *,
        link: CanLink | None = None,
        handle_signals: bool = True,
        threaded: bool = True,
        connect_timeout_s: float = CONNECT_TIMEOUT_S,
        pd_process: bool | None = None,
    ) -> None:
        if hand.torque_pd is None:
            raise UsageError(
                f"hand {hand.name!r} ({hand.path}) has actuator = {hand.actuator!r}: the Allegro CAN "
                'backend drives a torque-controlled hand (actuator = "torque_pd")'
            )
        self.hand = hand
        self.cfg = hand.torque_pd
        self.channel = channel or self.cfg.channel
        self.name = describe(self.cfg, self.channel)
        self.clock: Clock = clock or MonotonicClock()
        self.joints = hand.joints
        self.map = JointMap.from_hand(hand)
        self.lower = np.array([j.lower_rad for j in self.joints])
        self.upper = np.array([j.upper_rad for j in self.joints])
        self.q_open = np.array([j.open_rad for j in self.joints])
        self.kp = np.array([j.kp_nm_per_rad or 0.0 for j in self.joints])
        self.kd = np.array([j.kd_nm_s_per_rad or 0.0 for j in self.joints])
        self._link = link
        self.threaded = threaded
        self.handle_signals = handle_signals
        self.connect_timeout_s = connect_timeout_s
        if pd_process is None:
            crosses = isinstance(link, SocketLink) or (link is None and self.cfg.interface != "virtual")
            pd_process = threaded and crosses and processes_supported()
        if pd_process and not (threaded and (link is None or isinstance(link, SocketLink))):
            raise UsageError("the PD loop runs in its own process only on its wall clock, on a bus it can open")
        self.pd_process = pd_process
        self.loop: PDLoop | PDProcess | None = None
        self.connected = False
        self.torque_enabled = False
        self.last_goal: np.ndarray | None = None
        self.last_state: JointState | None = None
        self._last_health = -float("inf")
        self._exit_hooks = ExitHooks(self.close)  # the safe stop at exit and on SIGTERM

    # ---- lifecycle -----------------------------------------------------------------------------
    def connect(self) -> None:
        """Open the bus, start the hand (system off, info, periods, system on), wait for a full set
        of joint positions, hold the present pose."""
        if self.pd_process:
            self._connect_process()
            return
        link = self._link if self._link is not None else open_link(self.cfg, self.channel)
        self._link = link
        self.connected = True
        dev = self.map.device_id
        try:
            self.loop = PDLoop(
                link,
                self.map,
                self.kp,
                self.kd,
                self.cfg.rate_hz,
                self.cfg.position_stale_s,
                self.cfg.max_temperature_c,
                clock=self.clock.now,
                name=self.name,
            )
            self.loop.poll(0.0)  # whatever was queued before (the driver flushes too)
            for frame in start_frames(dev, self.cfg.rate_hz):
                link.send(frame)
            state = self.loop.wait_for_positions(self.connect_timeout_s, stepped=True)
            self.last_goal = np.clip(state.q, self.lower, self.upper)
            self.loop.set_goal(self.last_goal, True)
            self.torque_enabled = True
            if self.threaded:
                self.loop.start()
        except BaseException:
            self._shutdown_link()
            raise
        self._install_safety_hooks()

    def _connect_process(self) -> None:
        """``connect`` with the loop in its own process: it opens the bus and starts the hand."""
        link = self._link if isinstance(self._link, SocketLink) else None
        spec = PDSpec(
            joints=self.map,
            kp=self.kp,
            kd=self.kd,
            rate_hz=self.cfg.rate_hz,
            position_stale_s=self.cfg.position_stale_s,
            max_temperature_c=self.cfg.max_temperature_c,
            name=self.name,
            on_fault=self.hand.safety.on_fault,
            q_open=self.q_open,
            lower=self.lower,
            upper=self.upper,
            max_step_rad=self.hand.safety.max_joint_step_rad,
            control_dt=self.hand.dt,
            connect_timeout_s=self.connect_timeout_s,
            bus=None if link is not None else self.cfg,
            channel=self.channel,
        )
        loop = PDProcess(spec, self.clock.now, link)
        self.loop = loop
        self.connected = True
        try:
            loop.start()
            state = loop.state
            if state is None:
                raise HardwareError(f"CAN bus {self.name}: the PD process gave no joint positions")
            self.last_goal = np.clip(state.q, self.lower, self.upper)
            loop.set_goal(self.last_goal, True)
            self.torque_enabled = True
        except BaseException:
            self._shutdown_link()
            raise
        self._install_safety_hooks()

    # ---- per tick ----------------------------------------------------------------------------------
    def read(self) -> JointState:
        """The latest full set of joint positions (never waits; stamped when it was complete)."""
        state = self.loop.state if self.loop is not None else None
        if state is None:
            raise HardwareError(f"CAN bus {self.name}: no joint positions yet (connect() first)")
        js = JointState(q=state.q, dq=state.dq, current_a=np.full(state.q.shape, np.nan), t=state.t)
        self.last_state = js
        return js

    def clamp_goal(self, q_goal: np.ndarray) -> np.ndarray:
        """Limit the step from the previous goal, then clamp to the joint limits."""
        q = np.asarray(q_goal, dtype=float)
        if q.shape != self.lower.shape or not np.all(np.isfinite(q)):
            raise UsageError(f"write_goals: expected {self.lower.size} finite joint angles, got shape {q.shape}")
        return limited_goal(q, self.last_goal, self.hand.safety.max_joint_step_rad, self.lower, self.upper)

    def write_goals(self, q_goal: np.ndarray) -> None:
        q = self.clamp_goal(q_goal)
        self.last_goal = q
        if self.loop is not None:
            self.loop.set_goal(q, self.torque_enabled)

    def set_torque(self, enabled: bool) -> None:
        if enabled and (self.last_goal is None or self.loop is None):
            raise HardwareError("set_torque(True) before connect(): no goal to hold")
        if enabled and self.loop is not None and self.loop.fault is not None:
            raise HardwareError(f"torque on refused after a fault: {self.loop.fault} (close and connect again)")
        self.torque_enabled = enabled
        if self.loop is not None and self.last_goal is not None:
            self.loop.set_goal(self.last_goal, enabled)

    # ---- health ------------------------------------------------------------------------------------
    def check_health(self) -> None:
        """Raise the loop's latched fault (``hardware_error``); every ``HEALTH_POLL_S`` (this
        backend's clock) also ask for the hand's information and temperatures, which the loop
        judges as they arrive (the trial loop calls this every tick)."""
        loop = self.loop
        if loop is None:
            return
        if loop.fault is not None:
            raise HardwareError(loop.fault, reason="hardware_error")
        if self.threaded and not loop.running and self.connected:
            where = "process" if isinstance(loop, PDProcess) else "thread"
            loop.trip(f"CAN bus {self.name}: the PD loop's {where} stopped")
            raise HardwareError(loop.fault or "", reason="hardware_error")
        if isinstance(loop, PDProcess):  # it asks for the hand's health itself
            lost = loop.controller_lost
            if lost is not None:
                raise HardwareError(lost, reason="hardware_error")
            return
        now = self.clock.now()
        if now - self._last_health >= HEALTH_POLL_S:
            self._last_health = now
            self.request_health()

    def request_health(self) -> None:
        """Ask for the hand information (status bits) and the four temperatures; the replies are
        judged by the loop as they arrive."""
        if self._link is None or isinstance(self.loop, PDProcess):  # (the PD process asks itself)
            return
        try:
            for f in health_frames(self.map.device_id):
                self._link.send(f)
        except HardwareError as exc:
            if self.loop is not None:
                self.loop.trip(str(exc))

    def stats(self) -> dict[str, float]:
        return self.loop.stats() if self.loop is not None else {}

    # ---- safe shutdown -------------------------------------------------------------------------------
    def safe_stop(self, action: str | None = None, timeout_s: float = 2.0) -> list[str]:
        """Bring the hand to a safe state; never raises. Returns the problems met."""
        action = action or self.hand.safety.on_fault
        if action not in SAFE_ACTIONS:
            action = "torque_off"
        problems: list[str] = []
        loop = self.loop
        if not self.connected or loop is None:
            return problems
        if loop.fault is not None:
            problems.append(f"{action}: not possible after a fault ({loop.fault}); zero torque")
            self.torque_enabled = False
            return problems
        if action == "hold":
            state = loop.state
            if state is not None:
                self.last_goal = np.clip(state.q, self.lower, self.upper)
                loop.set_goal(self.last_goal, True)
                self.torque_enabled = True
            return problems
        try:
            if action == "open" and self.torque_enabled and self.last_goal is not None and self.threaded:
                self._ramp_to(self.q_open, timeout_s)
        except (Exception, KeyboardInterrupt, SystemExit) as exc:
            problems.append(f"open: {type(exc).__name__}: {exc}")
        self.set_torque(False)
        return problems

    def _ramp_to(self, q_target: np.ndarray, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and self.loop is not None and self.loop.fault is None:
            self.write_goals(q_target)
            if self.last_goal is not None and np.allclose(self.last_goal, np.clip(q_target, self.lower, self.upper)):
                break
            time.sleep(self.hand.dt)
        end = time.monotonic() + min(0.5, max(0.0, deadline - time.monotonic()))
        while time.monotonic() < end and self.loop is not None and self.loop.fault is None:
            state = self.loop.state
            if state is not None and self.last_goal is not None and np.all(np.abs(state.q - self.last_goal) < 0.05):
                break
            time.sleep(self.hand.dt)

    def close(self) -> None:
        """``safety.on_fault``, then zero torque, system off, reports stopped, the bus closed."""
        try:
            if self.connected:
                self.safe_stop()
        finally:
            self._shutdown_link()

    def _shutdown_link(self) -> None:
        self._remove_safety_hooks()
        loop, link = self.loop, self._link
        if loop is not None:
            loop.stop()
        if self.connected and link is not None:
            if not isinstance(loop, PDProcess):  # (the PD process sent them, or it did at its stop)
                send_stop_frames(link, self.map)
            try:
                link.close()
            except Exception:
                pass
        self.connected = False
        self.torque_enabled = False

    def __enter__(self) -> AllegroCANHand:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _install_safety_hooks(self) -> None:
        self._exit_hooks.install(self.handle_signals)

    def _remove_safety_hooks(self) -> None:
        self._exit_hooks.remove()
