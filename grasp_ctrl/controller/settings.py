"""Controller gains, speeds and time-outs (hand-independent defaults)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ControllerSettings:
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
    stiffness_aware_squeeze: bool = False  # True: move the pads' goals so the joints' springs push along the
    #   closing vectors (controller/motion.py); off: on MuJoCo it
    #   does not help yet (docs/mujoco.md)
    grip_targets: str = "equal"  # "force_closure": per-fingertip targets whose closing forces cancel,
    #   the smallest tau (controller/grip_targets.py)
    grip_weight_margin: float = 0.0  # > 0: scale the targets so mu x their sum >= this x the object's
    #   weight (objects.toml mass_kg); 0: tau_n as tuned
    low_confidence_slowdown: bool = False  # slow the ramp when the policy's variance is high
    variance_scale_n2: float = 0.05  # variance at which the ramp runs at half speed
