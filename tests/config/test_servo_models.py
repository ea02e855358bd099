"""Servo facts by model (config/servos.py): one table for the bus, the controller and the worlds."""

from __future__ import annotations

import math

import pytest

from grasp_ctrl.config.servos import MODELS, servo_model
from grasp_ctrl.controller.joint_stiffness import joint_stiffness
from grasp_ctrl.errors import ConfigError, UsageError
from grasp_ctrl.hardware.dynamixel import control_table


def test_the_leap_servo_facts_come_from_its_data_sheet():
    m = servo_model("XC330-M288-T")
    assert (m.stall_torque_nm, m.stall_current_a, m.no_load_speed_rpm) == (0.93, 1.8, 103.0)
    # kp = (P/128) / 885 per pulse x 4096 / (2 pi) pulses per rad x 0.93 N m
    assert m.kp_nm_per_rad(600) == pytest.approx(600 / 128 / 885 * 4096 / (2 * math.pi) * 0.93)
    assert m.kp_nm_per_rad(600) == pytest.approx(3.21, abs=0.01)
    assert m.torque_per_amp_nm == pytest.approx(0.93 / 1.8)


def test_the_bus_reads_the_same_table():
    assert control_table.MODELS is MODELS
    assert control_table.model_by_number(1240).name == "XC330-M288-T"


def test_the_stiffness_follows_the_hand_files_model(hand):
    ks = joint_stiffness(hand)
    assert ks.kp_nm_per_rad is not None
    assert ks.kp_nm_per_rad.max() == pytest.approx(
        servo_model(hand.dynamixel.model).kp_nm_per_rad(hand.dynamixel.position_p_gain)
        * max(j.gain_scale for j in hand.joints)
    )


def test_a_model_without_facts_has_no_stiffness_and_says_why(hand):
    import dataclasses

    other = dataclasses.replace(hand, dynamixel=dataclasses.replace(hand.dynamixel, model="XM430-W350-T"))
    ks = joint_stiffness(other)
    assert ks.kp_nm_per_rad is None and "XM430-W350-T" in ks.reason
    with pytest.raises(UsageError, match="unknown"):
        servo_model("XC999")


def test_an_unknown_model_in_the_hand_file_is_one_line(tmp_path):
    from grasp_ctrl.config import load_hand
    from grasp_ctrl.files.paths import default_hand_file

    text = default_hand_file().read_text().replace('model = "XC330-M288-T"', 'model = "XC331"', 1)
    path = tmp_path / "hand.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match="model"):
        load_hand(path)
