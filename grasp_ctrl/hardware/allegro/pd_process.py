"""The Allegro's joint PD loop in its own process, which owns the CAN bus.

A PD thread in the control process shares the interpreter lock with the 100 Hz control tick (and,
in the dry run, the world's physics and the emulators), and its periods stretch whenever they
hold it. Here the loop (pd_loop.py's ``PDLoop``, unchanged) runs in a child process and the
command's process talks to it through shared memory (child.py's ``SharedBlock``), latest value
only, no locks:

- to the loop: the goal (joint angles and torque on/off, under a sequence counter), a heartbeat
  (a thread of the command's process writes the time every 20 ms), a trip request, a stop;
- from the loop: its latest full set of positions, velocities and torques (sequence counter),
  its latched fault, its counters and ring of periods, the hand's temperatures and information.

The child opens the bus itself (python-can from the hand file's ``[torque_pd]``; or one end of a
socket pair: the emulated hand, emulators/allegro_can_process.py), starts the hand (pd_loop's
``start_frames``), waits for a full set of positions, holds the present pose and runs the loop.
Its safety, independent of the command's process:

- every torque it sends is clamped to the hand file's limits (``JointMap.pwm``), and goals are
  clipped to the joint limits;
- a latched fault (stale positions, an error frame, a failed send, over-temperature, the hand's
  fault bits, a trip) leaves only zero-torque frames, as in the thread;
- when the command's process ends (its parent pid changes) or its heartbeat is older than
  ``heartbeat_stale_s``, the child applies the hand file's ``on_fault`` itself: ``torque_off``
  (zero torque), ``hold`` (the present pose, while the command's process lives; zero torque
  once it has gone) or ``open`` (goals stepped toward the open posture at ``max_joint_step_rad``
  per control period, then zero torque); goals from the command are ignored from then on, and
  ``check_health`` there raises it;
- whenever it ends (asked, the command gone, an exception), its last frames are zero torque,
  system off and the reports stopped; if it cannot send them (killed after not answering), the
  command's process sends them (``PDProcess.stop``).

SIGINT and SIGTERM are ignored in the child: they are the command's (a terminal sends Ctrl-C to
the whole process group), which applies ``on_fault`` through the goals and then stops the child
and reaps it.

Out of the interpreter lock, what is left of the loop's jitter is the wait for a core. The child
asks for the realtime scheduling class (``SCHED_FIFO`` at ``RT_PRIORITY``: root, or an ``rtprio``
limit for the user), else a lower nice value, else keeps what it has; the record says which
(``scheduling`` beside the period figures). A period's work is a tenth of a millisecond and the
loop sleeps in between, so it takes little from the rest even at that priority.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from grasp_ctrl.config.hand import TorquePDConfig
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.allegro import protocol as pr
from grasp_ctrl.hardware.allegro.bus import CanLink
from grasp_ctrl.hardware.allegro.child import Child, Layout, SharedBlock, SocketLink, parent_alive, start_child
from grasp_ctrl.hardware.allegro.pd_loop import (
    HEALTH_POLL_S,
    PERIOD_SAMPLES,
    Goal,
    LoopCounters,
    LoopState,
    PDLoop,
    health_frames,
    loop_stats,
    period_figures,
    send_stop_frames,
    start_frames,
)
from grasp_ctrl.hardware.allegro.protocol import JointMap

HEARTBEAT_S = 0.02  # the command's process writes its heartbeat this often
HEARTBEAT_STALE_S = 0.5  # older than this, the child takes over (on_fault)
STARTUP_S = 30.0  # the child's interpreter and imports (a loaded host), besides the hand's answer
STOP_S = 1.0  # the child's own stop (its last frames); it is killed after that
OPEN_RAMP_S = 2.0  # the child's open ramp, as the backend's safe stop
OPEN_TOLERANCE_RAD = 0.05  # the open posture reached
RT_PRIORITY = 50  # SCHED_FIFO, where allowed
NICE = -10  # else this, where allowed
_COUNTERS = tuple(f.name for f in fields(LoopCounters))
_INFO = 5  # hardware and firmware versions, right hand, temperature, status


@dataclass(frozen=True)
class PDSpec:
    """What the child needs (picklable): the loop's parameters, the safe action's, and the bus
    (``bus`` and ``channel``: python-can from the hand file; None: a socket end handed over)."""

    joints: JointMap
    kp: np.ndarray
    kd: np.ndarray
    rate_hz: float
    position_stale_s: float
    max_temperature_c: float
    name: str
    on_fault: str
    q_open: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    max_step_rad: float  # per control period
    control_dt: float
    connect_timeout_s: float
    bus: TorquePDConfig | None = None
    channel: str | None = None
    health_poll_s: float = HEALTH_POLL_S
    heartbeat_stale_s: float = HEARTBEAT_STALE_S


def pd_layout(n_joints: int) -> Layout:
    n = n_joints
    floats = {
        # the command's process writes these
        "goal_seq": 1,
        "goal_q": n,
        "goal_active": 1,
        "heartbeat": 1,
        "stop": 1,
        "trip_req": 1,
        "reset_req": 1,
        # the child writes these
        "state_seq": 1,
        "q": n,
        "dq": n,
        "tau": n,
        "t": 1,
        "sets": 1,
        "fault": 1,
        "fault_t": 1,
        "lost": 1,
        "counters": len(_COUNTERS),
        "n_periods": 1,
        "missed_base": 1,
        "periods": PERIOD_SAMPLES,
        "temps": pr.N_TEMPERATURE_SENSORS,
        "info": _INFO,
        "ready": 1,  # 0 starting, 1 running, -1 failed to start
        "beat": 1,
        "done": 1,  # the last frames went out
    }
    texts = {"trip_text": 512, "fault_text": 1024, "lost_text": 512, "error_text": 1024, "serial": 16, "sched": 32}
    return Layout(floats, texts)


# ---- the child -------------------------------------------------------------------------------------
class _ChildLoop(PDLoop):
    """The PD loop with the shared block around each period (``cycle``)."""

    def __init__(self, link: CanLink, spec: PDSpec, block: SharedBlock, parent_pid: int) -> None:
        super().__init__(
            link,
            spec.joints,
            spec.kp,
            spec.kd,
            spec.rate_hz,
            spec.position_stale_s,
            spec.max_temperature_c,
            clock=time.monotonic,
            name=spec.name,
        )
        self.spec = spec
        self.block = block
        self.parent_pid = parent_pid
        self._periods = block.f["periods"]  # the ring the command's process reads
        self._goal_seq = -1.0
        self._trip_req = block["trip_req"]
        self._reset_req = block["reset_req"]
        self._last_health = -float("inf")
        self._fault_t = 0.0
        self._fault_out = False
        self._state_out: LoopState | None = None
        self._serial_out = False
        self.lost: str | None = None  # why the child took over (the command's process gone or silent)
        self._parent_gone = False
        self._open_t0 = 0.0
        self._open_done = False
        self._open_step = spec.max_step_rad * (1.0 / spec.rate_hz) / spec.control_dt

    def trip(self, reason: str) -> None:
        if self._fault is None:
            self._fault_t = time.monotonic()
        super().trip(reason)

    def start_hand(self) -> None:
        """The hand's start-up, then its present pose (within the limits) held."""
        self.poll(0.0)  # whatever was queued before (the driver flushes too)
        for frame in start_frames(self.joints.device_id, 1.0 / self.period_s):
            self.link.send(frame)
        state = self.wait_for_positions(self.spec.connect_timeout_s, stepped=True)
        self.set_goal(np.clip(state.q, self.spec.lower, self.spec.upper), True)
        self._sync_out()

    def cycle(self, now: float | None = None) -> None:
        self._sync_in()
        super().cycle(now)
        self._sync_out()

    # ---- in ------------------------------------------------------------------------------------
    def _sync_in(self) -> None:
        b = self.block
        now = time.monotonic()
        if b["stop"]:
            self._stop.set()
        if b["trip_req"] != self._trip_req:
            self._trip_req = b["trip_req"]
            self.trip(b.text("trip_text"))
        if b["reset_req"] != self._reset_req:
            self._reset_req = b["reset_req"]
            self._reset_periods = True
        self._watch_controller(now)
        if self.lost is None and b["goal_seq"] != self._goal_seq:
            got = b.read_seq("goal_seq", ("goal_q", "goal_active"))
            if got is not None:
                self._goal_seq = got[0]
                q, active = got[1]
                self.set_goal(np.clip(q, self.spec.lower, self.spec.upper), bool(active[0] > 0.5))
        if now - self._last_health >= self.spec.health_poll_s:
            self._last_health = now
            if self._fault is None:
                self._send(health_frames(self.joints.device_id))

    def _watch_controller(self, now: float) -> None:
        """The command's process gone or silent: ``on_fault`` from here (once), then its course."""
        spec = self.spec
        alive = parent_alive(self.parent_pid)
        if self.lost is None:
            age = now - self.block["heartbeat"]
            if alive and age <= spec.heartbeat_stale_s:
                return
            why = "ended" if not alive else f"gave no heartbeat for {age:.2f} s"
            self.lost = (
                f"CAN bus {self.name}: the control process {why}; the PD process applied on_fault = {spec.on_fault!r}"
            )
            self.block.set_text("lost_text", self.lost)
            self.block["lost"] = 1.0
            self._open_t0 = now
            state = self._state
            if spec.on_fault == "hold" and state is not None and self._goal.active:
                self.set_goal(np.clip(state.q, spec.lower, spec.upper), True)
            elif spec.on_fault != "open":
                self.set_goal(self._goal.q_rad, False)
        if not alive and not self._parent_gone:
            self._parent_gone = True
            if spec.on_fault == "hold":  # holding needs the program: limp once it has gone
                self.set_goal(self._goal.q_rad, False)
        if spec.on_fault == "open" and not self._open_done:
            self._step_open(now)
        finished = spec.on_fault != "open" or self._open_done or self._fault is not None
        if self._parent_gone and finished:
            self._stop.set()

    def _step_open(self, now: float) -> None:
        spec = self.spec
        goal = self._goal
        target = np.clip(spec.q_open, spec.lower, spec.upper)
        q = goal.q_rad + np.clip(target - goal.q_rad, -self._open_step, self._open_step)
        q = np.clip(q, spec.lower, spec.upper)
        state = self._state
        reached = np.allclose(q, target) and state is not None and np.all(np.abs(state.q - target) < OPEN_TOLERANCE_RAD)
        if reached or now - self._open_t0 > OPEN_RAMP_S or not goal.active:
            self._open_done = True
            self.set_goal(q, False)
        else:
            self.set_goal(q, True)

    # ---- out -----------------------------------------------------------------------------------
    def _sync_out(self) -> None:
        b = self.block
        state = self._state
        if state is not None and state is not self._state_out:
            self._state_out = state
            b.write_seq(
                "state_seq", {"q": state.q, "dq": state.dq, "tau": state.tau_nm, "t": state.t, "sets": state.sets}
            )
        if self._fault is not None and not self._fault_out:
            self._fault_out = True
            b.set_text("fault_text", self._fault)
            b["fault_t"] = self._fault_t
            b["fault"] = 1.0
        c = self.counters
        b.f["counters"][:] = [getattr(c, k) for k in _COUNTERS]
        b["n_periods"] = self._n_periods
        b["missed_base"] = self._missed_base
        for sensor, celsius in self.temperatures_c.items():
            b.f["temps"][sensor] = celsius
        info = self.hand_info
        if info is not None:
            b.f["info"][:] = [
                info.hardware_version,
                info.firmware_version,
                info.right_hand,
                info.temperature_c,
                info.status,
            ]
        if self.serial is not None and not self._serial_out:
            self._serial_out = True
            b.set_text("serial", self.serial)
        b["beat"] = time.monotonic()

    def finish(self) -> None:
        """The last frames (zero torque, system off, reports stopped), each tried."""
        send_stop_frames(self.link, self.joints)
        self.block["done"] = 1.0


def raise_priority() -> str:
    """This process on the realtime scheduling class where allowed, else niced down where
    allowed; what it got, in words."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(RT_PRIORITY))
        return f"SCHED_FIFO {RT_PRIORITY}"
    except (AttributeError, OSError):
        pass
    try:
        os.setpriority(os.PRIO_PROCESS, 0, NICE)
        return f"nice {NICE}"
    except (AttributeError, OSError):
        return f"nice {os.getpriority(os.PRIO_PROCESS, 0)}" if hasattr(os, "getpriority") else "as started"


def _open_link(spec: PDSpec, link_fd: int | None) -> CanLink:
    if link_fd is not None:
        return SocketLink.from_fd(link_fd, spec.name)
    from grasp_ctrl.hardware.allegro.bus import open_link

    assert spec.bus is not None
    return open_link(spec.bus, spec.channel)


def child_main(payload: tuple[PDSpec, int, int | None, int]) -> None:
    """The child's whole life: open the bus, start the hand, run the loop until asked to stop
    (or the command's process has gone), then the last frames."""
    spec, block_fd, link_fd, parent_pid = payload
    block = SharedBlock(pd_layout(len(spec.joints.finger)), fd=block_fd)
    loop: _ChildLoop | None = None
    code = 1
    try:
        block.set_text("sched", raise_priority())
        loop = _ChildLoop(_open_link(spec, link_fd), spec, block, parent_pid)
        loop.start_hand()
        block["ready"] = 1.0
        loop._run()
        code = 0
    except BaseException as exc:
        text = (
            str(exc)
            if isinstance(exc, HardwareError)
            else f"CAN bus {spec.name}: PD process: {type(exc).__name__}: {exc}"
        )
        block.set_text("error_text", text)
        if block["ready"] == 0.0:
            block["ready"] = -1.0
    finally:
        if loop is not None:
            loop.finish()
            try:
                loop.link.close()
            except Exception:
                pass
    os._exit(code)  # no interpreter teardown: nothing of the command's is run or flushed here


# ---- the command's side -------------------------------------------------------------------------------
class PDProcess:
    """The loop in its child process, with ``PDLoop``'s interface for the backend (hand.py):
    ``set_goal``, ``state`` (stamped on ``clock``), ``fault``, ``trip``, ``running``, the figures.
    ``link``: a socket end for the child (kept here too, for the last frames if the child cannot);
    None: the child opens ``spec.bus``."""

    def __init__(self, spec: PDSpec, clock: Callable[[], float], link: SocketLink | None = None) -> None:
        self.spec = spec
        self.clock = clock
        self.name = spec.name
        self.joints = spec.joints
        self.period_s = 1.0 / spec.rate_hz
        self.link = link
        n = len(spec.joints.finger)
        self.block: SharedBlock | None = None
        self.child: Child | None = None
        self._goal = Goal(np.zeros(n), False)
        self._local_fault: str | None = None
        self._state: LoopState | None = None
        self._state_seq = -1.0
        self._beat_stop = threading.Event()
        self._beat: threading.Thread | None = None

    # ---- lifecycle -----------------------------------------------------------------------------
    def start(self) -> None:
        """Start the child and wait until it holds the hand's present pose; a one-line
        ``HardwareError`` (the child's own words) otherwise, with the child reaped."""
        block = SharedBlock(pd_layout(len(self.joints.finger)))
        block.f["periods"][:] = np.nan
        block.f["temps"][:] = np.nan
        block["heartbeat"] = time.monotonic()
        self.block = block
        fds = [block.fd] + ([self.link.fileno()] if self.link is not None else [])
        payload = (self.spec, block.fd, self.link.fileno() if self.link is not None else None, os.getpid())
        self._beat_stop.clear()
        self._beat = threading.Thread(target=self._heartbeat, name=f"allegro-pd-heartbeat-{self.name}", daemon=True)
        self._beat.start()
        try:
            self.child = start_child(
                f"{__name__}:child_main", payload, fds, name=f"CAN bus {self.name}: the PD process"
            )
            block.release_fd()  # the child has its own; the mapping stays
            if self.child.wait_ready(block, STARTUP_S + self.spec.connect_timeout_s) != 1.0:
                text = block.text("error_text")
                if not text:
                    code = self.child.returncode
                    text = f"CAN bus {self.name}: the PD process " + (
                        f"ended (exit status {code})" if code is not None else "did not start in time"
                    )
                raise HardwareError(text)
        except BaseException:
            self.stop()
            raise
        self._read_state()

    def _heartbeat(self) -> None:
        while not self._beat_stop.wait(HEARTBEAT_S):
            block = self.block
            if block is not None:
                block["heartbeat"] = time.monotonic()

    def stop(self, timeout_s: float = STOP_S) -> None:
        """Ask the child to stop (its last frames: zero torque, system off), reap it (killed
        after ``timeout_s``); the last frames from here if it did not send them."""
        block, child = self.block, self.child
        self.child = None
        done = True
        if block is not None:
            block["stop"] = 1.0
            block.release_fd()
        if child is not None:
            child.stop(timeout_s)
            done = block is not None and block["done"] == 1.0
        self._beat_stop.set()
        beat, self._beat = self._beat, None
        if beat is not None:
            beat.join(1.0)
        if not done:
            self._last_frames_from_here()

    def _last_frames_from_here(self) -> None:
        link: CanLink | None = self.link
        opened = False
        try:
            if link is None and self.spec.bus is not None:
                from grasp_ctrl.hardware.allegro.bus import open_link

                link, opened = open_link(self.spec.bus, self.spec.channel), True
            if link is None:
                return
            send_stop_frames(link, self.joints)
        except HardwareError:
            pass
        finally:
            if opened and link is not None:
                link.close()

    @property
    def running(self) -> bool:
        b = self.block
        return self.child is not None and self.child.alive and b is not None and b["ready"] == 1.0 and not b["done"]

    # ---- goal and state --------------------------------------------------------------------------
    def set_goal(self, q_rad: np.ndarray, active: bool = True) -> None:
        goal = np.array(q_rad, dtype=float)
        goal.flags.writeable = False
        self._goal = Goal(goal, bool(active))
        if self.block is not None:
            self.block.write_seq("goal_seq", {"goal_q": goal, "goal_active": 1.0 if active else 0.0})

    @property
    def goal(self) -> Goal:
        return self._goal

    def _read_state(self) -> LoopState | None:
        b = self.block
        if b is None or b["state_seq"] == self._state_seq:
            return self._state
        got = b.read_seq("state_seq", ("q", "dq", "tau", "t", "sets"))
        if got is None:
            return self._state
        seq, (q, dq, tau, t, sets) = got
        if sets[0] < 1:
            return None
        for a in (q, dq, tau):
            a.flags.writeable = False
        # the child stamps with the monotonic clock; the owner's clock (a trial's) stamps here
        stamp = self.clock() - (time.monotonic() - float(t[0]))
        self._state, self._state_seq = LoopState(q, dq, tau, stamp, int(sets[0])), seq
        return self._state

    @property
    def state(self) -> LoopState | None:
        return self._read_state()

    # ---- faults ---------------------------------------------------------------------------------
    @property
    def fault(self) -> str | None:
        b = self.block
        if b is not None and b["fault"]:
            return b.text("fault_text")
        return self._local_fault

    @property
    def fault_time(self) -> float | None:
        """When the child latched its fault (``time.monotonic``), or None."""
        b = self.block
        return b["fault_t"] if b is not None and b["fault"] else None

    def trip(self, reason: str) -> None:
        """Latch a fault in the child: only zero torque from its next period on."""
        if self._local_fault is None:
            self._local_fault = reason
        b = self.block
        if b is not None:
            b.set_text("trip_text", reason)
            b["trip_req"] = b["trip_req"] + 1.0

    @property
    def controller_lost(self) -> str | None:
        """Why the child took over (on_fault), if it did."""
        b = self.block
        return b.text("lost_text") if b is not None and b["lost"] else None

    # ---- figures --------------------------------------------------------------------------------
    @property
    def counters(self) -> LoopCounters:
        if self.block is None:
            return LoopCounters()
        values = self.block.f["counters"]
        return LoopCounters(**{k: int(v) for k, v in zip(_COUNTERS, values)})

    def reset_periods(self) -> None:
        if self.block is not None:
            self.block["reset_req"] = self.block["reset_req"] + 1.0

    def _ring(self) -> tuple[np.ndarray, int, int]:
        b = self.block
        if b is None:
            return np.zeros(0), 0, 0
        return b.f["periods"].copy(), int(b["n_periods"]), int(b["missed_base"])

    def period_figures(self) -> dict[str, Any]:
        periods, n, missed_base = self._ring()
        out = period_figures(periods, n, self.counters.missed_periods - missed_base, self.period_s)
        out["scheduling"] = self.scheduling
        return out

    @property
    def scheduling(self) -> str:
        """The PD process's scheduling class and priority, in words (``raise_priority``)."""
        return self.block.text("sched") if self.block is not None else ""

    def stats(self) -> dict[str, float]:
        periods, n, _ = self._ring()
        return loop_stats(self.counters, periods, n, self.period_s)

    @property
    def temperatures_c(self) -> dict[int, int]:
        if self.block is None:
            return {}
        return {i: int(c) for i, c in enumerate(self.block.f["temps"]) if np.isfinite(c)}

    @property
    def hand_info(self) -> pr.HandInfo | None:
        if self.block is None or not self.block.f["info"][0]:
            return None
        hw, fw, right, temp, status = (int(v) for v in self.block.f["info"])
        return pr.HandInfo(hw, fw, bool(right), temp, status)

    @property
    def serial(self) -> str | None:
        return (self.block.text("serial") or None) if self.block is not None else None
