"""The hand file's actuator section: which kind drives the joints, and a one-line error naming the
file and key for a section that is missing or contradicts the kind."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.config.actuation import pd_gains, torque_limits_nm, torque_per_amp_nm
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.errors import ConfigError
from grasp_ctrl.files.paths import hand_configs_dir

ALLEGRO = hand_configs_dir() / "allegro_hand.toml"
LEAP = hand_configs_dir() / "leap_hand.toml"


def _variant(tmp_path: Path, source: Path, edit) -> Path:  # type: ignore[no-untyped-def]
    out = tmp_path / source.name
    out.write_text(edit(source.read_text()))
    return out


def _error(path: Path) -> str:
    with pytest.raises(ConfigError) as info:
        load_hand(path)
    message = str(info.value)
    assert "\n" not in message
    assert str(path) in message
    return message


def test_the_leap_is_a_dynamixel_hand_with_its_servos_facts() -> None:
    leap = load_hand(LEAP)
    assert leap.actuator == "dynamixel" and leap.torque_pd is None
    per_amp = torque_per_amp_nm(leap)
    assert per_amp == pytest.approx(0.93 / 1.8)
    currents = np.array([j.current_limit_a for j in leap.joints])
    assert np.allclose(torque_limits_nm(leap), currents * per_amp)
    gains = pd_gains(leap)
    assert gains.kp_nm_per_rad is not None and gains.kp_nm_per_rad.shape == (16,)


def test_a_torque_hand_without_its_section_names_the_key(tmp_path: Path) -> None:
    path = _variant(tmp_path, ALLEGRO, lambda t: re.sub(r"\[torque_pd\]\n(.*\n)*?\n", "", t, count=1))
    assert "torque_pd" in _error(path)


def test_a_torque_joint_without_its_gain_names_the_joint(tmp_path: Path) -> None:
    path = _variant(tmp_path, ALLEGRO, lambda t: t.replace("kp_nm_per_rad = 3.333333\n", "", 1))
    assert "fingers[0].joints[0].kp_nm_per_rad" in _error(path)


def test_a_dynamixel_table_on_a_torque_hand_is_a_contradiction(tmp_path: Path) -> None:
    path = _variant(tmp_path, ALLEGRO, lambda t: t + '\n[dynamixel]\nport = "/dev/ttyUSB0"\n')
    assert "dynamixel" in _error(path)


def test_a_current_limit_on_a_torque_joint_is_a_contradiction(tmp_path: Path) -> None:
    path = _variant(
        tmp_path,
        ALLEGRO,
        lambda t: t.replace("kp_nm_per_rad = 3.333333\n", "kp_nm_per_rad = 3.333333\ncurrent_limit_a = 0.5\n", 1),
    )
    assert "fingers[0].joints[0].current_limit_a" in _error(path)


def test_torque_keys_on_a_dynamixel_hand_are_a_contradiction(tmp_path: Path) -> None:
    path = _variant(
        tmp_path,
        LEAP,
        lambda t: t.replace("current_limit_a = 0.55\n", "current_limit_a = 0.55\ntorque_limit_nm = 0.3\n", 1),
    )
    assert "torque_limit_nm" in _error(path)


def test_a_torque_pd_table_on_a_dynamixel_hand_is_a_contradiction(tmp_path: Path) -> None:
    path = _variant(tmp_path, LEAP, lambda t: t + '\n[torque_pd]\nsource = "x"\n')
    assert "torque_pd" in _error(path)


def test_an_unknown_actuator_kind_lists_the_kinds(tmp_path: Path) -> None:
    path = _variant(tmp_path, ALLEGRO, lambda t: t.replace('actuator = "torque_pd"', 'actuator = "hydraulic"'))
    message = _error(path)
    assert "dynamixel" in message and "torque_pd" in message


def test_a_collision_box_of_an_unknown_joint_is_refused(tmp_path: Path) -> None:
    path = _variant(tmp_path, ALLEGRO, lambda t: t.replace("ffj0 = [", "ffj9 = [", 1))
    assert "collision.links.ffj9" in _error(path)
