"""The paper controller's settings (controller/machine.py): gains, speeds and time-outs of its
state machine, with its own defaults. Every controller is a ``GraspController`` subclass, so every
controller's settings class extends this one (grip_load's: controller/grip_load_settings.py)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from grasp_ctrl.config.objects import GRIP_TARGET_MODES
from grasp_ctrl.controller.settings import ControllerSettings

#: How the paper's controller reads "increase the force on all the fingertips to tau ... then
#: raise the arm" (docs/controller.md, decision record 0017):
#: regulate: every pad is regulated toward its target in ramp, hold, lift and lower;
#: push_then_hold: the ramp only pushes each pad forward, ends once every pad has reached its
#: target, and the fingers then hold their goals while the arm lifts and lowers.
RAMP_MODES: tuple[str, ...] = ("regulate", "push_then_hold")


@dataclass(frozen=True)
class PaperSettings(ControllerSettings):
    """The paper's controller squeezes along the closing vectors toward tau on every fingertip."""

    controller: ClassVar[str] = "paper"
    CHOICES: ClassVar[dict[str, tuple[str, ...]]] = {"grip_targets": GRIP_TARGET_MODES, "ramp_mode": RAMP_MODES}
    # no slow zone, no overshoot, no retreat, no weight margin
    ZERO_ALLOWED: ClassVar[tuple[str, ...]] = (
        "lower_overshoot_m",
        "lower_slow_zone_m",
        "retreat_m",
        "grip_weight_margin",
    )

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
    ramp_timeout_s: float = 6.0
    hold_gain_m_s_per_n: float = 0.005  # grip force controller during lift/hold/lower
    hold_max_speed_m_s: float = 0.004
    reach_tolerance_m: float = 0.001
    reach_timeout_s: float = 10.0
    lift_speed_m_s: float = 0.04
    lower_speed_m_s: float = 0.015
    lower_overshoot_m: float = 0.03  # how far below the grasp height lowering may go
    lower_slow_zone_m: float = 0.015  # approach the support surface slowly from this high
    lower_slow_speed_m_s: float = 0.005
    grip_lost_fraction: float = 0.3  # grip below this fraction of tau = slipping
    contact_lost_s: float = 0.05
    open_s: float = 0.4  # time to open the fingers on release
    release_back_off_m_s: float = 0.05  # release: pads back off along their closing vectors
    retreat_m: float = 0.05
    preshape: bool = True  # reach in a posture whose pads face the object, close along
    preshape_standoff_m: float = 0.01  #   its surface normals (kinematics/preshape.py), this far off
    stiffness_aware_squeeze: bool = False  # move the pads' goals so the joints' springs push along the
    #   closing vectors (controller/motion.py); off: along the closing vectors, and the LEAP thumb's
    #   pad slides down a box's face as it squeezes, pressing the box into the table (docs/controller.md)
    grip_targets: str = "equal"  # tau each; "force_closure": per-fingertip targets whose closing forces
    #   cancel (the thumb pushes back what the index and middle push), the smallest tau
    #   (controller/grip_targets.py)
    grip_weight_margin: float = 0.0  # > 0: scale the targets so mu x their sum >= this x the object's
    #   weight (objects.toml mass_kg); 0: tau_n as tuned
    ramp_mode: str = "regulate"  # one of RAMP_MODES (above)
    low_confidence_slowdown: bool = False  # slow the ramp when the policy's variance is high
    variance_scale_n2: float = 0.05  # variance at which the ramp runs at half speed
