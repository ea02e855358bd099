"""The servo-chain emulator spoken to by the real dynamixel_sdk over a pty."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from dynamixel_sdk import (
    COMM_RX_CORRUPT,
    COMM_RX_TIMEOUT,
    COMM_SUCCESS,
    GroupSyncRead,
    GroupSyncWrite,
    PacketHandler,
    PortHandler,
)

from grasp_ctrl.emulators.dxl_chain import DynamixelChainEmulator, parse_ids
from grasp_ctrl.emulators.dxl_servo import HW_OVERLOAD


@pytest.fixture()
def bus() -> Iterator[tuple[DynamixelChainEmulator, PortHandler, PacketHandler]]:
    emu = DynamixelChainEmulator([1, 2, 3]).start()
    port = PortHandler(emu.port)
    assert port.openPort() and port.setBaudRate(4_000_000)
    try:
        yield emu, port, PacketHandler(2.0)
    finally:
        port.closePort()
        emu.stop()


def test_ping_read_write(bus) -> None:
    emu, port, ph = bus
    assert ph.ping(port, 2) == (1240, COMM_SUCCESS, 0)
    assert ph.ping(port, 9)[1] == COMM_RX_TIMEOUT
    assert ph.write4ByteTxRx(port, 2, 116, 3000) == (COMM_SUCCESS, 0)
    assert ph.read4ByteTxRx(port, 2, 116) == (3000, COMM_SUCCESS, 0)
    assert emu.servo(2).goal_history == [3000]


def test_eeprom_is_locked_while_torque_is_on(bus) -> None:
    emu, port, ph = bus
    assert ph.write1ByteTxRx(port, 1, 11, 5) == (COMM_SUCCESS, 0)
    assert ph.write1ByteTxRx(port, 1, 64, 1) == (COMM_SUCCESS, 0)
    assert ph.write1ByteTxRx(port, 1, 11, 3) == (COMM_SUCCESS, 7)  # access error
    assert emu.servo(1).get((11, 1)) == 5


def test_sync_write_then_fast_and_plain_sync_read(bus) -> None:
    emu, port, ph = bus
    w = GroupSyncWrite(port, ph, 116, 4)
    for i, goal in ((1, 100), (2, 200), (3, 300)):
        w.addParam(i, list(goal.to_bytes(4, "little")))
    assert w.txPacket() == COMM_SUCCESS
    r = GroupSyncRead(port, ph, 116, 4)
    for i in (1, 2, 3):
        r.addParam(i)
    assert r.txRxPacket() == COMM_SUCCESS
    assert [r.getData(i, 116, 4) for i in (1, 2, 3)] == [100, 200, 300]
    if hasattr(r, "fastSyncRead"):
        assert r.fastSyncRead() == COMM_SUCCESS
        assert [r.getData(i, 116, 4) for i in (1, 2, 3)] == [100, 200, 300]
    assert emu.sync_write_count == 1


def test_position_tracking_respects_the_current_limit(bus) -> None:
    import time

    emu, port, ph = bus
    ph.write1ByteTxRx(port, 1, 11, 5)
    ph.write2ByteTxRx(port, 1, 38, 50)  # 50 mA current limit
    ph.write1ByteTxRx(port, 1, 64, 1)
    ph.write4ByteTxRx(port, 1, 116, 2448)
    time.sleep(0.05)
    cur, res, _ = ph.read2ByteTxRx(port, 1, 126)
    assert res == COMM_SUCCESS and 0 < cur <= 50
    time.sleep(0.6)
    pos, _, _ = ph.read4ByteTxRx(port, 1, 132)
    assert abs(pos - 2448) <= 1


def test_faults_corrupt_drop_and_hardware_error(bus) -> None:
    emu, port, ph = bus
    emu.corrupt_next(1, dxl_id=3)
    assert ph.ping(port, 3)[1] == COMM_RX_CORRUPT
    assert ph.ping(port, 3)[1] == COMM_SUCCESS
    emu.drop_next(1)
    assert ph.ping(port, 1)[1] == COMM_RX_TIMEOUT
    emu.inject_hardware_error(2, HW_OVERLOAD)
    model, res, err = ph.ping(port, 2)
    assert res == COMM_SUCCESS and err & 0x80  # alert bit in every status packet
    assert ph.read1ByteTxRx(port, 2, 70)[0] == HW_OVERLOAD
    assert ph.write1ByteTxRx(port, 2, 64, 1) == (COMM_SUCCESS, 0x81)  # refused until reboot
    assert ph.reboot(port, 2) == (COMM_SUCCESS, 0x80)
    assert ph.read1ByteTxRx(port, 2, 70) == (0, COMM_SUCCESS, 0)


def test_blocked_joint_overloads_and_drops_torque(bus) -> None:
    import time

    emu, port, ph = bus
    emu.servo(1).motor.overload_after_s = 0.1
    emu.block_joint(1, 2100)
    ph.write1ByteTxRx(port, 1, 64, 1)
    ph.write4ByteTxRx(port, 1, 116, 2500)
    deadline = time.monotonic() + 2.0
    while time.monotonic() < deadline and ph.read1ByteTxRx(port, 1, 70)[0] == 0:
        time.sleep(0.02)
    assert ph.read1ByteTxRx(port, 1, 70)[0] == HW_OVERLOAD
    assert ph.read1ByteTxRx(port, 1, 64)[0] == 0
    assert ph.read4ByteTxRx(port, 1, 132)[0] == 2100


def test_parse_ids() -> None:
    assert parse_ids("0-3,8") == [0, 1, 2, 3, 8]


def test_external_physics_hook(bus) -> None:
    emu, port, ph = bus
    emu.external_physics = True
    ph.write1ByteTxRx(port, 1, 64, 1)
    ph.write4ByteTxRx(port, 1, 116, 2500)
    assert emu.goals()[1] == (2500, True)
    emu.set_present(1, 2222.0, velocity_counts_s=0.0, current_raw=-30.0)
    assert ph.read4ByteTxRx(port, 1, 132)[0] == 2222
    cur = ph.read2ByteTxRx(port, 1, 126)[0]
    assert cur - 65536 == -30
