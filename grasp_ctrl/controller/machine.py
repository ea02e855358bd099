"""The lift-and-place state machine (paper section V), built with ``transitions``.

Ticked once per control cycle with a Snapshot. Guards are pure functions of
the snapshot, the object profile and tick counters (time-outs are counted in
ticks, no timer threads), so tests can drive it tick by tick.

    tare -> reach -> close -> ramp -> lift -> hold -> lower -> release -> retreat -> done
    any state -> fault (reason), then the configured safe action
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from transitions import Machine

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.controller.grip_targets import GRIP_TARGET_MODES, grip_targets
from grasp_ctrl.controller.motion import FingertipMotion
from grasp_ctrl.controller.paper_settings import RAMP_MODES, PaperSettings
from grasp_ctrl.controller.ramp_settle import RampSettle
from grasp_ctrl.controller.snapshot import Command, Snapshot
from grasp_ctrl.errors import ConfigError
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR
from grasp_ctrl.kinematics.pad_ik import Facing
from grasp_ctrl.kinematics.preshape import preshape
from grasp_ctrl.numeric.finite import all_finite
from grasp_ctrl.numeric.solve_cache import stored
from grasp_ctrl.numeric.vec3 import norm3

STATES = ["tare", "reach", "close", "ramp", "lift", "hold", "lower", "release", "retreat", "done", "fault"]
ACTIVE = STATES[:-2]
TERMINAL = ("done", "fault")
#: ``_force_checks``' result bits.
FORCE_NOT_FINITE = 4  # an estimated |f_sensor|^2 is not finite
OVERFORCE = 8  # the largest |f_sensor| is above the limit (all finite)

# (source, dest, guard, reason-if-fault); checked in order on every tick.
TRANSITIONS: list[tuple[str, str, str, str | None]] = [
    ("tare", "reach", "tare_done", None),
    ("reach", "close", "at_reach_pose", None),
    ("reach", "fault", "reach_timed_out", "reach_timeout"),
    ("close", "ramp", "all_in_contact", None),
    ("close", "fault", "close_timed_out", "no_contact"),
    ("ramp", "lift", "ramp_settled", None),
    ("ramp", "fault", "ramp_timed_out", "ramp_timeout"),
    ("lift", "fault", "grip_lost", "slipped"),
    ("lift", "hold", "at_lift_height", None),
    ("hold", "fault", "grip_lost", "slipped"),
    ("hold", "lower", "hold_done", None),
    ("lower", "release", "release_detected", None),
    ("lower", "fault", "grip_lost", "slipped"),
    ("lower", "fault", "lower_exhausted", "no_release"),
    ("release", "retreat", "fingers_open", None),
    ("retreat", "done", "retreat_done", None),
]


def build_machine(
    model: Any,
    reason_setter: Any = None,
    machine_cls: type = Machine,
    states: list[str] | None = None,
    transitions: list[tuple[str, str, str, str | None]] | None = None,
    **extra: Any,
) -> Machine:
    """The one definition of states and transitions (also drawn by ``diagram``); ``states`` and
    ``transitions``: a controller's own (default: the paper's, ``STATES`` and ``TRANSITIONS``)."""
    states = states or STATES
    transitions = transitions or TRANSITIONS
    active = [s for s in states if s not in TERMINAL]
    machine = machine_cls(
        model=model,
        states=states,
        initial="tare",
        auto_transitions=False,
        queued=True,
        after_state_change="_on_enter" if reason_setter else None,
        **extra,
    )
    for src, dst, guard, reason in transitions:
        kwargs: dict[str, Any] = {"conditions": guard}
        if reason and reason_setter:
            kwargs["before"] = reason_setter(reason)
        machine.add_transition("step", src, dst, **kwargs)
    # Faults detected outside the guards (stale sensor, hardware, over-force, abort).
    machine.add_transition("fail", active, "fault", before="_set_reason" if reason_setter else None)
    return machine


@functools.lru_cache(maxsize=32)
@stored()
def _raised_reach_posture(hand: HandConfig, finger: str, raise_m: float) -> np.ndarray:
    motion = FingertipMotion(hand, HandKinematics(hand))
    return motion.raised_posture(motion.pregrasp_q, {finger: raise_m})


def raised_reach_posture(hand: HandConfig, finger: str, raise_m: float) -> np.ndarray:
    """The pregrasp posture with ``finger``'s pad raised by ``raise_m`` (FingertipMotion.
    raised_posture). A least-squares fit of tens of milliseconds, as long as a third of
    a trial, so it is fitted once per hand, finger and height (a ValueError is not kept)."""
    return _raised_reach_posture(hand, finger, raise_m).copy()


class GraspController:
    """The model of the state machine. ``tick(snapshot) -> Command``."""

    #: The current state's name; set by the ``transitions`` machine (``build_machine``).
    state: str
    #: This controller's states and transitions (a subclass may add its own).
    STATES: list[str] = STATES
    TRANSITIONS: list[tuple[str, str, str, str | None]] = TRANSITIONS
    #: Whether the tick gives it each fingertip's PAC spread (``Snapshot.pac_spread``).
    reads_vibration = False
    #: Its settings class (controller/registry.py: the settings of a run of it).
    SETTINGS: ClassVar[type[PaperSettings]] = PaperSettings
    s: PaperSettings

    if TYPE_CHECKING:
        # The triggers ``build_machine`` adds to the model; defined here they would stop
        # transitions from binding its own (it skips names the model already has).
        def step(self) -> bool: ...

        def fail(self, *, reason: str, detail: str | None = None) -> bool: ...

    def __init__(
        self,
        hand: HandConfig,
        obj: ObjectProfile,
        reach_pose_world: np.ndarray,
        settings: PaperSettings | None = None,
        kin: HandKinematics | None = None,
    ) -> None:
        self.hand = hand
        self.obj = obj
        self.s = settings or self.SETTINGS()
        if not isinstance(self.s, self.SETTINGS):
            raise TypeError(f"{type(self).__name__} takes {self.SETTINGS.__name__}, not {type(self.s).__name__}")
        self.dt = hand.dt
        self.kin = kin or HandKinematics(hand)
        self.motion = FingertipMotion(hand, self.kin, self.s.stiffness_aware_squeeze)
        self.names = [f.name for f in hand.fingers]
        self.grasp_mask = np.array([f.grasp for f in hand.fingers])
        # Per-finger arithmetic on a handful of fingers runs on Python lists: a numpy
        # call costs more than the whole loop at this size.
        self._grasping = [bool(g) for g in self.grasp_mask]
        # Each fingertip's grip target (controller/grip_targets.py); all tau by default.
        # An object's profile may choose its own mode (a heavy box: force_closure, objects.toml).
        if self.s.grip_targets not in GRIP_TARGET_MODES:
            raise ConfigError(
                "controller settings",
                "grip_targets",
                f"one of {', '.join(GRIP_TARGET_MODES)} (got {self.s.grip_targets!r})",
            )
        mode = obj.grip_targets or self.s.grip_targets
        self.grip_targets = grip_targets(
            self.motion.task_vectors, self.grasp_mask, obj.tau_n, mode, obj.mass_kg, obj.mu, self.s.grip_weight_margin
        )
        if self.s.ramp_mode not in RAMP_MODES:
            raise ConfigError(
                "controller settings", "ramp_mode", f"one of {', '.join(RAMP_MODES)} (got {self.s.ramp_mode!r})"
            )
        # The ramp pushes each pad forward until every pad has reached its target, then the
        # fingers hold their goals (paper_settings.RAMP_MODES); else every pad is regulated throughout.
        self.push_then_hold = self.s.ramp_mode == "push_then_hold"
        self._reached_ticks = 0  # push_then_hold: ramp ticks every pad has been at its target
        self.release_idx = self.names.index(hand.grasp.release_finger)
        self.reach_pose = np.asarray(reach_pose_world, dtype=float)
        self.reach_q = self._reach_posture()
        self.lift_top = self.reach_pose + np.array([0.0, 0.0, obj.lift_height_m])
        self.lower_limit_z = self.reach_pose[2] - self.s.lower_overshoot_m
        self.lower_bottom = self.reach_pose.copy()  # where lowering stops at the latest
        self.lower_bottom[2] = self.lower_limit_z
        self.palm_target: np.ndarray | None = None
        self._retreat_goal: np.ndarray | None = None
        self.torque_on = True
        self.failure_reason: str | None = None
        self.failure_detail: str | None = None  # what failed, for the record
        self.ticks_in_state = 0
        self.release_count = 0
        self.ramp_settle = RampSettle(self.s, self.dt)
        self.lost_count = [0] * len(self.names)  # ticks each fingertip has seemed to slip (finger order)
        self.snap: Snapshot | None = None
        self._force_sq_of: tuple[Snapshot | None, list[float]] = (None, [])  # (snapshot, _force_sq of it)
        self.history: list[tuple[float, str, str]] = []  # (t, from, to)

        self.machine = build_machine(self, self._reason_setter, states=self.STATES, transitions=self.TRANSITIONS)
        # The guards of each state's transitions: the machine is triggered only when one
        # holds (guards are pure, so this skips its overhead on the ticks nothing happens).
        self._guards = {
            state: [getattr(self, g) for src, _, g, _ in self.TRANSITIONS if src == state] for state in self.STATES
        }

    # ----- helpers ----------------------------------------------------------
    def _reach_posture(self) -> np.ndarray:
        """The pregrasp posture, or with ``settings.preshape`` the object's preshape
        (pads facing the object where closing along the task vectors meets it:
        kinematics/preshape.py); with a capped object, its cap finger's pad raised to the cap's
        contact height (the others close at ``grasp_height_m``); then the object's
        ``posture_offsets_rad`` added, clamped to the joint limits."""
        q = self.motion.pregrasp_q.copy()
        if self.s.preshape:
            shape = preshape(self.hand, self.obj, self._preshape_standoff_m())
            q = shape.q
            facing = np.array([n is not None for n in shape.pad_normals_hand])
            normals = np.array([n if n is not None else np.zeros(3) for n in shape.pad_normals_hand])
            self.motion.facing = Facing(facing, normals) if facing.any() else None
        cap = self.obj.cap
        if cap is None:
            return self._offset_posture(q)
        where = f"object {self.obj.name!r}"
        if cap.finger not in self.names or not self.grasp_mask[self.names.index(cap.finger)]:
            raise ConfigError(where, "cap.finger", f"a grasping finger of hand {self.hand.name!r} (got {cap.finger!r})")
        try:
            raised = raised_reach_posture(self.hand, cap.finger, cap.contact_height_m - self.obj.grasp_height_m)
        except ValueError as exc:
            raise ConfigError(where, "cap.contact_height_m", f"a height the finger can reach ({exc})") from None
        cap_joints = self.kin.slices[cap.finger]
        q[cap_joints] = raised[cap_joints]
        return self._offset_posture(q)

    def _offset_posture(self, q: np.ndarray) -> np.ndarray:
        """``q`` with the object's per-finger joint offsets added, clamped to the joint limits; a
        finger that keeps its pad facing while it closes keeps the facing of the offset posture."""
        offsets = self.obj.posture_offsets()
        if not offsets:
            return q
        for finger, values in offsets.items():
            sl = self.kin.slices.get(finger)
            if sl is None or len(values) != sl.stop - sl.start:
                raise ConfigError(
                    f"object {self.obj.name!r}",
                    f"posture_offsets_rad.{finger}",
                    f"one offset per joint of a finger of hand {self.hand.name!r}",
                )
            chain = self.kin.chains[finger]
            q[sl] = np.clip(q[sl] + np.asarray(values, dtype=float), chain.lower, chain.upper)
            facing = self.motion.facing
            i = self.names.index(finger)
            if facing is not None and facing.fingers[i]:
                rot, _ = chain.fk_rp(q[sl])
                facing.normals_hand[i] = rot @ PAD_NORMAL_SENSOR
        return q

    def _preshape_standoff_m(self) -> float:
        """How far from the object's nominal surface the pads wait before closing: the object's
        ``standoff_m``, else the controller's setting."""
        return self.obj.standoff_m if self.obj.standoff_m is not None else self.s.preshape_standoff_m

    @classmethod
    def guard_words(cls, s: PaperSettings) -> dict[str, str]:
        """Each guard's condition in words, with the settings' numbers (object parameters by name:
        they live in the object profile), for ``diagram``; a guard without words here is
        described by its docstring's first line."""
        if s.ramp_mode == "push_then_hold":
            settled = f"every grip at tau or above (within {s.ramp_tolerance_n:g} N) for {s.ramp_settle_s:g} s"
        else:
            settled = (
                f"grips averaged over {s.ramp_filter_s:g} s: every grip within {s.ramp_tolerance_n:g} N of tau "
                f"for {s.ramp_settle_s:g} s, or "
                f"balanced: mean within {s.ramp_tolerance_n:g} N, each within {s.ramp_balance_band_n:g} N, "
                f"steady for {s.ramp_steady_s:g} s"
            )
        return {
            "tare_done": "tare frames collected",
            "at_reach_pose": f"palm within {s.reach_tolerance_m * 1000:g} mm of the reach pose",
            "reach_timed_out": f"{s.reach_timeout_s:g} s in reach",
            "all_in_contact": "every grasping tip's contact gate fired",
            "close_timed_out": f"{s.close_timeout_s:g} s in close",
            "ramp_settled": settled,
            "ramp_timed_out": f"{s.ramp_timeout_s:g} s in ramp",
            "grip_lost": f"a grasping tip without contact or grip below {s.grip_lost_fraction:g} tau "
            f"for {s.contact_lost_s:g} s",
            "at_lift_height": "palm at lift_height_m",
            "hold_done": "hold_s elapsed",
            "release_detected": "index force on the object along +z below -release_threshold_n "
            "for release_debounce ticks",
            "lower_exhausted": f"palm {s.lower_overshoot_m * 1000:g} mm below the grasp height",
            "fingers_open": f"{s.open_s:g} s opening",
            "retreat_done": f"palm {s.retreat_m * 1000:g} mm above the release point",
        }

    @property
    def grip_targets(self) -> np.ndarray:
        """Each fingertip's grip target (N, finger order), as a new array; the tick reads the
        list ``_targets``."""
        return np.array(self._targets, dtype=float)

    @grip_targets.setter
    def grip_targets(self, targets: np.ndarray) -> None:
        self._targets = np.asarray(targets, dtype=float).tolist()

    @property
    def terminal(self) -> bool:
        return self.state in TERMINAL

    def _reason_setter(self, reason: str):
        def setter(*_: Any, **__: Any) -> None:
            self.failure_reason = reason

        return setter

    def _set_reason(self, reason: str, detail: str | None = None) -> None:
        self.failure_reason = reason
        self.failure_detail = detail

    def _on_enter(self, *_: Any, **__: Any) -> None:
        prev = self.history[-1][2] if self.history else "tare"
        t = self.snap.t if self.snap is not None else 0.0
        self.history.append((t, prev, self.state))
        self.ticks_in_state = 0
        self.ramp_settle.reset()
        self._reached_ticks = 0
        self.release_count = 0
        self.lost_count = [0] * len(self.names)

    def _elapsed(self) -> float:
        return self.ticks_in_state * self.dt

    @property
    def tau(self) -> float:
        return self.obj.tau_n

    # ----- guards (pure functions of the snapshot, profile and counters) -----
    def tare_done(self) -> bool:
        return bool(self.snap and self.snap.tare_ready)

    def at_reach_pose(self) -> bool:
        assert self.snap is not None
        return norm3(self.snap.p_palm_world - self.reach_pose) < self.s.reach_tolerance_m

    def reach_timed_out(self) -> bool:
        return self._elapsed() > self.s.reach_timeout_s

    def all_in_contact(self) -> bool:
        assert self.snap is not None
        return bool(self.snap.in_contact[self.grasp_mask].all())

    def close_timed_out(self) -> bool:
        return self._elapsed() > self.s.close_timeout_s

    def ramp_settled(self) -> bool:
        if self.push_then_hold:
            return self._reached_ticks * self.dt >= self.s.ramp_settle_s
        return self.ramp_settle.settled(self.dt)

    def ramp_timed_out(self) -> bool:
        return self._elapsed() > self.s.ramp_timeout_s

    def grip_lost(self) -> bool:
        dt, limit = self.dt, self.s.contact_lost_s
        for count, grasping in zip(self.lost_count, self._grasping):  # a plain loop: no generator per tick
            if grasping and count * dt >= limit:
                return True
        return False

    def at_lift_height(self) -> bool:
        assert self.snap is not None
        return abs(self.snap.p_palm_world[2] - self.lift_top[2]) < self.s.reach_tolerance_m

    def hold_done(self) -> bool:
        return self._elapsed() >= self.obj.hold_s

    def release_detected(self) -> bool:
        return self.release_count >= self.obj.release_debounce

    def lower_exhausted(self) -> bool:
        assert self.snap is not None
        return self.snap.p_palm_world[2] <= self.lower_limit_z + 1e-4

    def fingers_open(self) -> bool:
        return self._elapsed() >= self.s.open_s

    def retreat_done(self) -> bool:
        assert self.snap is not None
        if self._retreat_goal is None:
            return False
        return norm3(self.snap.p_palm_world - self._retreat_goal) < self.s.reach_tolerance_m

    # ----- the tick ----------------------------------------------------------
    def release_force_n(self, snap: Snapshot) -> float:
        """Force of the release fingertip ON the object along the support normal (+z):
        positive while it holds the object up, negative once the table carries it."""
        return float(-snap.f_world[self.release_idx, 2])

    def _update_counters(self, snap: Snapshot) -> None:
        grip = snap.grip_n.tolist()
        if self.state == "ramp":
            self._ramp_tick(snap)
        fraction = self.s.grip_lost_fraction
        self.lost_count = [
            count + 1 if not touching or g < fraction * t else 0
            for count, touching, g, t in zip(self.lost_count, snap.in_contact.tolist(), grip, self._lost_floor())
        ]
        self.release_count = self.release_count + 1 if self._release_signal(snap) else 0

    # The tick's rules a controller may refine (controller/grip_load.py does).
    def _ramp_tick(self, snap: Snapshot) -> None:
        """The ramp's settle counters, on the errors from the grip targets (push_then_hold: the
        ticks every grasping pad has been at its target, within the tolerance, or above)."""
        if self.push_then_hold:
            tolerance = self.s.ramp_tolerance_n
            reached = all(
                g >= t - tolerance
                for g, t, grasping in zip(snap.grip_n.tolist(), self._targets, self._grasping)
                if grasping
            )
            self._reached_ticks = self._reached_ticks + 1 if reached else 0
            return
        self.ramp_settle.update(self.grip_targets[self.grasp_mask] - snap.grip_n[self.grasp_mask])

    def _lost_floor(self) -> list[float]:
        """The targets whose ``grip_lost_fraction`` is the lost-grip floor, per fingertip."""
        return self._targets

    def _release_signal(self, snap: Snapshot) -> bool:
        """This tick counts toward the release: the index's force on the object along the
        support normal below -``release_threshold_n``."""
        return self.release_force_n(snap) < -self.obj.release_threshold_n

    def _force_sq(self, snap: Snapshot) -> list[float]:
        """Each fingertip's |f_sensor|^2 (no sqrt unless a limit is crossed), summed in the order
        np.einsum("ij,ij->i") sums them; once per snapshot (the force checks and a controller's
        own rules read it)."""
        seen, force_sq = self._force_sq_of
        if seen is not snap:
            force_sq = [((0.0 + x * x) + z * z) + y * y for x, y, z in snap.f_sensor.tolist()]
            self._force_sq_of = (snap, force_sq)
        return force_sq

    def _force_checks(self, snap: Snapshot, limit: float) -> int:
        """``FORCE_NOT_FINITE`` or ``OVERFORCE`` (the largest |f_sensor| above ``limit``), or 0."""
        force_sq = self._force_sq(snap)
        if not all(map(math.isfinite, force_sq)) and not all_finite(np.asarray(snap.f_sensor, dtype=float)):
            return FORCE_NOT_FINITE  # (finite components whose square overflows are overforce)
        return OVERFORCE if max(force_sq, default=0.0) > limit * limit else 0

    def tick(self, snap: Snapshot) -> Command:
        self.snap = snap
        if self.palm_target is None:
            self.palm_target = snap.p_palm_world.copy()
            self.motion.sync(snap.q)
        if not self.terminal:
            self.ticks_in_state += 1
            limit = self.hand.safety.max_fingertip_force_n
            self._update_counters(snap)
            self._decide(snap, self._force_checks(snap, limit), limit)
        self._act(snap)
        return Command(self.motion.next_goal(), self.palm_target.copy(), self.torque_on)  # (positional: cheaper)

    def _decide(self, snap: Snapshot, checks: int, limit: float) -> None:
        """A fault of the snapshot or of the force checks (``checks``: ``_force_checks``' bits),
        else the first transition whose guard holds."""
        if snap.fault:
            self.fail(reason=snap.fault, detail=snap.fault_detail)
        elif checks & FORCE_NOT_FINITE:
            # never let NaN slip past the over-force comparison (NaN > x is False)
            self.fail(reason="estimate_invalid", detail="non-finite estimated force in the snapshot")
        elif checks & OVERFORCE:  # all finite here
            force_sq = self._force_sq(snap)
            i = force_sq.index(max(force_sq))
            magnitude = math.hypot(*np.asarray(snap.f_sensor, dtype=float)[i])  # no overflow for huge components
            self.fail(
                reason="overforce",
                detail=f"fingertip {self.names[i]!r}: estimated |f_sensor| {magnitude:.4g} N > {limit:g} N",
            )
        else:
            for guard in self._guards[self.state]:
                if guard():
                    self.step()
                    break

    def safe_command(self, snap: Snapshot) -> Command:
        """The safe action from the measured pose, discarding the motion state (after a
        command came out non-finite): the goals restart at the measured joint angles."""
        q = np.where(np.isfinite(snap.q), snap.q, self.motion.open_q)
        last = (
            self.palm_target
            if self.palm_target is not None and np.all(np.isfinite(self.palm_target))
            else self.reach_pose
        )
        p = snap.p_palm_world if np.all(np.isfinite(snap.p_palm_world)) else last
        self.motion.sync(q)
        self.palm_target = np.array(p, dtype=float)
        if self.terminal:
            self._safe_action(snap._replace(q=q, p_palm_world=self.palm_target.copy()))
        return Command(q_goal=self.motion.next_goal(), p_palm_world=self.palm_target.copy(), torque_on=self.torque_on)

    # ----- actions per state --------------------------------------------------
    def _move_palm_toward(self, target: np.ndarray, speed: float) -> None:
        assert self.palm_target is not None
        delta = target - self.palm_target
        dist = norm3(delta)  # fixed-order sum: the same bits on any CPU (grasp_ctrl/numeric/vec3.py)
        step = speed * self.dt
        self.palm_target = target.copy() if dist <= step else self.palm_target + delta * (step / dist)

    def _squeeze(
        self,
        snap: Snapshot,
        gain: float,
        max_speed: float,
        palm_goal: np.ndarray | None = None,
        palm_speed: float = 0.0,
    ) -> None:
        """Per-finger force control along the closing vectors toward the grip targets; with
        ``palm_goal``, the palm moves toward it at ``palm_speed`` too (``_move_palm_toward``)."""
        grip = snap.grip_n
        slowest = 0.0 if self.push_then_hold else -max_speed  # push_then_hold: the ramp never backs a pad off
        speed = [min(max(gain * (t - g), slowest), max_speed) for g, t in zip(grip.tolist(), self._targets)]
        if self.s.low_confidence_slowdown and snap.variance is not None:
            speed = (np.array(speed) / (1.0 + np.max(snap.variance, axis=1) / self.s.variance_scale_n2)).tolist()
        dt = self.dt
        self.motion.squeeze_all(
            np.array([v * dt if grasping else 0.0 for v, grasping in zip(speed, self._grasping)]),
            np.asarray(snap.q, dtype=float),
            max_speed * dt,
        )
        if palm_goal is not None:
            self._move_palm_toward(palm_goal, palm_speed)

    def _act(self, snap: Snapshot) -> None:
        state = self.state
        s = self.s
        if state == "tare":
            pass  # stay still in free space while the baseline is recorded
        elif state == "reach":
            self.motion.set_posture(self.reach_q)
            self._move_palm_toward(self.reach_pose, self.hand.arm.max_speed_m_s)
        elif state == "close":
            step = s.close_speed_m_s * self.dt
            self.motion.advance_all(
                np.array(
                    [
                        step if grasping and not touching else 0.0
                        for grasping, touching in zip(self._grasping, snap.in_contact.tolist())
                    ]
                )
            )
        elif state == "ramp":
            self._squeeze(snap, s.ramp_gain_m_s_per_n, s.ramp_max_speed_m_s)
        elif state == "hold":
            if not self.push_then_hold:  # (push_then_hold: the fingers hold their goals)
                self._squeeze(snap, s.hold_gain_m_s_per_n, s.hold_max_speed_m_s)
        elif state == "lift":
            if self.push_then_hold:
                self._move_palm_toward(self.lift_top, s.lift_speed_m_s)
            else:
                self._squeeze(snap, s.hold_gain_m_s_per_n, s.hold_max_speed_m_s, self.lift_top, s.lift_speed_m_s)
        elif state == "lower":
            # The object was picked up at the reach pose: near that height the table is
            # close, so slow down and let the release debounce cost little extra push.
            near = snap.p_palm_world[2] - self.reach_pose[2] < s.lower_slow_zone_m
            speed = s.lower_slow_speed_m_s if near else s.lower_speed_m_s
            if self.push_then_hold:
                self._move_palm_toward(self.lower_bottom, speed)
            else:
                self._squeeze(snap, s.hold_gain_m_s_per_n, s.hold_max_speed_m_s, self.lower_bottom, speed)
        elif state == "release":
            # Back the pads off along their closing vectors: swinging straight to the open
            # posture can sweep a fingertip (the LEAP thumb) into the table beside the object.
            # First relax the servos in place (goals = the measured angles): under grip the
            # joints' springs are deflected, and not along the closing vectors, so backing off
            # from the deflected goals swings the pads as they unload (the LEAP thumb's tip rose
            # 11 mm on the mustard bottle) and drags a heavy object off the table by friction.
            if self.ticks_in_state == 0:
                self.motion.set_posture(np.asarray(snap.q, dtype=float))
            self.motion.advance_all(np.where(self.grasp_mask, -s.release_back_off_m_s * self.dt, 0.0))
        elif state == "retreat":
            if self._retreat_goal is None:
                self._retreat_goal = snap.p_palm_world + np.array([0.0, 0.0, s.retreat_m])
            self._move_palm_toward(self._retreat_goal, self.hand.arm.max_speed_m_s)
        elif state == "fault":
            self._safe_action(snap)

    def _safe_action(self, snap: Snapshot) -> None:
        action = self.hand.safety.on_fault
        assert self.palm_target is not None
        self.palm_target = snap.p_palm_world.copy()  # stop the arm where it is
        if action == "open":
            self.motion.set_posture(self.motion.open_q)
        elif action == "torque_off" and self.torque_on:
            self.motion.set_posture(snap.q)
            self.torque_on = False
        # "hold": keep the joint goals as they are, so the grip is maintained.
