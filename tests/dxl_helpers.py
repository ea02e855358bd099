"""Shared setup for the Dynamixel backend tests (the emulator plus the LEAP Hand file)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from grasp_ctrl.config.hand import HandConfig, load_hand

REPO = Path(__file__).resolve().parents[1]
LEAP = REPO / "hand_configs" / "leap_hand.toml"


def leap(on_fault: str = "open", **dxl: object) -> HandConfig:
    """The LEAP Hand file. The emulator shares a busy 2-core host with the tests, so
    its reply deadline is 40 ms here unless a test asks for the file's short one."""
    dxl = {"packet_timeout_ms": 40.0, **dxl}
    hand = load_hand(LEAP)
    hand = dataclasses.replace(hand, safety=dataclasses.replace(hand.safety, on_fault=on_fault))
    if dxl:
        hand = dataclasses.replace(hand, dynamixel=dataclasses.replace(hand.dynamixel, **dxl))
    return hand


def leap_file(tmp_path: Path) -> Path:
    """A copy of the LEAP Hand file with the test reply deadline (see ``leap``)."""
    text = LEAP.read_text()
    assert "packet_timeout_ms = 8.0" in text
    path = tmp_path / "leap_hand.toml"
    path.write_text(text.replace("packet_timeout_ms = 8.0", "packet_timeout_ms = 40.0", 1))
    return path
