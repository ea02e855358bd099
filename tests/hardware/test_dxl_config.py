"""Hand-file keys for the Dynamixel side and the arm."""

from __future__ import annotations

from pathlib import Path

import pytest

from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.errors import ConfigError
from tests.dxl_helpers import LEAP


def with_dynamixel_keys(tmp_path: Path, extra: str) -> Path:
    """The LEAP file with ``extra`` lines in [dynamixel] (replacing keys it already has)."""
    lines = LEAP.read_text().splitlines()
    for new in extra.splitlines():
        key = new.split("=")[0].strip()
        lines = [ln for ln in lines if ln.split("=")[0].strip() != key]
    at = lines.index("[dynamixel]") + 1
    text = "\n".join(lines[:at] + extra.splitlines() + lines[at:]) + "\n"
    path = tmp_path / "h.toml"
    path.write_text(text)
    return path


def test_shipped_leap_values() -> None:
    d = load_hand(LEAP).dynamixel
    assert d.fast_sync_read and d.latency_timer_ms == 1 and d.packet_timeout_ms == 8.0
    assert (d.position_p_gain, d.position_i_gain, d.position_d_gain) == (600, 0, 200)


def test_gains_parse(tmp_path: Path) -> None:
    path = with_dynamixel_keys(tmp_path, "position_p_gain = 700\nposition_d_gain = 100")
    path.write_text(path.read_text().replace("position_i_gain = 0 ", "# "))
    d = load_hand(path).dynamixel
    assert (d.position_p_gain, d.position_i_gain, d.position_d_gain) == (700, None, 100)


@pytest.mark.parametrize(
    "extra, key",
    [
        ('fast_sync_read = "yes"', "dynamixel.fast_sync_read"),
        ("latency_timer_ms = 0", "dynamixel.latency_timer_ms"),
        ("position_p_gain = -1", "dynamixel.position_p_gain"),
        ("fast_sync = true", "dynamixel.fast_sync"),
    ],
)
def test_bad_values_name_the_key(tmp_path: Path, extra: str, key: str) -> None:
    with pytest.raises(ConfigError) as info:
        load_hand(with_dynamixel_keys(tmp_path, extra))
    assert info.value.key == key
