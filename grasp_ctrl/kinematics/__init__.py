"""Forward kinematics, Jacobians and damped least-squares IK from the hand file."""

from grasp_ctrl.kinematics.chain import FingerChain, HandKinematics
from grasp_ctrl.kinematics.transforms import axis_angle, rpy_matrix, transform

__all__ = ["FingerChain", "HandKinematics", "axis_angle", "rpy_matrix", "transform"]
