"""Configuration files: hands and object profiles (TOML, validated on load)."""

from grasp_ctrl.config.hand import (
    ArmConfig,
    DynamixelConfig,
    FingerConfig,
    HandConfig,
    JointConfig,
    TactileConfig,
    load_hand,
)
from grasp_ctrl.config.objects import ObjectProfile, load_objects

__all__ = [
    "ArmConfig",
    "DynamixelConfig",
    "FingerConfig",
    "HandConfig",
    "JointConfig",
    "ObjectProfile",
    "TactileConfig",
    "load_hand",
    "load_objects",
]
