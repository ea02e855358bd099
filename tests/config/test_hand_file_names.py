"""Names in a hand file become MuJoCo scene names and tick-log columns: each is an identifier,
joint names are unique, and a bad one is a one-line error naming the file and key, on every
command that reads the file (before, MuJoCo's XML parser failed on a repeated joint name, and a
quote in a name reached the scene's XML)."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from grasp_ctrl.cli import main
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.errors import ConfigError
from grasp_ctrl.files.paths import hand_configs_dir

LEAP = hand_configs_dir() / "leap_hand.toml"


def _leap_with(tmp_path: Path, old: str, new: str) -> Path:
    text = LEAP.read_text()
    assert old in text
    path = tmp_path / "hand.toml"
    path.write_text(text.replace(old, new, 1))
    return path


def test_a_repeated_joint_name_is_refused(tmp_path: Path) -> None:
    path = _leap_with(tmp_path, 'name = "middle_mcp"', 'name = "index_mcp"')
    with pytest.raises(ConfigError) as info:
        load_hand(path)
    assert "fingers.joints.name" in str(info.value) and "index_mcp" in str(info.value)


@pytest.mark.parametrize(
    ("old", "new", "key"),
    [
        ('name = "index_pip"', 'name = "a\\"/><x y=\\""', "fingers[0].joints[2].name"),
        ('name = "leap_hand"', 'name = "le\\"ap"', "name"),
        ('name = "thumb_ipl"', 'name = "thumb ipl"', "fingers[3].joints[3].name"),
    ],
)
def test_a_name_that_is_not_an_identifier_is_refused(tmp_path: Path, old: str, new: str, key: str) -> None:
    path = _leap_with(tmp_path, old, new)
    with pytest.raises(ConfigError) as info:
        load_hand(path)
    message = str(info.value)
    assert key in message and "\n" not in message


@pytest.mark.parametrize("command", [["run", "--backend", "mujoco"], ["run", "--backend", "mock"], ["lift-capacity"]])
def test_commands_give_one_line_for_a_repeated_joint_name(tmp_path: Path, capsys, command: list[str]) -> None:  # type: ignore[no-untyped-def]
    path = _leap_with(tmp_path, 'name = "middle_mcp"', 'name = "index_mcp"')
    extra = ["--objects", "lego", "--trials", "1", "--out", str(tmp_path / "run")] if command[0] == "run" else []
    assert main([*command, "--hand", str(path), *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "index_mcp" in err[0], err


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.text(min_size=1, max_size=12))
def test_any_joint_name_loads_as_an_identifier_or_fails_in_one_line(tmp_path: Path, name: str) -> None:
    import json

    path = _leap_with(tmp_path, 'name = "index_dip"', f"name = {json.dumps(name)}")
    try:
        hand = load_hand(path)
    except ConfigError as exc:
        assert "\n" not in str(exc)
        return
    assert hand.fingers[0].joints[3].name == name
