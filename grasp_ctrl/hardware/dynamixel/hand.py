"""``DynamixelHand``: the HandBackend for a chain of X-series servos.

Per control tick: one sync read of current, velocity and position for all
servos (``read``) and one sync write of goal positions (``write_goals``). Goals
are clamped to the joint limits and to ``safety.max_joint_step_rad`` from the
previous goal before they are converted to counts, and the servos' own
position-limit registers hold the same limits, so no goal outside the limits
is ever sent (and the firmware would refuse one).

Safety: use it as a context manager (or call ``close``): on normal exit, an
exception, Ctrl-C (SIGINT) or SIGTERM the hand performs ``safety.on_fault``:
``hold`` (keep torque, hold the present position), ``open`` (move to the open
posture within the step limit, then torque off) or ``torque_off``.
"""

from __future__ import annotations

import time

import numpy as np

from grasp_ctrl.config.hand import SAFE_ACTIONS, HandConfig
from grasp_ctrl.errors import HardwareError, UsageError
from grasp_ctrl.hardware.base import Clock, JointState
from grasp_ctrl.hardware.dynamixel import control_table as ct
from grasp_ctrl.hardware.dynamixel.bus import DynamixelBus
from grasp_ctrl.hardware.dynamixel.calibration import Calibration
from grasp_ctrl.hardware.dynamixel.port import set_low_latency
from grasp_ctrl.hardware.dynamixel.setup import configure_servos
from grasp_ctrl.hardware.exit_hooks import ExitHooks
from grasp_ctrl.numeric.limits import limited_goal


class MonotonicClock:
    def now(self) -> float:
        return time.monotonic()


class DynamixelHand:
    """HandBackend over dynamixel_sdk. Joint vectors follow ``hand.joints`` order."""

    def __init__(
        self,
        hand: HandConfig,
        port: str | None = None,
        clock: Clock | None = None,
        *,
        handle_signals: bool = True,
        health_poll_s: float = 0.1,
    ) -> None:
        self.hand = hand
        self.cfg = hand.dynamixel
        self.port_name = port or self.cfg.port
        self.clock: Clock = clock or MonotonicClock()
        self.joints = hand.joints
        self.ids = [j.servo_id for j in self.joints]
        self.names = {j.servo_id: j.name for j in self.joints}
        self.cal = Calibration.from_joints(self.joints)
        self.lower = self.cal.lower_rad
        self.upper = self.cal.upper_rad
        self.q_open = np.array([j.open_rad for j in self.joints])
        self.model = self.cfg.servo  # config/servos.py, or the hand file's [servo_models.NAME]
        self.amp_per_unit = self.model.amp_per_current_unit if self.model else 0.001
        self.bus = DynamixelBus(
            self.port_name,
            self.cfg.baud,
            self.names,
            packet_timeout_ms=self.cfg.packet_timeout_ms,
            retries=self.cfg.retries,
            fast_sync_read=self.cfg.fast_sync_read,
            drain_s=self.cfg.latency_timer_ms / 1000.0,
        )
        self.handle_signals = handle_signals
        self.health_poll_s = health_poll_s
        self._last_health_poll = -float("inf")
        self.latency_status = ""
        self.connected = False
        self.torque_enabled = False
        self.last_goal: np.ndarray | None = None
        self.last_state: JointState | None = None
        self.faults: dict[int, int] = {}  # id -> hardware error bits seen by check_health
        self._exit_hooks = ExitHooks(self.close)  # the safe stop at exit and on SIGTERM

    # ---- lifecycle -------------------------------------------------------------
    def connect(self) -> None:
        """Open, ping every servo, configure with torque off, hold the present pose."""
        self.bus.open()
        self.connected = True
        try:
            self.latency_status = set_low_latency(self.port_name, self.cfg.latency_timer_ms)
            self.check_servos()
            self._choose_sync_read()
            errors = self.read_hardware_errors()
            if errors:
                raise HardwareError(
                    f"servos report hardware errors before start: {self._describe(errors)}; "
                    "power-cycle or run `hand-check --recover` (reboots them)"
                )
            self.configure()
            state = self.read()
            self.last_goal = np.clip(state.q, self.lower, self.upper)
            self._send_goal_counts(self.cal.to_counts(self.last_goal))
            self.set_torque(True)
        except BaseException:
            self.close_port_only()
            raise
        self._install_safety_hooks()

    def check_servos(self) -> dict[int, int]:
        """Ping every configured id; raise naming missing servos and model mismatches."""
        missing, mismatched, models = [], [], {}
        for j in self.joints:
            model, why = self.bus.ping(j.servo_id)
            if model is None:
                missing.append(f"{j.name} (id {j.servo_id})")
                continue
            models[j.servo_id] = model
            if self.model is not None and model != self.model.model_number:
                got = ct.model_by_number(model)
                mismatched.append(
                    f"{j.name} (id {j.servo_id}) is {got.name if got else f'model {model}'}, expected {self.model.name}"
                )
        problems = []
        if missing:
            problems.append("no reply from " + ", ".join(missing))
        if mismatched:
            problems.append("model mismatch: " + "; ".join(mismatched) + " (fix [dynamixel] model or the servos)")
        if problems:
            raise HardwareError(f"Dynamixel bus {self.port_name}: " + "; ".join(problems))
        return models

    def configure(self) -> None:
        """EEPROM settings need torque off; done servo by servo, each write checked."""
        configure_servos(self.bus, self.joints, self.model, self.cfg)
        self.torque_enabled = False

    def _choose_sync_read(self) -> None:
        """Fast Sync Read needs recent firmware; fall back to Sync Read if the servos ignore it."""
        if not self.bus.fast_sync_read:
            return
        retries, self.bus.retries = self.bus.retries, 0
        try:
            self.bus.sync_read(self.ids, ct.STATE_START, ct.STATE_LENGTH)
        except HardwareError:
            self.bus.fast_sync_read = False
        finally:
            self.bus.retries = retries

    # ---- per tick ----------------------------------------------------------------
    def read(self) -> JointState:
        res = self.bus.sync_read(self.ids, ct.STATE_START, ct.STATE_LENGTH)
        raw = b"".join(res.data[i] for i in self.ids)
        rec = np.frombuffer(raw, dtype=np.dtype([("cur", "<i2"), ("vel", "<i4"), ("pos", "<i4")]))
        state = JointState(
            q=self.cal.to_rad(rec["pos"]),
            dq=self.cal.velocity_to_rad_s(rec["vel"]),
            current_a=self.cal.sign * rec["cur"].astype(float) * self.amp_per_unit,
            t=self.clock.now(),
        )
        self.last_state = state
        return state

    def clamp_goal(self, q_goal: np.ndarray) -> np.ndarray:
        """Limit the step from the previous goal, then clamp to the joint limits."""
        q = np.asarray(q_goal, dtype=float)
        if q.shape != self.lower.shape or not np.all(np.isfinite(q)):
            raise UsageError(f"write_goals: expected {self.lower.size} finite joint angles, got shape {q.shape}")
        return limited_goal(q, self.last_goal, self.hand.safety.max_joint_step_rad, self.lower, self.upper)

    def write_goals(self, q_goal: np.ndarray) -> None:
        q = self.clamp_goal(q_goal)
        self._send_goal_counts(self.cal.to_counts(q))
        self.last_goal = q

    def _send_goal_counts(self, counts: np.ndarray) -> None:
        self.bus.sync_write(ct.ADDR_GOAL_POSITION, 4, {i: int(c) for i, c in zip(self.ids, counts)})

    def set_torque(self, enabled: bool) -> None:
        if enabled and self.last_goal is None:
            raise HardwareError("set_torque(True) before connect(): no goal to hold")
        failures = []
        for i in self.ids:
            if enabled and i in self.faults:
                continue  # a faulted servo refuses torque until rebooted
            try:
                self.bus.write(i, ct.ADDR_TORQUE_ENABLE, 1, 1 if enabled else 0)
            except HardwareError as exc:
                failures.append(str(exc))
        self.torque_enabled = enabled
        if failures:
            raise HardwareError("torque " + ("on" if enabled else "off") + " failed: " + "; ".join(failures))

    # ---- health ----------------------------------------------------------------------
    def read_hardware_errors(self) -> dict[int, int]:
        res = self.bus.sync_read(self.ids, ct.ADDR_HARDWARE_ERROR_STATUS, 1)
        return {i: res.data[i][0] for i in self.ids if res.data[i][0]}

    def check_health(self, force: bool = False) -> None:
        """Poll Hardware Error Status explicitly (sync reads only carry the alert bit).

        Every status packet of the per-tick read carries the alert bit, so the
        register is polled at once when a read saw it, and otherwise every
        ``health_poll_s`` (clock time) or when ``force`` is set."""
        now = self.clock.now()
        if not (force or self.bus.alert_seen or now - self._last_health_poll >= self.health_poll_s):
            return
        self._last_health_poll = now
        self.bus.alert_seen = False
        errors = self.read_hardware_errors()
        self.faults = errors
        if errors:
            raise HardwareError(f"hardware error: {self._describe(errors)}", reason="hardware_error")

    def _describe(self, errors: dict[int, int]) -> str:
        """Port, servo (joint name and id) and the Hardware Error Status bits, by name and value."""
        return f"bus {self.port_name}: " + "; ".join(
            f"{self.bus.label(i)}: {', '.join(ct.hardware_error_names(bits))} (status 0x{bits:02x})"
            for i, bits in sorted(errors.items())
        )

    def recover(self) -> None:
        """Documented recovery: reboot the faulted servos (clears the error, torque off,
        RAM defaults), re-apply the configuration, hold the present pose, torque on."""
        errors = self.read_hardware_errors()
        for i in errors:
            self.bus.reboot(i)
        if errors:
            time.sleep(0.5)  # the servos need a moment to come back
        self.faults = {}
        self.set_torque(False)
        self.configure()
        state = self.read()
        self.last_goal = np.clip(state.q, self.lower, self.upper)
        self._send_goal_counts(self.cal.to_counts(self.last_goal))
        self.set_torque(True)

    # ---- safe shutdown ---------------------------------------------------------------
    def safe_stop(self, action: str | None = None, timeout_s: float = 2.0) -> list[str]:
        """Bring the hand to a safe state; never raises. Returns the problems met."""
        action = action or self.hand.safety.on_fault
        if action not in SAFE_ACTIONS:
            action = "torque_off"
        problems: list[str] = []
        if not self.connected:
            return problems
        self.bus.unjam()
        if action == "hold":
            # Servos keep holding their last goal even if this refresh fails.
            try:
                state = self.read()
                self.last_goal = np.clip(state.q, self.lower, self.upper)
                self._send_goal_counts(self.cal.to_counts(self.last_goal))
            except Exception as exc:
                problems.append(f"hold: {exc}")
            return problems
        try:
            if action == "open" and self.torque_enabled and self.last_goal is not None:
                self._ramp_to(self.q_open, timeout_s)
        except (Exception, KeyboardInterrupt, SystemExit) as exc:
            # whatever happened (a second Ctrl-C included), still turn the torque off
            problems.append(f"open: {type(exc).__name__}: {exc}")
        self.bus.unjam()
        try:
            self.set_torque(False)
        except HardwareError as exc:
            problems.append(str(exc))
        return problems

    def _ramp_to(self, q_target: np.ndarray, timeout_s: float) -> None:
        assert self.last_goal is not None  # the caller ramps only from a goal already sent
        healthy = np.array([i not in self.faults for i in self.ids])
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            goal = np.where(healthy, q_target, self.last_goal)
            self.write_goals(goal)
            if np.allclose(self.last_goal, goal, atol=1e-9):
                break
            time.sleep(self.hand.dt)
        # give the servos a moment to reach the last goal before torque goes off
        end = time.monotonic() + min(0.5, max(0.0, deadline - time.monotonic()))
        while time.monotonic() < end:
            state = self.read()
            if np.all(np.abs(state.q - self.last_goal)[healthy] < 0.05):
                break
            time.sleep(self.hand.dt)

    def close(self) -> None:
        """Safe shutdown (``safety.on_fault``), then release the port."""
        if self.connected:
            self.safe_stop()
        self.close_port_only()

    def close_port_only(self) -> None:
        self._remove_safety_hooks()
        if self.connected:
            self.bus.unjam()
            self.bus.close()
        self.connected = False

    def __enter__(self) -> DynamixelHand:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _install_safety_hooks(self) -> None:
        self._exit_hooks.install(self.handle_signals)

    def _remove_safety_hooks(self) -> None:
        self._exit_hooks.remove()
