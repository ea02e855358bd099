"""``hand-check`` against the emulator's pty."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.emulators.dxl_chain import DynamixelChainEmulator
from grasp_ctrl.emulators.dxl_servo import HW_OVERLOAD
from tests.dxl_helpers import leap, leap_file


@pytest.fixture()
def emu() -> Iterator[DynamixelChainEmulator]:
    with DynamixelChainEmulator.for_hand(leap()) as e:
        yield e


def test_all_good_and_move(emu: DynamixelChainEmulator, capsys: pytest.CaptureFixture[str], tmp_path) -> None:
    assert main(["hand-check", "--hand", str(leap_file(tmp_path)), "--port", emu.port, "--move", "--step", "0.05"]) == 0
    out = capsys.readouterr().out
    assert "16/16 servos answered" in out and "hand-check: OK" in out
    assert out.count(" ok\n") >= 32  # state table and move test, every joint
    assert not any(s.torque_on for s in emu.servos.values())  # torque off afterwards
    assert all(len(s.goal_history) > 2 for s in emu.servos.values())


def test_missing_servo_and_hardware_error(
    emu: DynamixelChainEmulator, capsys: pytest.CaptureFixture[str], tmp_path
) -> None:
    emu.set_missing(6)
    emu.inject_hardware_error(13, HW_OVERLOAD)
    assert main(["hand-check", "--hand", str(leap_file(tmp_path)), "--port", emu.port, "--move"]) == 1
    cap = capsys.readouterr()
    assert "middle_pip       6" in cap.out and "MISSING" in cap.out
    assert "overload" in cap.out
    assert "middle_pip (id 6): no reply" in cap.err
    assert "thumb_axl (id 13): HARDWARE ERROR" in cap.err
    assert not any(len(s.goal_history) for s in emu.servos.values())  # nothing moved


def test_recover_reboots_a_faulted_servo(
    emu: DynamixelChainEmulator, capsys: pytest.CaptureFixture[str], tmp_path
) -> None:
    emu.inject_hardware_error(13, HW_OVERLOAD)
    assert main(["hand-check", "--hand", str(leap_file(tmp_path)), "--port", emu.port, "--recover"]) == 0
    assert "rebooted (was overload)" in capsys.readouterr().out
    assert emu.servo(13).get((70, 1)) == 0


def test_bad_port_is_one_line(capsys: pytest.CaptureFixture[str], tmp_path) -> None:
    assert main(["hand-check", "--hand", str(leap_file(tmp_path)), "--port", "/dev/does-not-exist"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot open Dynamixel port /dev/does-not-exist" in err
