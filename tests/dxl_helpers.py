"""Shared setup for the Dynamixel backend tests (the emulator plus the LEAP Hand file)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from grasp_ctrl.config.hand import HandConfig, load_hand

REPO = Path(__file__).resolve().parents[1]
LEAP = REPO / "hand_configs" / "leap_hand.toml"


def leap(on_fault: str = "open", **dxl: object) -> HandConfig:
    hand = load_hand(LEAP)
    hand = dataclasses.replace(hand, safety=dataclasses.replace(hand.safety, on_fault=on_fault))
    if dxl:
        hand = dataclasses.replace(hand, dynamixel=dataclasses.replace(hand.dynamixel, **dxl))
    return hand
