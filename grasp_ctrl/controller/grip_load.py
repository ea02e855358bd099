"""The grip-load controller: the paper's states plus a guarded reach, a load phase and a slip response.

The paper's controller ramps each fingertip to a fixed tau and lifts at constant speed. On a
heavy object the grasp then changes under the fingers at lift-off: whatever pressed the object
into the table (the LEAP thumb's distal link on a bottle's top, a pad on a box's rim) lets go
within a tick, the grip drops by a third to a half and the object slips. This controller uses
the force *vectors* the estimators give, as a human grasp does (Johansson and Westling 1984;
Romano et al. 2011, "Load"):

- **squeeze and targets** (its settings' defaults, controller/grip_load_settings.py; the paper's
  controller runs without them): the squeeze moves each goal so the joints' springs push along the
  closing vector (``stiffness_aware_squeeze``: a goal moved along it slides the LEAP thumb's pad
  down a box's face, pressing the box into the table), to force-closure targets (the thumb pushes
  back what the index and middle push); a deformable object's targets stay under its crush cap.
- **reach and preshape**: the pads reach backed off ``reach_standoff_m`` along their closing
  vectors, then each finger returns to its closing preshape and stops at its own contact.
- **load** (between ramp and lift): the arm rises slowly (``load_speed_m_s``) while the grip loop
  follows what the fingertips come to carry; the state ends after ``load_min_rise_m`` once they
  carry ``load_weight_fraction`` of the profile's weight for ``load_settle_s``, or at
  ``load_max_rise_m``.
- **grip-load coordination** (load, lift, hold, lower): every grip target is the ramp's target
  times one common factor ``s`` (the fingers push against each other through the object, so their
  targets keep their proportions), the smallest that keeps each pad's load inside its friction
  cone with a margin: ``grip_i >= grip_margin * load_i / mu_hat`` (the grip is the pad's normal
  force on an object held by its sides; ``mu_hat`` starts at the profile's friction).
- **slip response**: a pad whose load nears the cone, whose grip falls or whose tangential force
  jumps faster than set, or whose skin vibrates (PAC), raises ``s`` by ``slip_boost`` and makes the
  arm wait; vibration in lift or hold also lowers ``mu_hat`` to what the grasp held.
- ``s`` stays below ``grip_cap_fraction`` of the safety limit (less the tangential force: the
  over-force check reads ``|f_sensor|``) and of a deformable object's crush force, and relaxes at
  ``grip_relax_per_s``; during the ramp a fingertip past that cap scales the targets down.
- **the servos' limits**: while squeezing, no grasping joint's goal runs further from its angle
  than ``windup_lag_factor`` times the deflection at which its servo saturates; during the ramp a
  finger held there short of its target scales the targets to what it gives
  (``servo_limited_s``), and a ramp whose grips cycle about their targets settles
  (``ramp_cycle_s``, controller/ramp_settle.py).

It reads only what a real hand gives (the estimated forces, contact flags, PAC, joint angles, the
palm's position) and the object profile, never the world's truth. docs/controller.md.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from grasp_ctrl.config.actuation import hand_servo, torque_limits_nm
from grasp_ctrl.controller.grip_load_settings import GripLoadSettings
from grasp_ctrl.controller.joint_stiffness import joint_stiffness
from grasp_ctrl.controller.machine import STATES, TRANSITIONS, GraspController
from grasp_ctrl.controller.motion import FingertipMotion
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.ramp_settle import TrendRampSettle
from grasp_ctrl.controller.snapshot import Snapshot
from grasp_ctrl.errors import ConfigError
from grasp_ctrl.numeric.gravity import GRAVITY_M_S2
from grasp_ctrl.numeric.reductions import np_sum

LOAD_STATES = [
    *STATES[: STATES.index("reach") + 1],
    "preshape",
    *STATES[STATES.index("reach") + 1 : STATES.index("ramp") + 1],
    "load",
    *STATES[STATES.index("ramp") + 1 :],
]


def _load_transitions() -> list[tuple[str, str, str, str | None]]:
    out: list[tuple[str, str, str, str | None]] = []
    for src, dst, guard, reason in TRANSITIONS:
        if (src, dst) == ("reach", "close"):
            out += [
                ("reach", "preshape", guard, reason),
                ("preshape", "close", "preshape_done", None),
                ("preshape", "fault", "close_timed_out", "no_contact"),
            ]
        elif (src, dst) == ("ramp", "lift"):
            out += [
                ("ramp", "load", guard, reason),
                ("load", "fault", "grip_lost", "slipped"),
                ("load", "lift", "load_carried", None),
            ]
        else:
            out.append((src, dst, guard, reason))
    return out


LOAD_TRANSITIONS = _load_transitions()
COORDINATED = ("load", "lift", "hold", "lower")
SQUEEZING = ("ramp", *COORDINATED)  # the states whose goals the force loop moves
SATURATED_SHARE = 0.95  # a joint whose goal is this share of its wind-up bound away gives all it can


class GripLoadController(GraspController):
    """``GraspController`` with the load state, grip-load coordination and the slip response."""

    STATES = LOAD_STATES
    TRANSITIONS = LOAD_TRANSITIONS
    reads_vibration = True
    SETTINGS: ClassVar[type[PaperSettings]] = GripLoadSettings
    s: GripLoadSettings

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        if self.push_then_hold:  # its load phase and slip response regulate the grips throughout
            raise ConfigError("controller settings", "ramp_mode", "regulate for grip_load (push_then_hold: paper only)")
        self.ramp_settle = TrendRampSettle(self.s, self.dt)  # holds under quantised goals and noise
        limit = self.hand.safety.max_fingertip_force_n * self.s.limits.grip_cap_fraction
        if self.obj.deformable and self.obj.crush_force_n is not None:
            limit = min(limit, self.obj.crush_force_n * self.s.limits.grip_cap_fraction)
        self.grip_cap_n = limit
        # the targets keep their proportions under the cap (force closure asks the thumb for what
        # the index and middle push together: 4 N on the paper cup, whose crush force is 3.2 N)
        peak = float(np.max(self.grip_targets, initial=0.0))
        if peak > limit:
            self.grip_targets = self.grip_targets * (limit / peak)
        self.base_targets = self.grip_targets.copy()
        self._base = self.base_targets.tolist()
        self._base_floor = [max(b, 1e-3) for b in self._base]  # (the cone's and the cap's divisor)
        self.scale = 1.0  # the common factor on the base targets
        self.ramp_scale = 1.0  # the factor the ramp settled on
        self.mu_hat = float(self.obj.mu)
        self.weight_n = float(self.obj.mass_kg) * GRAVITY_M_S2
        self.carried_n = 0.0
        self.carried_ticks = 0
        # Per-finger state as lists (GraspController: a numpy call costs more than the loop here).
        self.slipping = [False] * len(self.names)
        self.slip_events = 0
        self._prev_ft: list[float] | None = None  # the filtered tangential forces and grips
        self._prev_grip = [0.0] * len(self.names)
        self._held_ratio = 0.0  # the carried load over the summed grip, on the previous tick
        self._pac_usual = [math.inf] * len(self.names)  # each fingertip's usual PAC spread (counts)
        self._pac_ticks = [0] * len(self.names)
        self._grasp_idx = [i for i, g in enumerate(self._grasping) if g]
        self._carried_of: tuple[Snapshot | None, float] = (None, 0.0)  # (snapshot, _carried of it)
        self._load_start_z: float | None = None
        self._load_top: np.ndarray | None = None
        self.pause_ticks = 0
        self._hold_sum, self._hold_index_sum, self._hold_n = 0.0, 0.0, 0
        self.wide_q = self._wide_posture()
        self._alpha = [0.0] * len(self.names)  # each finger's way from the wide to the closing preshape
        self.lag_bound_rad = self._lag_bound()
        self._servo_limited = [0] * len(self.names)  # ticks each finger has given all its servos can
        self._joint_finger = np.zeros(len(self.hand.joints), dtype=np.int64)  # each joint's finger index
        for i, name in enumerate(self.names):
            self._joint_finger[self.kin.slices[name]] = i
        self._grasp_joints = self.grasp_mask[self._joint_finger]
        self._grasp_joint_list = self._grasp_joints.tolist()
        self._lag_bound_list = None if self.lag_bound_rad is None else self.lag_bound_rad.tolist()

    def _lag_bound(self) -> np.ndarray | None:
        """Per joint: ``windup_lag_factor`` times the goal-to-angle deflection at which the joint
        reaches its torque limit (config/actuation.py: a servo's current limit x its torque per amp,
        or a torque-controlled joint's limit; over its stiffness); None without a bound (factor 0,
        or the stiffness or torque constant unknown)."""
        if self.s.limits.windup_lag_factor <= 0.0:
            return None
        kp = joint_stiffness(self.hand).kp_nm_per_rad
        if kp is None:
            return None
        if self.hand.servo_driven and not hand_servo(self.hand).known_torque:
            return None
        limit_nm = torque_limits_nm(self.hand)
        return self.s.limits.windup_lag_factor * limit_nm / kp

    def _bound_windup(self, snap: Snapshot) -> None:
        """Keep each grasping joint's goal within ``lag_bound_rad`` of its measured angle. On the
        mustard bottle the thumb's distal joint sits at its 0.55 A limit while the squeeze keeps
        asking its pad for more: its goal ran a radian past the joint, and when the grasp shifted
        the joint swung toward it and the pad's force jumped past the safety limit."""
        bound = self.lag_bound_rad
        if bound is None or not self._wound_past(snap.q.tolist(), self.motion.q_goal.tolist()):
            return
        q = np.asarray(snap.q, dtype=float)
        goal = self.motion.q_goal
        lo, hi = q - bound, q + bound
        over = self._grasp_joints & ((goal < lo) | (goal > hi))
        if not over.any():
            return
        m = self.motion
        goal[over] = np.clip(np.clip(goal[over], lo[over], hi[over]), m.lower[over], m.upper[over])  # limits last
        self.motion.rebase_fingers(sorted({int(i) for i in self._joint_finger[over]}))

    def _wound_past(self, q: list[float], goal: list[float]) -> bool:
        """Whether a grasping joint's goal lies outside ``lag_bound_rad`` of its angle (the
        comparisons ``_bound_windup`` makes, on lists)."""
        assert self._lag_bound_list is not None
        for g, qj, b, grasping in zip(goal, q, self._lag_bound_list, self._grasp_joint_list):
            if grasping and (g < qj - b or g > qj + b):
                return True
        return False

    def _preshape_standoff_m(self) -> float:
        """Guarded closing: the pads wait ``guarded_standoff_m`` off the nominal surface (an object
        set down by hand sits up to a centimetre and ten degrees off), and each finger closes
        until its own contact (the close state), so the placement does not decide the grasp."""
        return self.obj.standoff_m if self.obj.standoff_m is not None else self.s.reach.guarded_standoff_m

    def _wide_posture(self) -> np.ndarray:
        """The reach posture with every grasping pad backed off along its closing vector by
        ``reach_standoff_m`` less the closing standoff (the same IK as closing, so the preshape
        state's way back is the line the pad closes along); the cap finger keeps its posture."""
        back = self.s.reach.reach_standoff_m - self._preshape_standoff_m()
        if back <= 0.0:
            return self.reach_q.copy()
        scratch = FingertipMotion(self.hand, self.kin, self.s.stiffness_aware_squeeze)
        scratch.facing = self.motion.facing
        scratch.set_posture(self.reach_q)
        moving = self.grasp_mask.copy()
        if self.obj.cap is not None and self.obj.cap.finger in self.names:
            moving[self.names.index(self.obj.cap.finger)] = False
        steps = max(1, math.ceil(back / 0.001))  # millimetre IK steps, as closing takes them
        for _ in range(steps):
            scratch.advance_all(np.where(moving, -back / steps, 0.0))
        return np.clip(scratch.q_goal, self.motion.lower, self.motion.upper)

    # ----- guards --------------------------------------------------------------
    @classmethod
    def guard_words(cls, s: PaperSettings) -> dict[str, str]:
        assert isinstance(s, GripLoadSettings)
        cycle = s.cycle.ramp_cycle_s
        load = s.load
        release = super().guard_words(s)["release_detected"]
        return {
            **super().guard_words(s),
            "ramp_settled": f"every grip within {s.ramp_tolerance_n:g} N of its target for {s.ramp_settle_s:g} s, "
            f"or balanced (each within {s.ramp_balance_band_n:g} N) with a flat trend over {s.ramp_steady_s:g} s"
            + (f", or cycling about the targets over {cycle:g} s" if cycle > 0 else ""),
            "release_detected": release
            + (", or the carried load falls near the support" if s.coordination.release_relative else ""),
            "preshape_done": "every grasping finger at its closing preshape or stopped at its own contact",
            "load_carried": f"palm risen {load.load_min_rise_m * 1000:g} mm and the pads carry "
            f"{load.load_weight_fraction:g} of the weight for {load.load_settle_s:g} s, "
            f"or risen {load.load_max_rise_m * 1000:g} mm",
        }

    def preshape_done(self) -> bool:
        """Every grasping finger at its closing preshape, or stopped at its own contact."""
        assert self.snap is not None
        touching = self.snap.in_contact.tolist()
        return all(a >= 1.0 or t for a, t, g in zip(self._alpha, touching, self._grasping) if g)

    def load_carried(self) -> bool:
        assert self.snap is not None
        start = self._load_start_z
        if start is None:
            return False
        rise = self.snap.p_palm_world[2] - start
        if rise >= self.s.load.load_max_rise_m:
            return True
        return rise >= self.s.load.load_min_rise_m and self.carried_ticks * self.dt >= self.s.load.load_settle_s

    # ----- per-tick estimates ------------------------------------------------------
    def _update_counters(self, snap: Snapshot) -> None:
        """The paper's counters (with the refinements below), then the coordination in the
        states that carry."""
        super()._update_counters(snap)
        if self.state in COORDINATED:
            self._unwind(snap)
            self._coordinate(snap)

    def _ramp_tick(self, snap: Snapshot) -> None:
        self._unwind(snap)
        self._limit_to_safety(snap)
        self._limit_to_servos(snap)
        super()._ramp_tick(snap)

    def _limit_to_servos(self, snap: Snapshot) -> None:
        """While ramping, a grasping finger whose servos give all they can (a joint's goal held at
        the wind-up bound, ``_bound_windup``) while its grip stays short of its target for
        ``servo_limited_s`` scales every target down to the share it gives (down to
        ``min_grip_scale``): the fingers push against each other through the object, so a target
        the weakest finger cannot reach keeps the ramp from settling (on the mustard bottle the
        LEAP thumb's MCP and distal joints sit at 1.2 and 0.55 A with its grip at 3.1 N of 5.5)."""
        bound = self.lag_bound_rad
        if bound is None or self.s.limits.servo_limited_s <= 0.0:
            return
        q = np.asarray(snap.q, dtype=float)
        pinned = self._grasp_joints & (np.abs(self.motion.q_goal - q) >= SATURATED_SHARE * bound)
        grip = snap.grip_n.tolist()
        short: list[float] = []
        for i, name in enumerate(self.names):
            held = self._grasping[i] and grip[i] < self._targets[i] - self.s.ramp_tolerance_n
            held = held and bool(pinned[self.kin.slices[name]].any())
            self._servo_limited[i] = self._servo_limited[i] + 1 if held else 0
            if self._servo_limited[i] * self.dt >= self.s.limits.servo_limited_s:
                short.append(max(grip[i], 0.0) / max(self._targets[i], 1e-9))
        if short:
            scale = max(self.s.limits.min_grip_scale, self.scale * min(short))
            self._servo_limited = [0] * len(self.names)
            if scale < self.scale:
                self.scale = scale
                self._targets = [b * self.scale for b in self._base]

    def _unwind(self, snap: Snapshot) -> None:
        """A grasping pad whose |f_sensor| passes ``unwind_fraction`` of the safety limit: its
        finger's goal is set to its measured joint angles. A goal wound past a stalled joint
        (on the mustard bottle the thumb's IPL link rests on the box's top and its distal joint
        stalls 0.12 rad short of its goal, at its 0.55 A limit) keeps that servo at its limit
        while the ramp retreats the pad at its rate limit, and the pad's force rises into the
        over-force fault; from the measured angles the retreat acts at once."""
        fraction = self.s.limits.unwind_fraction
        if fraction >= 1.0:
            return
        limit = fraction * self.hand.safety.max_fingertip_force_n
        limit_sq = limit * limit
        over = [i for i, sq in enumerate(self._force_sq(snap)) if self._grasping[i] and sq > limit_sq]
        if over:
            q = np.asarray(snap.q, dtype=float)
            self.motion.hold_at(q, [self.kin.slices[self.names[i]] for i in over])

    def _lost_floor(self) -> list[float]:
        """The tuned targets: a raised target must not turn a steady grip into a slip."""
        return self._base

    def _release_signal(self, snap: Snapshot) -> bool:
        return self._support_took_load(snap)

    def _support_took_load(self, snap: Snapshot) -> bool:
        """The paper's release rule (the index's force on the object along the support normal below
        -``release_threshold_n``, counted from what the index pressed down in hold), or, near the support (within ``lower_slow_zone_m`` of the grasp
        height), the load the fingertips carry together falling ``release_threshold_n`` (or half of
        it, when more) below its mean while the object hung in the grasp (the hold state): the
        support pushes back. The sum, not one fingertip: the fingers' vertical forces also hold a
        couple (on the lego the index and middle push up 0.8 N each, the thumb down 0.9 N), which
        shifts as the arm moves; the sum is the object's weight however the couple shifts."""
        index_n = self.release_force_n(snap)
        carried = self._carried(snap)
        if self.state == "hold":
            self._hold_sum += carried
            self._hold_index_sum += index_n
            self._hold_n += 1
            return False
        # an index that pressed down while the object hung (a couple: on the lego the thumb lifts
        # 1.4 N while the index and middle press 0.45 N each) counts from what it pressed then
        pressed = min(self._hold_index_sum / self._hold_n, 0.0) if self._hold_n else 0.0
        if index_n - pressed < -self.obj.release_threshold_n:
            return True
        if self.state != "lower" or not self.s.coordination.release_relative or not self._hold_n:
            return False
        near = snap.p_palm_world[2] - self.reach_pose[2] < self.s.lower_slow_zone_m
        held = self._hold_sum / self._hold_n
        return near and carried < held - max(self.obj.release_threshold_n, 0.5 * held)

    def _vibrating(self, snap: Snapshot, touching: list[bool]) -> list[bool]:
        """Fingertips whose PAC spread stayed ``slip_pac_counts`` above its usual level for
        ``slip_pac_ticks`` ticks: the skin vibrates as it slides (a BioTac's PAC, sampled at
        2.2 kHz, 22 samples a frame). The usual level is each fingertip's spread averaged over
        ``slip_pac_window_s`` of quiet ticks, so a steady creep (MuJoCo's held grasps creep at
        about a millimetre a second) raises it, and a slip that speeds up stands out."""
        spread = snap.pac_spread
        if spread is None:
            return [False] * len(self.names)
        c = self.s.coordination
        counts, ticks_needed = c.slip_pac_counts, c.slip_pac_ticks
        k = min(1.0, self.dt / max(c.slip_pac_window_s, self.dt))
        usual_now, ticks_now, vibrating = [], [], []
        for usual, x, t, ticks in zip(
            self._pac_usual, np.asarray(spread, dtype=float).tolist(), touching, self._pac_ticks
        ):
            if not math.isfinite(usual):
                usual = x
            loud = t and x > usual + counts
            usual_now.append((usual if loud else usual + k * (x - usual)) if t else math.inf)
            ticks = ticks + 1 if loud else 0
            ticks_now.append(ticks)
            vibrating.append(ticks >= ticks_needed)
        self._pac_usual, self._pac_ticks = usual_now, ticks_now
        return vibrating

    def _carried(self, snap: Snapshot) -> float:
        """The load the touching grasping fingertips carry together: the object's weight pulls them
        down (-z on the sensor), so it is minus the sum of their vertical forces."""
        seen, carried = self._carried_of
        if seen is not snap:  # (read twice a tick: the release rule and the coordination)
            z = [
                row[2] for row, t, g in zip(snap.f_world.tolist(), snap.in_contact.tolist(), self._grasping) if t and g
            ]
            carried = -np_sum(z)
            self._carried_of = (snap, carried)
        return carried

    def _limit_to_safety(self, snap: Snapshot) -> None:
        """While ramping, a fingertip whose |f_sensor| passes ``grip_cap_fraction`` of the safety
        limit (the LEAP thumb on a box's rim carries as much shear as normal force) scales every
        target down in proportion, so the ramp settles below the over-force fault instead of
        running into it (down to ``min_grip_scale`` of the tuned targets)."""
        peak_sq = 0.0  # the largest |f|^2 of a grasping pad, squares summed as np.sum sums them; NaN sticks
        for (x, y, z), grasping in zip(snap.f_sensor.tolist(), self._grasping):
            if grasping:
                sq = (x * x + y * y) + z * z
                if sq > peak_sq or sq != sq:
                    peak_sq = sq
        peak = math.sqrt(peak_sq)
        if peak > self.grip_cap_n:
            self.scale = max(self.s.limits.min_grip_scale, self.scale * self.grip_cap_n / peak)
            self._targets = [b * self.scale for b in self._base]

    def _coordinate(self, snap: Snapshot) -> None:
        s, dt = self.s, self.dt
        c = s.coordination
        f = snap.f_sensor
        f_t = np.hypot(f[:, 0], f[:, 1]).tolist()  # (libm's hypot: math.hypot rounds otherwise)
        grip = snap.grip_n.tolist()
        touching = [t and g for t, g in zip(snap.in_contact.tolist(), self._grasping)]
        self.carried_n = self._carried(snap)
        if self.state == "load":
            enough = self.carried_n >= s.load.load_weight_fraction * self.weight_n
            self.carried_ticks = self.carried_ticks + 1 if enough else 0
        # the scale each fingertip's cone asks for. The pads grip the object's sides, so the
        # normal force is the grip (horizontal) and the load is the vertical force on the object:
        # grip_i >= margin x load_i / mu_hat, i.e. scale >= margin x load_i / (mu_hat x base_i).
        # (The sensor frame's own normal is not the contact's on the BioTac's curved skin: a
        # pad on a domed cap reads as much shear as normal force while it holds still.)
        mu = max(self.mu_hat, 1e-3)
        # slip signals: the ratio near the cone, the grip falling, the tangential force jumping
        # (rates from first-order filtered forces: a learned estimate's tick-to-tick noise is no slip)
        k = min(1.0, dt / max(c.slip_filter_s, dt))
        prev_ft, prev_grip = (f_t, grip) if self._prev_ft is None else (self._prev_ft, self._prev_grip)
        # (also while loading: a grip raised as the pads start to slide carries a heavy box whose
        # shear builds as it leaves the table: docs/controller.md)
        vibrating = self._vibrating(snap, touching)
        margin, cone = c.grip_margin, c.slip_cone_fraction * mu
        falling, jumping = -c.slip_grip_rate_n_s, c.slip_rate_n_s
        wanted: float | None = None  # max(need over the touching pads, default=1.0), as max() picks it
        ft_filtered, grip_filtered, slipping = [], [], []
        for t, row, floor, x, px, g, pg, v in zip(
            touching, snap.f_world.tolist(), self._base_floor, f_t, prev_ft, grip, prev_grip, vibrating
        ):
            load = -row[2]
            if t:
                need = margin * max(load, 0.0) / (mu * floor)
                if wanted is None or need > wanted:
                    wanted = need
            xf, gf = px + k * (x - px), pg + k * (g - pg)
            ft_filtered.append(xf)
            grip_filtered.append(gf)
            slipping.append(
                t
                and (
                    abs(load) > cone * max(g, 0.0)  # (max(NaN, 0.0) is NaN, as np.maximum's)
                    or (gf - pg) / dt < falling
                    or abs((xf - px) / dt) > jumping
                    or v
                )
            )
        if wanted is None:
            wanted = 1.0
        self._prev_ft, self._prev_grip = ft_filtered, grip_filtered
        if any(slipping) and not any(self.slipping):
            self.slip_events += 1
            self.scale += c.slip_boost
        total_grip = np_sum([g if t else 0.0 for g, t in zip(grip, touching)])
        if any(vibrating) and self.state in ("lift", "hold") and c.slip_adapts_mu:
            # The object slides in the grasp (the skin vibrates) while it hangs in it: the friction
            # is at most the load the grasp held over the grip it held it with (the sum: a single
            # pad's ratio on a domed cap is no friction). The cone rule then asks for the grip
            # that friction needs. (Not while loading: pads that slide over an object the table
            # still carries say nothing of the friction.)
            if total_grip > 0.1 and self._held_ratio > 0.0:
                self.mu_hat = max(c.min_mu_hat, min(self.mu_hat, self._held_ratio))
        self.slipping = slipping
        self._held_ratio = max(self.carried_n, 0.0) / total_grip if total_grip > 0.1 else 0.0
        # the cap: the safety limit on |f| (with the tangential force) and a deformable's crush force
        cap: float | None = None  # min over the grasping pads, default 1.0, as min() picks it
        for i in self._grasp_idx:
            room = self.grip_cap_n**2 - f_t[i] ** 2
            room_cap = math.sqrt(room) / self._base_floor[i] if room > 0 else 1.0
            if cap is None or room_cap < cap:
                cap = room_cap
        if cap is None:
            cap = 1.0
        # what the ramp settled on, unless the load asks for more; a slip's boost relaxes like the
        # load's need (kept through lift and hold, it left the heavy boxes' thumbs at the safety limit)
        wanted = max(wanted, self.ramp_scale)
        if wanted > self.scale:
            self.scale = wanted
        else:  # relax slowly toward what the load asks for
            self.scale = max(wanted, self.scale - c.grip_relax_per_s * dt)
        self.scale = min(max(self.scale, s.limits.min_grip_scale), cap)
        self._targets = [b * self.scale for b in self._base]

    # ----- actions ----------------------------------------------------------------
    def _on_enter(self, *args: Any, **kwargs: Any) -> None:
        super()._on_enter(*args, **kwargs)
        self.carried_ticks = 0
        self.pause_ticks = 0
        if self.state == "load" and self.snap is not None:  # (a tick sets the snapshot before stepping)
            self.ramp_scale = self.scale
            self._load_start_z = float(self.snap.p_palm_world[2])
            self._load_top = np.asarray(
                self.palm_target if self.palm_target is not None else self.snap.p_palm_world, dtype=float
            ).copy()
            self._load_top[2] += self.s.load.load_max_rise_m + 0.01  # a goal past the phase's end: it ends on the way

    def _paused(self) -> bool:
        """The arm waits while a fingertip slips or a grip is short of its raised target (at
        most ``slip_max_pause_s`` per state: a grip the servos cannot give must not stall it)."""
        if self.pause_ticks * self.dt >= self.s.coordination.slip_max_pause_s:
            return False
        assert self.snap is not None
        grip = self.snap.grip_n.tolist()
        tol = self.s.ramp_tolerance_n
        short = self.s.coordination.pause_when_short and any(
            g < t - 3.0 * tol for g, t, grasping in zip(grip, self._targets, self._grasping) if grasping
        )
        if any(self.slipping) or short:
            self.pause_ticks += 1
            return True
        return False

    def _act(self, snap: Snapshot) -> None:
        state, s = self.state, self.s
        load = s.load
        if state == "reach":
            self.motion.set_posture(self.wide_q)  # pads clear of an object set down off its mark
            self._move_palm_toward(self.reach_pose, self.hand.arm.max_speed_m_s)
        elif state == "preshape":
            # each finger moves in joint space from the wide to the closing preshape, its pad at
            # about the closing speed, and stops at its own contact
            span = max(s.reach.reach_standoff_m - self._preshape_standoff_m(), 1e-6)
            step = s.close_speed_m_s * self.dt / span
            touching = snap.in_contact.tolist()
            q = self.wide_q.copy()
            for i, name in enumerate(self.names):
                if not touching[i]:
                    self._alpha[i] = min(1.0, self._alpha[i] + step)
                rows = self.kin.slices[name]
                q[rows] += self._alpha[i] * (self.reach_q[rows] - self.wide_q[rows])
            self.motion.set_posture(q)
        elif state == "load":
            assert self._load_top is not None  # set on entering load
            speed = 0.0 if self._paused() else load.load_speed_m_s
            self._squeeze(snap, load.load_gain_m_s_per_n, load.load_max_speed_m_s, self._load_top, speed)
        elif state == "lift":
            speed = 0.0 if self._paused() else s.lift_speed_m_s
            self._squeeze(snap, load.load_gain_m_s_per_n, load.load_max_speed_m_s, self.lift_top, speed)
        elif state == "hold":
            self._squeeze(snap, load.load_gain_m_s_per_n, load.load_max_speed_m_s)
        elif state == "lower":
            near = snap.p_palm_world[2] - self.reach_pose[2] < s.lower_slow_zone_m
            speed = s.lower_slow_speed_m_s if near else s.lower_speed_m_s
            if self._paused() and not near:
                speed = 0.0
            self._squeeze(snap, s.hold_gain_m_s_per_n, s.hold_max_speed_m_s, self.lower_bottom, speed)
        else:
            super()._act(snap)
        if state in SQUEEZING:
            self._bound_windup(snap)

    @property
    def tau(self) -> float:
        """The ramp's tau times the grip scale (what the tick log records as the grip target)."""
        return self.obj.tau_n * self.scale
