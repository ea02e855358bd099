"""The Allegro v4's CAN frames (hardware/allegro/protocol.py) against SimLab's driver.

The expected numbers are written here with their source, simlabrobotics/allegro_hand_ros_v4
(BSD-3): candef.h (ids), pcan.cpp (frame layouts, the id shift), AllegroHandDrv.cpp (replies,
scaling). No python-can needed: the frames are this project's own type.
"""

from __future__ import annotations

import math
import shutil
import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.errors import ConfigError
from grasp_ctrl.hardware.allegro import protocol as pr
from grasp_ctrl.hardware.allegro.protocol import CanFrame, JointMap, ProtocolError

ALLEGRO = Path(__file__).resolve().parents[2] / "hand_configs" / "allegro_hand.toml"


@pytest.fixture(scope="module")
def allegro():
    return load_hand(ALLEGRO)


def test_ids_are_the_drivers():
    # candef.h
    assert (pr.CMD_SYSTEM_ON, pr.CMD_SYSTEM_OFF, pr.CMD_SET_TORQUE, pr.CMD_SET_PERIOD) == (0x40, 0x41, 0x60, 0x81)
    assert (pr.CMD_SET_POSE, pr.CMD_CONFIG) == (0xE0, 0x68)
    assert (pr.RTR_HAND_INFO, pr.RTR_SERIAL, pr.RTR_FINGER_POSE, pr.RTR_IMU, pr.RTR_TEMPERATURE) == (
        0x80,
        0x88,
        0x20,
        0x30,
        0x38,
    )
    # pcan.cpp canSendMsg: CanMsg.ID = (id << 2) | CAN_ID; canReadMsg: (ID & 0xfffffffc) >> 2
    assert pr.wire_id(0x60, 0) == 0x180 and pr.wire_id(0x63, 2) == 0x18E
    f = CanFrame(0x18E)
    assert f.command == 0x63 and f.device_id == 2
    # the highest id the driver uses still fits 11 bits
    assert pr.wire_id(0xE3, 3) <= 0x7FF
    with pytest.raises(ValueError):
        pr.wire_id(0x40, 4)


def test_torque_frame_layout():
    # pcan.cpp command_set_torque: 4 x int16, low byte first, id ID_CMD_SET_TORQUE_1 + findex, length 8
    f = pr.set_torque(2, [1, -1, 675, -32768])
    assert f.arbitration_id == (0x62 << 2) and not f.is_remote
    assert f.data == bytes([0x01, 0x00, 0xFF, 0xFF, 0xA3, 0x02, 0x00, 0x80])
    assert pr.decode_torque(f) == (2, (1, -1, 675, -32768))
    with pytest.raises(ValueError):
        pr.set_torque(0, [40000, 0, 0, 0])
    with pytest.raises(ValueError):
        pr.set_torque(4, [0, 0, 0, 0])


def test_period_system_and_request_frames():
    # pcan.cpp command_set_period: 3 x int16 LE (position, IMU, temperature ms), length 6
    f = pr.set_period(3, 0, 0)
    assert f.arbitration_id == 0x81 << 2 and f.data == bytes([3, 0, 0, 0, 0, 0])
    assert pr.decode_period(f) == (3, 0, 0)
    # command_servo_on / off: no data
    assert pr.system_on().arbitration_id == 0x100 and pr.system_on().data == b""
    assert pr.system_off(1).arbitration_id == 0x105
    # canSentRTR: remote frames, length 0
    r = pr.request_finger_pose(3)
    assert r.is_remote and r.data == b"" and r.arbitration_id == 0x23 << 2
    assert pr.request_temperature(1).arbitration_id == 0x39 << 2


def test_position_reply_scaling():
    # AllegroHandDrv.cpp _parseMessage: (short)(d0 | d1 << 8) * (333.3 / 65536) * (pi / 180)
    raw = struct.pack("<4h", 1000, -1000, 32767, 0)
    reply = pr.decode_reply(CanFrame(0x21 << 2, raw))
    assert reply == pr.FingerPose(1, (1000, -1000, 32767, 0))
    assert pr.RAD_PER_COUNT == pytest.approx(333.3 / 65536.0 * math.pi / 180.0)
    assert 1000 * pr.RAD_PER_COUNT == pytest.approx(math.radians(5.0858), rel=1e-4)


def test_hand_info_serial_temperature_replies():
    # _parseMessage ID_RTR_HAND_INFO: hw version d1 d0, fw d3 d2, type d4 (0 right), temp d5, status d6
    data = bytes([0x04, 0x00, 0x10, 0x02, 0x00, 41, 0x03, 0x00])
    info = pr.decode_reply(CanFrame(0x80 << 2, data))
    assert isinstance(info, pr.HandInfo)
    assert (info.hardware_version, info.firmware_version, info.right_hand, info.temperature_c) == (4, 0x0210, True, 41)
    assert info.servo_on and info.high_temperature and not info.internal_comm_fault
    assert info.faults() == ["high-temperature fault"]
    assert pr.decode_reply(pr.hand_info(info)) == info
    # ID_RTR_SERIAL: eight characters
    assert pr.decode_reply(CanFrame(0x88 << 2, b"040A080R")) == "040A080R"
    # ID_RTR_TEMPERATURE_n: int32 LE degC
    t = pr.decode_reply(CanFrame(0x3A << 2, struct.pack("<i", 55)))
    assert t == pr.Temperature(2, 55)


def test_joint_map_of_the_hand_file(allegro):
    m = JointMap.from_hand(allegro)
    # servo_id = finger x 4 + joint (the driver's eJointName order)
    assert m.finger.tolist() == [i // 4 for i in range(16)] and m.slot.tolist() == [i % 4 for i in range(16)]
    assert m.pwm_per_nm == 1200.0 and m.pwm_limit == 1200.0
    q = np.linspace(-0.4, 1.2, 16)
    back = m.joints_rad(m.counts(q))
    assert np.all(np.abs(back - q) <= pr.RAD_PER_COUNT / 2 + 1e-12)
    # torque -> PWM: x 1200, truncated toward zero (the driver's (short) cast), clamped to the joint's limit
    tau = np.zeros(16)
    tau[0], tau[1], tau[2] = 0.1, -0.0008, 5.0
    pwm = m.pwm(tau)
    assert pwm[0, 0] == 120 and pwm[0, 1] == 0 and pwm[0, 2] == int(0.375 * 1200)
    assert m.torque_nm(pwm)[2] == pytest.approx(0.375)


def test_sign_and_offset_apply_to_positions_and_torques(allegro):
    m = JointMap.from_hand(allegro)
    m = JointMap(m.finger, m.slot, m.offset_rad + 0.1, -m.sign, m.pwm_per_nm, m.pwm_limit, m.torque_limit_nm)
    counts = np.zeros((4, 4), dtype=np.int64)
    counts[0, 0] = 2000
    assert m.joints_rad(counts)[0] == pytest.approx(-(2000 * pr.RAD_PER_COUNT - 0.1))
    tau = np.zeros(16)
    tau[0] = 0.1
    assert m.pwm(tau)[0, 0] == -120


def test_a_torque_limit_beyond_the_pwm_range_is_refused(tmp_path, allegro):
    path = tmp_path / "allegro.toml"
    shutil.copy(ALLEGRO, path)
    text = path.read_text().replace("pwm_limit = 1200.0", "pwm_limit = 600.0")
    path.write_text(text)
    with pytest.raises(ConfigError, match=r"torque_limit_nm: at most 0.5 N m \(\[torque_pd\] pwm_limit 600"):
        load_hand(path)


frames = st.builds(
    CanFrame,
    arbitration_id=st.integers(0, 0x1FFFFFFF),
    data=st.binary(max_size=8),
    is_remote=st.booleans(),
    is_extended=st.booleans(),
    is_error=st.booleans(),
)


@settings(max_examples=400, deadline=None)
@given(frames)
def test_untrusted_frames_decode_or_raise_protocol_error(frame):
    try:
        reply = pr.decode_reply(frame)
    except ProtocolError:
        return
    assert not frame.is_remote and not frame.is_error and not frame.is_extended
    if isinstance(reply, pr.FingerPose):
        assert 0 <= reply.finger < 4 and all(-32768 <= c <= 32767 for c in reply.counts)
    elif isinstance(reply, str):
        assert len(reply) == 8 and reply.isprintable()


@settings(max_examples=200, deadline=None)
@given(frames)
def test_untrusted_torque_frames_decode_or_raise_protocol_error(frame):
    try:
        finger, pwm = pr.decode_torque(frame)
    except ProtocolError:
        return
    assert 0 <= finger < 4 and len(pwm) == 4


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.floats(allow_nan=True, allow_infinity=True, width=64),
        min_size=16,
        max_size=16,
    )
)
def test_no_torque_outside_the_limits_whatever_is_asked(allegro, tau):
    m = JointMap.from_hand(allegro)
    pwm = m.pwm(np.array(tau))
    limit_pwm = m.torque_limit_nm * m.pwm_per_nm
    assert np.all(np.abs(pwm[m.finger, m.slot]) <= limit_pwm + 1e-9)
    assert np.all(np.abs(pwm) <= m.pwm_limit)
    for f in m.torque_frames(np.array(tau)):
        _, values = pr.decode_torque(f)
        assert all(abs(v) <= m.pwm_limit for v in values)
