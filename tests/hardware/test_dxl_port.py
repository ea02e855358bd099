"""Port setup: USB latency timer through sysfs, and the short packet timeout."""

from __future__ import annotations

from pathlib import Path

import pytest

from grasp_ctrl.hardware.dynamixel.port import ShortTimeoutPortHandler, set_low_latency


def test_latency_timer_is_set_where_the_port_has_one(tmp_path: Path) -> None:
    timer = tmp_path / "ttyUSB7" / "latency_timer"
    timer.parent.mkdir()
    timer.write_text("16\n")
    assert "16 -> 1" in set_low_latency("/dev/ttyUSB7", 1, sysfs_root=str(tmp_path))
    assert timer.read_text().strip() == "1"
    assert set_low_latency("/dev/ttyUSB7", 1, sysfs_root=str(tmp_path)) == "latency timer 1 ms"


def test_ports_without_a_latency_timer_are_skipped(tmp_path: Path) -> None:
    assert "skipped" in set_low_latency("/dev/pts/3", 1, sysfs_root=str(tmp_path))


def test_unwritable_latency_timer_says_what_to_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    timer = tmp_path / "ttyUSB0" / "latency_timer"
    timer.parent.mkdir()
    timer.write_text("16\n")

    def refuse(self: Path, *args: object, **kwargs: object) -> int:
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(Path, "write_text", refuse)  # what a non-root user meets in sysfs
    msg = set_low_latency("/dev/ttyUSB0", 1, sysfs_root=str(tmp_path))
    assert "is 16 ms" in msg and "sudo tee" in msg and str(timer) in msg


def test_packet_timeout_is_transmission_time_plus_margin() -> None:
    port = ShortTimeoutPortHandler("/dev/null", margin_ms=8.0)
    port.tx_time_per_byte = (1000.0 / 4_000_000) * 10.0
    port.setPacketTimeout(336)  # a 16-servo fast sync read of 10 bytes each
    assert port.packet_timeout == pytest.approx(336 * 0.0025 + 8.0)
