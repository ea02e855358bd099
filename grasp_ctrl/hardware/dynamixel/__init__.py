"""Dynamixel (Protocol 2.0, X-series) hand backend on dynamixel_sdk."""

from grasp_ctrl.hardware.dynamixel.hand import DynamixelHand

__all__ = ["DynamixelHand"]
