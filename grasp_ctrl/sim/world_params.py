"""The simulated worlds' own parameters (servo model, skin, variation draws, the BioTac model):
what a trial passes to either world, in a module of its own so that a MuJoCo run does not import
the mock world to name them."""

from __future__ import annotations

from dataclasses import dataclass, field

from grasp_ctrl.sim.biotac.model import BioTacParams
from grasp_ctrl.sim.variation import NOMINAL, Variation


@dataclass(frozen=True)
class WorldParams:
    servo_time_constant_s: float = 0.03
    servo_stiffness_nm_per_rad: float = 10.0
    servo_max_speed_rad_s: float = 6.0
    torque_per_amp_nm: float | None = None  # None: the hand file's servo model's (0.517 for the XC330-M288-T)
    tangential_stiffness_n_per_m: float = 400.0
    # The placement, mass, friction and stiffness draws' half-widths (sim/variation.py); the
    # mock world has no yaw (its objects stay axis-aligned) and no joint offsets.
    variation: Variation = NOMINAL
    start_clearance_m: float = 0.05  # palm starts this far above the reach pose
    # Contact on the skin point facing the object (cap or pad), as on a real fingertip
    # and in MuJoCo; False puts it at the pad centre whatever the tilt (a simpler model
    # whose force can leave the friction cone of the skin there: docs/mock_world.md).
    skin_contact: bool = True
    biotac: BioTacParams = field(default_factory=BioTacParams)
