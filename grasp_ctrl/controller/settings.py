"""Controller gains, speeds and time-outs (hand-independent defaults), and each controller's own
choices among them (``settings_for``). The classes behind the names: controller/registry.py."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from grasp_ctrl.config.objects import GRIP_TARGET_MODES
from grasp_ctrl.config.toml_reader import finite_number
from grasp_ctrl.errors import ConfigError, UsageError

if TYPE_CHECKING:
    from grasp_ctrl.config.hand import HandConfig

CONTROLLER_NAMES: tuple[str, ...] = ("paper", "grip_load")
DEFAULT_CONTROLLER = "grip_load"  # it measures better under both variation profiles (docs/results.md)

# Each controller's own choices where ControllerSettings' defaults (grip_load's) are not its own:
# the paper's controller squeezes along the closing vectors toward tau on every fingertip.
CONTROLLER_CHOICES: dict[str, dict[str, Any]] = {
    "paper": {
        "stiffness_aware_squeeze": False,
        "grip_targets": "equal",
        "open_s": 0.4,
        "release_back_off_m_s": 0.05,
        "lower_speed_m_s": 0.015,
        "lower_slow_zone_m": 0.015,
    },
    "grip_load": {},
}


#: How the paper's controller reads "increase the force on all the fingertips to tau ... then
#: raise the arm" (docs/controller.md, decision record 0017):
#: regulate: every pad is regulated toward its target in ramp, hold, lift and lower;
#: push_then_hold: the ramp only pushes each pad forward, ends once every pad has reached its
#: target, and the fingers then hold their goals while the arm lifts and lowers.
RAMP_MODES: tuple[str, ...] = ("regulate", "push_then_hold")


def unknown_controller(name: str) -> UsageError:
    """The one-line error for a controller name that is not one of ``CONTROLLER_NAMES``."""
    return UsageError(f"--controller {name!r}: unknown (one of {', '.join(CONTROLLER_NAMES)})")


@dataclass(frozen=True)
class ControllerSettings:
    controller: str = "grip_load"  # which controller (controller/registry.py): grip_load | paper
    close_speed_m_s: float = 0.02  # fingertip speed along the task vector while closing
    close_timeout_s: float = 4.0
    ramp_gain_m_s_per_n: float = 0.01  # fingertip speed per N of force error
    ramp_max_speed_m_s: float = 0.01  # rate limit of the force ramp
    ramp_tolerance_n: float = 0.15
    ramp_settle_s: float = 0.1  # all fingertips within tolerance this long
    ramp_balance_band_n: float = 0.4  # or: mean grip within tolerance, each within this band, and
    ramp_steady_n: float = 0.05  #   steady (a free object balancing opposing fingers,
    ramp_steady_s: float = 0.5  #   controller/ramp_settle.py): no grip moved more than
    #   ramp_steady_n for ramp_steady_s
    ramp_filter_s: float = 0.1  # both rules read each grip's error averaged over this long
    ramp_cycle_s: float = 1.5  # grip_load: or the grips cycle about their targets (a light object
    #   rocking on the table) over this long, each mean in the band and not drifting (0: no such rule)
    ramp_cycle_swing_n: float = 2.5  #   with no filtered error swinging by more than this
    ramp_timeout_s: float = 6.0
    hold_gain_m_s_per_n: float = 0.005  # grip force controller during lift/hold/lower
    hold_max_speed_m_s: float = 0.004
    reach_tolerance_m: float = 0.001
    reach_timeout_s: float = 10.0
    lift_speed_m_s: float = 0.04
    lower_speed_m_s: float = 0.03  # grip_load's (the paper's controller: 0.015; CONTROLLER_CHOICES):
    #   a light, soft object (the plastic bottle) turns in the grasp over a long lower and a grip fades
    lower_overshoot_m: float = 0.03  # how far below the grasp height lowering may go
    lower_slow_zone_m: float = 0.008  # approach the support surface slowly from this high (grip_load's;
    #   the paper's controller: 0.015): a plastic bottle set down 9 mm off centre turns in the grasp
    #   over a 3 s slow approach until a grip fades
    lower_slow_speed_m_s: float = 0.005
    grip_lost_fraction: float = 0.3  # grip below this fraction of tau = slipping
    contact_lost_s: float = 0.05
    # grip_load's release (the paper's controller: 0.4 s at 0.05 m/s; CONTROLLER_CHOICES): the
    # same 20 mm, slower, so an object that touches down tilted settles as the grip fades instead
    # of dropping flat from a corner (the lego landed at 0.13 m/s)
    open_s: float = 1.0  # time to open the fingers on release
    release_back_off_m_s: float = 0.02  # release: pads back off along their closing vectors
    retreat_m: float = 0.05
    preshape: bool = True  # reach in a posture whose pads face the object, close along
    preshape_standoff_m: float = 0.01  #   its surface normals (kinematics/preshape.py), this far off
    # The next two are grip_load's choices; the paper's controller runs with False and "equal"
    # (settings_for below).
    stiffness_aware_squeeze: bool = True  # move the pads' goals so the joints' springs push along the
    #   closing vectors (controller/motion.py); off: along the closing vectors, and the LEAP thumb's
    #   pad slides down a box's face as it squeezes, pressing the box into the table (docs/controller.md)
    grip_targets: str = "force_closure"  # per-fingertip targets whose closing forces cancel (the thumb
    #   pushes back what the index and middle push), the smallest tau; "equal": tau each
    #   (controller/grip_targets.py)
    grip_weight_margin: float = 0.0  # > 0: scale the targets so mu x their sum >= this x the object's
    #   weight (objects.toml mass_kg); 0: tau_n as tuned
    # grip_load only (controller/grip_load.py, docs/controller.md)
    reach_standoff_m: float = 0.025  # the pads reach this far off the nominal surface (an object set down
    #   by hand is up to a centimetre and ten degrees off), then take the closing preshape, each
    #   stopping at its own contact
    guarded_standoff_m: float = 0.01  # the closing preshape's standoff (an object's standoff_m overrides it)
    load_speed_m_s: float = 0.005  # the arm's speed while the fingertips take the weight
    load_min_rise_m: float = 0.006  # the load phase lasts at least this rise (the grasp's compliance unwinds)
    load_max_rise_m: float = 0.015  # and ends this high at the latest
    load_gain_m_s_per_n: float = 0.005  # the grip loop while loading, lifting and holding
    load_max_speed_m_s: float = 0.004
    load_weight_fraction: float = 0.8  # ... or once the fingertips carry this share of the profile's weight
    load_settle_s: float = 0.1  #   for this long
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
    min_grip_scale: float = 0.6  # the safety limit may scale the ramp's targets down to this share
    grip_cap_fraction: float = 0.8  # grips stay below this share of the safety limit and the crush force
    unwind_fraction: float = 0.9  # a pad above this share of the safety limit: its finger's goal is
    #   set to where its joints are (a goal wound past a stalled joint keeps the servo at its
    #   current limit, and a retreat has to undo the wind-up first); 1 or more: never
    windup_lag_factor: float = 1.5  # grip_load: while squeezing, a grasping joint's goal stays within
    #   this many times the deflection at which its servo reaches its current limit (current limit x
    #   torque per amp / kp) of its measured angle: more goal adds no torque, only a wind-up that drives
    #   the joint when the contact gives; 0: no bound
    servo_limited_s: float = 0.5  # grip_load: a finger held at that bound with its grip short of its target
    #   this long scales every ramp target down to the share it gives (0: never)
    ramp_mode: str = "regulate"  # the paper's controller: one of RAMP_MODES (above)
    low_confidence_slowdown: bool = False  # slow the ramp when the policy's variance is high
    variance_scale_n2: float = 0.05  # variance at which the ramp runs at half speed


#: The text settings and their values.
SETTING_CHOICES: dict[str, tuple[str, ...]] = {
    "grip_targets": GRIP_TARGET_MODES,
    "controller": CONTROLLER_NAMES,
    "ramp_mode": RAMP_MODES,
}
MAX_SETTING = 1e6  # no controller setting (seconds, metres, newtons, ratios) comes near it
# settings that may be zero (no slow zone, no overshoot, no retreat; grip_load's wind-up bound,
# servo-limited targets and cycle settle rule off)
ZERO_ALLOWED = (
    "lower_overshoot_m",
    "lower_slow_zone_m",
    "retreat_m",
    "grip_weight_margin",
    "windup_lag_factor",
    "servo_limited_s",
    "ramp_cycle_s",
)


def checked_settings(values: dict[str, Any], where: str, table: str | None = None) -> dict[str, Any]:
    """``values`` checked as controller settings: known keys, each of its default's type, a text
    setting one of ``SETTING_CHOICES``, numbers finite and positive (those of ``ZERO_ALLOWED``
    may be zero). Raises a UsageError naming ``where`` and ``settings.KEY``, or with ``table``
    (a file's table, ``where`` the file) a ConfigError naming the file and ``table.KEY``."""

    def fail(key: str, need: str) -> Exception:
        if table is not None:
            return ConfigError(where, f"{table}.{key}", need)
        return UsageError(f"{where}: settings.{key}: {need}")

    fields = {f.name for f in dataclasses.fields(ControllerSettings)}
    defaults = ControllerSettings()
    out: dict[str, Any] = {}
    for key, v in values.items():
        if key not in fields:
            raise fail(key, f"a known setting (one of {', '.join(sorted(fields))})")
        default = getattr(defaults, key)
        if isinstance(default, bool):
            if not isinstance(v, bool):
                raise fail(key, f"true or false (got {v!r})")
        elif isinstance(default, str):
            choices = SETTING_CHOICES.get(key, ())
            if v not in choices:
                raise fail(key, f"one of {', '.join(choices)} (got {v!r})")
        elif not finite_number(v) or v < 0 or v > MAX_SETTING or (v == 0 and key not in ZERO_ALLOWED):
            need = f"a finite number {'>=' if key in ZERO_ALLOWED else '>'} 0 and <= {MAX_SETTING:g}"
            shown = repr(v) if len(repr(v)) <= 40 else f"{repr(v)[:20]}..."
            raise fail(key, f"{need} (got {shown})")
        out[key] = v
    return out


def settings_for(name: str, hand: HandConfig | None = None, **overrides: Any) -> ControllerSettings:
    """The settings a run of controller ``name`` starts from: ``ControllerSettings``' defaults
    with the controller's own choices (``CONTROLLER_CHOICES``), the hand file's
    ``[controllers.NAME]`` choices, then ``overrides``."""
    if name not in CONTROLLER_NAMES:
        raise unknown_controller(name)
    own: dict[str, Any] = {}
    if hand is not None:
        for table, _ in hand.controller_choices:  # a misspelt table would be ignored without a word
            if table not in CONTROLLER_NAMES:
                raise ConfigError(
                    hand.path, f"controllers.{table}", f"a controller's name, one of {', '.join(CONTROLLER_NAMES)}"
                )
        own = checked_settings(hand.choices_of(name), hand.path, f"controllers.{name}")
        if "controller" in own:
            raise ConfigError(hand.path, f"controllers.{name}.controller", "not a setting here (the table's name is)")
    return dataclasses.replace(ControllerSettings(controller=name), **{**CONTROLLER_CHOICES[name], **own, **overrides})
