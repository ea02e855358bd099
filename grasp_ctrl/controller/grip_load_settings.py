"""The grip_load controller's settings (controller/grip_load.py, docs/controller.md): the paper's
state machine's (with its own choices among them) and its own, gathered by what they rule."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.settings import after


@dataclass(frozen=True)
class RampCycle:
    """The ramp also settles when the grips cycle about their targets (a light object rocking on
    the table) over ``ramp_cycle_s``, each mean in the band and not drifting (controller/ramp_settle.py)."""

    ramp_cycle_s: float = 1.5  # 0: no such rule
    ramp_cycle_swing_n: float = 2.5  # with no filtered error swinging by more than this


@dataclass(frozen=True)
class GuardedReach:
    """The reach and the closing preshape."""

    reach_standoff_m: float = 0.025  # the pads reach this far off the nominal surface (an object set down
    #   by hand is up to a centimetre and ten degrees off), then take the closing preshape, each
    #   stopping at its own contact
    guarded_standoff_m: float = 0.01  # the closing preshape's standoff (an object's standoff_m overrides it)


@dataclass(frozen=True)
class LoadPhase:
    """The load state between ramp and lift."""

    load_speed_m_s: float = 0.005  # the arm's speed while the fingertips take the weight
    load_min_rise_m: float = 0.006  # the load phase lasts at least this rise (the grasp's compliance unwinds)
    load_max_rise_m: float = 0.015  # and ends this high at the latest
    load_gain_m_s_per_n: float = 0.005  # the grip loop while loading, lifting and holding
    load_max_speed_m_s: float = 0.004
    load_weight_fraction: float = 0.8  # ... or once the fingertips carry this share of the profile's weight
    load_settle_s: float = 0.1  #   for this long


@dataclass(frozen=True)
class Coordination:
    """Grip-load coordination: the common grip scale's friction-cone margin, the slip response and
    the friction estimate, the arm's pauses, the release from the carried load, the relaxation."""

    grip_margin: float = 1.3  # each pad's load <= mu x its grip / this (the friction cone's safety margin)
    slip_cone_fraction: float = 0.9  # slip: a pad's load above this share of mu x its grip
    slip_grip_rate_n_s: float = 15.0  # slip: a grip falling faster than this
    slip_rate_n_s: float = 25.0  # slip: a tangential force changing faster than this
    slip_filter_s: float = 0.03  # the rates are read over this long
    slip_pac_counts: float = 20.0  # slip: a fingertip's PAC spread this far above its usual level (raw counts;
    #   the sensor model's noise is 6, sim/biotac/model.py: 20 is sliding at about 1.5 mm/s more than usual)
    slip_pac_window_s: float = 0.5  # the usual level: the spread averaged over this long
    slip_pac_ticks: int = 2  #   for this many ticks
    slip_boost: float = 0.15  # each slip raises the grip scale by this
    slip_adapts_mu: bool = True  # vibration in lift or hold lowers the friction estimate to the load/grip held
    min_mu_hat: float = 0.3  # the friction estimate never falls below this
    slip_max_pause_s: float = 1.0  # the arm waits for the grips at most this long per state
    pause_when_short: bool = False  # the arm also waits while a grip is short of its raised target
    release_relative: bool = True  # release also when the carried load falls near the support (grip_load.py)
    grip_relax_per_s: float = 0.5  # the grip scale falls back toward the load's need at this rate


@dataclass(frozen=True)
class GripLimits:
    """The safety limit and the servos' limits."""

    min_grip_scale: float = 0.6  # the safety limit may scale the ramp's targets down to this share
    grip_cap_fraction: float = 0.8  # grips stay below this share of the safety limit and the crush force
    unwind_fraction: float = 0.9  # a pad above this share of the safety limit: its finger's goal is
    #   set to where its joints are (a goal wound past a stalled joint keeps the servo at its
    #   current limit, and a retreat has to undo the wind-up first); 1 or more: never
    windup_lag_factor: float = 1.5  # while squeezing, a grasping joint's goal stays within this many
    #   times the deflection at which its servo reaches its current limit (current limit x torque
    #   per amp / kp) of its measured angle: more goal adds no torque, only a wind-up that drives
    #   the joint when the contact gives; 0: no bound
    servo_limited_s: float = 0.5  # a finger held at that bound with its grip short of its target
    #   this long scales every ramp target down to the share it gives (0: never)


@dataclass(frozen=True)
class GripLoadSettings(PaperSettings):
    controller: ClassVar[str] = "grip_load"
    # the wind-up bound, the servo-limited targets and the cycle settle rule may be off
    ZERO_ALLOWED: ClassVar[tuple[str, ...]] = (
        *PaperSettings.ZERO_ALLOWED,
        "windup_lag_factor",
        "servo_limited_s",
        "ramp_cycle_s",
    )

    # Its choices among the paper's settings. A light, soft object (the plastic bottle) turns in
    # the grasp over a long lower, and set down 9 mm off centre over a 3 s slow approach, until a
    # grip fades: it lowers faster, slowly over the last 8 mm.
    lower_speed_m_s: float = 0.03
    lower_slow_zone_m: float = 0.008
    # The same 20 mm release, slower, so an object that touches down tilted settles as the grip
    # fades instead of dropping flat from a corner (docs/controller.md).
    open_s: float = 1.0
    release_back_off_m_s: float = 0.02
    # The squeeze moves each goal so the joints' springs push along the closing vector, to
    # force-closure targets (docs/controller.md).
    stiffness_aware_squeeze: bool = True
    grip_targets: str = "force_closure"

    cycle: RampCycle = field(default_factory=RampCycle, metadata=after("ramp_filter_s"))
    reach: GuardedReach = field(default_factory=GuardedReach, metadata=after("grip_weight_margin"))
    load: LoadPhase = field(default_factory=LoadPhase)
    coordination: Coordination = field(default_factory=Coordination)
    limits: GripLimits = field(default_factory=GripLimits)
