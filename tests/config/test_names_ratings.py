"""Names are identifiers (config/identifiers.py) and a hand file asks no servo for more than its
ratings (config/servos.py, or the file's own [servo_models.NAME]). Every file here is a tmp_path copy
of a shipped one; the shipped files are never edited."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from grasp_ctrl.cli import main
from grasp_ctrl.config import load_hand, load_objects
from grasp_ctrl.config.identifiers import (
    IDENTIFIER,
    check_identifier,
    check_identifier_arg,
    is_identifier,
)
from grasp_ctrl.config.servos import MODELS
from grasp_ctrl.errors import ConfigError, PolicyError, UsageError
from grasp_ctrl.estimators.registry import load_policy, resolve_policy_path
from grasp_ctrl.files.paths import REPO_ROOT, default_objects_file, policies_dir
from grasp_ctrl.files.storage import check_object_name

LEAP = REPO_ROOT / "hand_configs" / "leap_hand.toml"
OBJECTS_TOML = Path(default_objects_file()).read_text()
LEGO_BODY = OBJECTS_TOML[OBJECTS_TOML.index("[objects.lego]") :].split("\n\n")[0].split("\n", 1)[1]


def toml_key(name: str) -> str:
    """``name`` as a TOML quoted key: every character that is not printable ASCII is escaped."""
    out = []
    for c in name:
        if c in '"\\' or not (" " <= c <= "~"):
            out.append(f"\\U{ord(c):08X}")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def objects_file(tmp_path: Path, name: str) -> Path:
    """An object file holding the shipped lego's profile under ``name``."""
    path = tmp_path / "objects.toml"
    path.write_text(f"[objects.{toml_key(name)}]\n{LEGO_BODY}\n")
    return path


def hand_file(tmp_path: Path, *edits: tuple[str, str], extra: str = "") -> Path:
    """A copy of the LEAP Hand file with each (old, new) replaced once, and ``extra`` appended."""
    text = LEAP.read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = tmp_path / "hand.toml"
    path.write_text(text + extra)
    return path


def one_line(exc: BaseException) -> str:
    text = str(exc)
    assert "\n" not in text and "\r" not in text, repr(text)
    return text


# ------------------------------------------------------------------------------ names


@pytest.mark.parametrize(
    "name",
    ["lego\n", ".lego", "a" * 65, "a/b", "..", "", "lé", "in dex", "x\x00y"],
    ids=["newline", "leading-dot", "65-chars", "slash", "dotdot", "empty", "non-ascii", "space", "nul"],
)
def test_an_object_name_that_is_not_an_identifier_is_one_line(tmp_path, name):
    path = objects_file(tmp_path, name)
    with pytest.raises(ConfigError) as info:
        load_objects(path)
    text = one_line(info.value)
    assert text.startswith(f"{path}: objects.<object name>: an identifier")
    assert "object names become directory names" in text


def test_identifiers_pass_as_object_names(tmp_path):
    for name in ("lego", "a" * 64, "Lego-2.v1", "_x", "9"):
        assert list(load_objects(objects_file(tmp_path, name))) == [name]


def test_a_newline_object_name_never_makes_a_run_directory(tmp_path, capsys):
    """It used to run: SAFE_NAME's `$` matched before the trailing newline."""
    out = tmp_path / "run"
    argv = ["run", "--backend", "mock", "--object-file", str(objects_file(tmp_path, "lego\n"))]
    argv += ["--objects", "lego\n", "--out", str(out), "--trials", "1", "--quiet", "--no-tick-logs"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "an identifier" in err and "'lego\\n'" in err
    assert not out.exists()


def test_the_run_dir_check_and_run_json_use_the_same_rule():
    with pytest.raises(UsageError, match="object name 'lego\\\\n': must be an identifier"):
        check_object_name("lego\n")
    assert check_object_name("lego.v2") == "lego.v2"
    from grasp_ctrl.config.objects import profile_from_json

    with pytest.raises(ConfigError, match=r"run\.json: objects\.name: an identifier"):
        profile_from_json(".lego", {"shape": "box"}, "run.json", "objects.")


def test_a_policy_json_whose_name_has_a_space_is_one_line(tmp_path):
    meta = json.loads((policies_dir() / "mlp_mock.json").read_text())
    meta["name"] = "mlp mock"
    path = tmp_path / "mlp_mock.json"
    path.write_text(json.dumps(meta))
    with pytest.raises(PolicyError) as info:  # what every unloadable policy raises
        load_policy(str(path))
    assert one_line(info.value).startswith(f"{path}: name: an identifier")
    meta["name"] = "mlp_mock.v2"  # the same file with an identifier loads
    path.write_text(json.dumps(meta))
    assert load_policy(str(path)) is not None


@pytest.mark.parametrize("spec", ["mlp mock", ".mlp_mock", "mlp\nmock", "a" * 65, ""])
def test_a_policy_name_on_the_command_line_is_an_identifier(spec):
    with pytest.raises(UsageError) as info:
        resolve_policy_path(spec)
    assert "must be an identifier" in one_line(info.value)


def test_a_bad_policy_name_is_refused_by_run_in_one_line(tmp_path, capsys):
    argv = ["run", "--backend", "mock", "--policy", "mlp mock", "--objects", "lego", "--out", str(tmp_path / "r")]
    assert main([*argv, "--trials", "1", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "must be an identifier" in err


def test_a_calibrated_policys_base_name_cannot_leave_its_folder(tmp_path):
    from grasp_ctrl.estimators.calibrated import _base_path

    with pytest.raises(PolicyError, match=r"base_policy\.name: an identifier"):
        _base_path({"base_policy": {"name": "../../x"}}, tmp_path / "cal.json")


def test_a_finger_named_in_dex_is_one_line(tmp_path):
    path = hand_file(
        tmp_path, ('name = "index"', 'name = "in dex"'), ('release_finger = "index"', 'release_finger = "in dex"')
    )
    with pytest.raises(ConfigError) as info:
        load_hand(path)
    assert one_line(info.value) == (
        f"{path}: fingers[0].name: an identifier: 1-64 ASCII letters, digits, '_', '-' or '.', "
        "not starting with '.' (got 'in dex')"
    )


def test_the_shipped_files_keep_loading():
    hand = load_hand(LEAP)
    assert all(is_identifier(f.name) for f in hand.fingers)
    assert all(is_identifier(n) for n in load_objects(default_objects_file()))
    for json_path in sorted(policies_dir().glob("*.json")):
        assert is_identifier(json.loads(json_path.read_text())["name"]), json_path


# ------------------------------------------------------------------------------ the property

SAFE_COMPONENT = re.compile(r"[!-~]+")  # printable ASCII, no space


@settings(max_examples=400, deadline=None)
@given(st.one_of(st.text(max_size=80), st.from_regex(IDENTIFIER, fullmatch=True), st.sampled_from([".", "..", "a\n"])))
def test_any_string_is_an_identifier_and_a_safe_path_component_or_one_line_error(value):
    try:
        accepted = check_identifier(value, "objects.toml", "objects.<object name>")
    except ConfigError as exc:
        assert one_line(exc).startswith("objects.toml: objects.<object name>: an identifier")
        with pytest.raises(UsageError) as info:
            check_identifier_arg(value, "--policy")
        one_line(info.value)
        assert not is_identifier(value)
        return
    assert accepted == value and is_identifier(value) and check_identifier_arg(value, "--policy") == value
    assert SAFE_COMPONENT.fullmatch(value) and 1 <= len(value) <= 64
    assert "/" not in value and "\x00" not in value and value not in (".", "..") and not value.startswith(".")
    base = Path("/run/trials/policy")
    assert (base / value).parent == base and (base / value).name == value


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.text(max_size=70))
def test_any_object_table_name_loads_or_is_one_line(tmp_path, value):
    path = objects_file(tmp_path, value)
    try:
        names = list(load_objects(path))
    except ConfigError as exc:
        one_line(exc)
        assert not is_identifier(value)
    else:
        assert names == [value] and is_identifier(value)


# ------------------------------------------------------------------------------ ratings


def test_current_limit_5_a_on_an_xc330_is_refused_naming_the_stall_current(tmp_path):
    path = hand_file(tmp_path, ("current_limit_a = 0.55", "current_limit_a = 5.0"))
    with pytest.raises(ConfigError) as info:
        load_hand(path)
    assert one_line(info.value) == (
        f"{path}: fingers[0].joints[0].current_limit_a: at most 1.8 A, the XC330-M288-T's stall current at 5 V (got 5)"
    )
    ok = hand_file(tmp_path, ("current_limit_a = 0.55", "current_limit_a = 1.8"))
    assert load_hand(ok).joints[0].current_limit_a == 1.8


def test_a_current_limit_on_a_lower_rated_model_names_that_model(tmp_path):
    path = hand_file(tmp_path, ('model = "XC330-M288-T"', 'model = "XC330-T288-T"'))  # thumb_mcp has 1.2 A
    with pytest.raises(ConfigError, match=r"at most 0\.8 A, the XC330-T288-T's stall current at 11\.1 V \(got 1\.2\)"):
        load_hand(path)


def test_a_goal_velocity_above_the_rating_is_refused(tmp_path):
    path = hand_file(tmp_path, ("profile_velocity = 0 ", "profile_velocity = 3000 "))
    with pytest.raises(ConfigError) as info:
        load_hand(path)
    assert one_line(info.value) == (
        f"{path}: dynamixel.profile_velocity: at most 2047 (468.8 rev/min), the XC330-M288-T's Velocity "
        "Limit register maximum, which bounds Goal and Profile Velocity (got 3000)"
    )
    assert (
        load_hand(hand_file(tmp_path, ("profile_velocity = 0 ", "profile_velocity = 2047 "))).dynamixel.profile_velocity
        == 2047
    )


def test_gains_above_the_register_are_refused_as_written(tmp_path):
    path = hand_file(tmp_path, ("position_p_gain = 600", "position_p_gain = 20000"))
    with pytest.raises(ConfigError, match=r"dynamixel\.position_p_gain: at most 16383, the XC330-M288-T's Position P"):
        load_hand(path)
    # 5000 fits the register, but x gain_scale 4 would be written as 20000
    path = hand_file(
        tmp_path, ("position_p_gain = 600", "position_p_gain = 5000"), ("\ngain_scale = 0.75", "\ngain_scale = 4.0")
    )
    with pytest.raises(ConfigError, match=r"joints\[\d\]\.gain_scale: at most 3\.277 with position_p_gain = 5000"):
        load_hand(path)


CUSTOM = """
[servo_models.XC330-X999]   # a servo config/servos.py does not know
model_number = 1999
current_unit_a = 0.002
max_current_limit = 1000
stall_current_a = 1.5
stall_voltage_v = 5.0
stall_torque_nm = 0.8
max_velocity_limit = 1000
max_position_gain = 16383
"""


def test_a_servo_model_defined_in_the_hand_file_is_accepted_and_its_ratings_apply(tmp_path):
    from grasp_ctrl.controller.joint_stiffness import joint_stiffness
    from grasp_ctrl.emulators.dxl_chain import DynamixelChainEmulator
    from grasp_ctrl.hardware.dynamixel import DynamixelHand
    from grasp_ctrl.hardware.dynamixel import control_table as ct

    model = ('model = "XC330-M288-T"', 'model = "XC330-X999"')
    timeout = ("packet_timeout_ms = 8.0", "packet_timeout_ms = 40.0")  # a busy test host
    hand = load_hand(hand_file(tmp_path, model, timeout, extra=CUSTOM))
    servo = hand.dynamixel.servo
    assert "XC330-X999" not in MODELS and servo is not None and servo.model_number == 1999
    assert joint_stiffness(hand).kp_nm_per_rad is not None  # the controller reads the same facts
    # the bus speaks to it in its own units and checks its model number on connect
    emu = DynamixelChainEmulator.for_hand(hand).start()
    try:
        dxl = DynamixelHand(hand, emu.port, handle_signals=False)
        dxl.connect()
        try:
            j = hand.joints[0]
            assert emu.servo(j.servo_id).get((ct.ADDR_CURRENT_LIMIT, 2)) == round(j.current_limit_a / 0.002)
        finally:
            dxl.close()
    finally:
        emu.stop()
    # its own ratings are checked like the table's
    over = hand_file(tmp_path, model, ("current_limit_a = 0.55", "current_limit_a = 1.6"), extra=CUSTOM)
    with pytest.raises(ConfigError, match=r"at most 1\.5 A, the XC330-X999's stall current at 5 V \(got 1\.6\)"):
        load_hand(over)


def test_the_override_cannot_redefine_a_known_model_or_go_unnamed(tmp_path):
    again = CUSTOM.replace("XC330-X999", "XC330-M288-T")
    with pytest.raises(ConfigError, match=r"servo_models\.XC330-M288-T: a model that config/servos\.py does not know"):
        load_hand(hand_file(tmp_path, extra=again))
    with pytest.raises(ConfigError, match=r"dynamixel\.model: one of .* or a model of a \[servo_models\.NAME\] table"):
        load_hand(hand_file(tmp_path, ('model = "XC330-M288-T"', 'model = "XC330-X998"'), extra=CUSTOM))
    with pytest.raises(ConfigError, match=r"servo_models\.XC330-X999\.current_unit_a: required key is missing"):
        load_hand(hand_file(tmp_path, extra=CUSTOM.replace("current_unit_a = 0.002\n", "")))
