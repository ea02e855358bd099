"""Each joint's position stiffness (N m/rad) from the hand file's servo model and gains.

A Dynamixel in (current-based) position mode is a spring about its goal: the
squeeze's force on an object is that spring's torque, so the controller needs
each joint's stiffness to turn a wanted fingertip force into goal changes
(``kinematics/stiffness_squeeze.py``, the stiffness-aware squeeze; docs/mujoco.md).

The servo's facts come from the model table (config/servos.py) by the hand file's
``[dynamixel] model``. For the LEAP Hand's XC330-M288-T (stall torque 0.93 N m at 1.8 A):
with the LEAP API's P = 600, D = 200, kp = 3.2 N m/rad (the LEAP simulation and MuJoCo
Menagerie use 3.0), kv = 0.0086 N m s/rad (Menagerie: 0.01).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasp_ctrl.config.actuation import pd_gains
from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.servos import ServoModel, servo_model

#: The LEAP Hand's servo: the default where no hand file names one.
DEFAULT_MODEL = "XC330-M288-T"
_DEFAULT = servo_model(DEFAULT_MODEL)


def servo_kp_nm_per_rad(p_gain: float, model: ServoModel = _DEFAULT) -> float:
    return model.kp_nm_per_rad(p_gain)


def servo_kv_nm_s_per_rad(d_gain: float, model: ServoModel = _DEFAULT) -> float:
    return model.kv_nm_s_per_rad(d_gain)


@dataclass(frozen=True)
class JointStiffness:
    """Per joint (hand-file order) position stiffness, or None with the reason it is unknown."""

    kp_nm_per_rad: np.ndarray | None
    reason: str

    @property
    def compliance_rad_per_nm(self) -> np.ndarray:
        """1 / kp per joint; empty when the stiffness is unknown (the kernels' "no stiffness")."""
        if self.kp_nm_per_rad is None:
            return np.zeros(0)
        return 1.0 / self.kp_nm_per_rad


def joint_stiffness(hand: HandConfig) -> JointStiffness:
    """The joints' stiffness: ``[dynamixel] position_p_gain`` x each joint's ``gain_scale`` through
    the servo model, or a torque-controlled hand's ``kp_nm_per_rad`` (config/actuation.py)."""
    gains = pd_gains(hand)
    return JointStiffness(gains.kp_nm_per_rad, gains.reason)
