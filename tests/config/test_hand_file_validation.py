"""Hand files the loader refuses in one line (file and key) instead of failing later: a grasping
finger whose task vector has no closing direction in the hand's x-y plane (scipy's "Residuals are
not finite" from the preshape, on every backend), geometry that is not hand-sized (a unit slip),
and TOML files too big to read (a 1 GiB sparse file was read whole before its error)."""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.config.hand import MAX_FINGER_BASE_M, MAX_FINGER_LINK_M, MIN_CLOSING_COMPONENT, load_hand
from grasp_ctrl.config.toml_limits import MAX_BYTES, MAX_CONTAINERS
from grasp_ctrl.errors import ConfigError
from grasp_ctrl.files.paths import hand_configs_dir

LEAP = hand_configs_dir() / "leap_hand.toml"
ALLEGRO = hand_configs_dir() / "allegro_hand.toml"
LEAP_TEXT = LEAP.read_text()


def _leap_with(tmp_path: Path, pattern: str, new: str, count: int = 1) -> Path:
    """The LEAP hand file with the first ``count`` lines matching ``pattern`` replaced by ``new``."""
    text, n = re.subn(pattern, new, LEAP_TEXT, count=count, flags=re.MULTILINE)
    assert n == count, pattern
    path = tmp_path / "hand.toml"
    path.write_text(text)
    return path


def _refused(path: Path, key: str) -> str:
    with pytest.raises(ConfigError) as info:
        load_hand(path)
    message = str(info.value)
    assert message.startswith(f"{path}: {key}: ") and "\n" not in message and len(message) < 400, message
    return message


def _cli_one_line(argv: list[str], capsys) -> tuple[int, str]:  # type: ignore[no-untyped-def]
    rc = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    return rc, err[0]


# ---------------------------------------------------------------- A. the closing direction
@pytest.mark.parametrize("vector", ["[0, 0, 1]", "[0.0, 0.0, -1.0]", "[0.1, 0.0, 1.0]", "[0.0, 0.4, -1.0]"])
def test_a_grasping_finger_without_a_closing_direction_is_refused(tmp_path: Path, vector: str) -> None:
    path = _leap_with(tmp_path, r"^task_vector_hand = .*$", f"task_vector_hand = {vector}")
    message = _refused(path, "fingers[0].task_vector_hand")
    assert "x-y plane" in message and f"got {vector})" in message


@pytest.mark.parametrize("vector", ["[0, 0, 0]", "[1e-12, 0, 0]"])
def test_a_zero_task_vector_is_refused(tmp_path: Path, vector: str) -> None:
    path = _leap_with(tmp_path, r"^task_vector_hand = .*$", f"task_vector_hand = {vector}")
    assert "a non-zero vector" in _refused(path, "fingers[0].task_vector_hand")


@pytest.mark.parametrize("vector", ["[1.0, 0.0, -1.0]", "[-1.0, 0.5, 0.5]", "[0.0, 1.0, 0.0]"])
def test_a_tilted_closing_direction_still_loads(tmp_path: Path, vector: str) -> None:
    hand = load_hand(_leap_with(tmp_path, r"^task_vector_hand = .*$", f"task_vector_hand = {vector}"))
    vx, vy, vz = hand.fingers[0].task_vector_hand
    assert abs(vx * vx + vy * vy + vz * vz - 1.0) < 1e-12 and (vx * vx + vy * vy) ** 0.5 >= MIN_CLOSING_COMPONENT


def test_a_finger_that_does_not_grasp_may_point_anywhere(tmp_path: Path) -> None:
    """The ring finger (grasp = false) never closes: its vector is not checked beyond non-zero."""
    text = LEAP_TEXT.replace(
        'grasp = false\ntask_vector_hand = [-1.0, 0.0, 0.0]', 'grasp = false\ntask_vector_hand = [0.0, 0.0, 1.0]'
    )
    assert text != LEAP_TEXT
    path = tmp_path / "hand.toml"
    path.write_text(text)
    assert load_hand(path).finger("ring").task_vector_hand == (0.0, 0.0, 1.0)


@pytest.mark.parametrize(
    "command",
    [["run", "--backend", "mock"], ["run", "--backend", "mujoco"], ["run", "--backend", "dynamixel", "--emulate"]],
)
def test_run_refuses_a_vertical_task_vector_in_one_line_on_every_backend(tmp_path: Path, capsys, command) -> None:  # type: ignore[no-untyped-def]
    path = _leap_with(tmp_path, r"^task_vector_hand = .*$", "task_vector_hand = [0, 0, 1]")
    out = tmp_path / "run"
    rc, line = _cli_one_line(
        [*command, "--hand", str(path), "--objects", "paper_cup", "--trials", "1", "--out", str(out), "--quiet"], capsys
    )
    assert rc == 2 and str(path) in line and "fingers[0].task_vector_hand" in line and not out.exists()


def test_lift_capacity_refuses_it_the_same_way(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    path = _leap_with(tmp_path, r"^task_vector_hand = .*$", "task_vector_hand = [0, 0, 1]")
    rc, line = _cli_one_line(["lift-capacity", "--hand", str(path)], capsys)
    assert rc == 2 and "fingers[0].task_vector_hand" in line


# ---------------------------------------------------------------- A. hand-sized geometry
@pytest.mark.parametrize(
    "pattern, new, key",
    [
        (r"^tip_xyz = .*$", "tip_xyz = [-0.0055, -44.5, 0.0145]", "fingers[0].tip_xyz"),  # mm written as m
        (r"^tip_xyz = .*$", f"tip_xyz = [0.0, 0.0, {MAX_FINGER_LINK_M + 0.01}]", "fingers[0].tip_xyz"),
        (r"^origin_xyz = .*$", "origin_xyz = [-7.0952, 23.0578, -18.7224]", "fingers[0].joints[0].origin_xyz"),
        (
            r"^origin_xyz = .*$",
            f"origin_xyz = [0.0, -{MAX_FINGER_LINK_M + 0.01}, 0.0]",
            "fingers[0].joints[0].origin_xyz",
        ),
        (r"^base_xyz = .*$", f"base_xyz = [{MAX_FINGER_BASE_M + 0.01}, 0.0, 0.0]", "fingers[0].base_xyz"),
        (r"^base_xyz = .*$", "base_xyz = [16.9, 14.8, 3.5]", "fingers[0].base_xyz"),
    ],
)
def test_geometry_that_is_not_hand_sized_is_refused(tmp_path: Path, pattern: str, new: str, key: str) -> None:
    message = _refused(_leap_with(tmp_path, pattern, new), key)
    assert "hand-sized" in message and " m " in message


def test_the_shipped_hand_files_load_with_a_wide_margin_to_the_bounds() -> None:
    """Both shipped hands: geometry under a fifth of each bound, closing directions horizontal."""
    for path in (LEAP, ALLEGRO):
        hand = load_hand(path)
        for f in hand.fingers:
            assert max(abs(v) for v in f.base_xyz) < MAX_FINGER_BASE_M / 5, (path, f.name)
            assert max(abs(v) for v in f.tip_xyz) < MAX_FINGER_LINK_M / 5, (path, f.name)
            assert max(abs(v) for j in f.joints for v in j.origin_xyz) < MAX_FINGER_LINK_M / 5, (path, f.name)
            if f.grasp:
                assert abs(f.task_vector_hand[2]) < 1e-12, (path, f.name)


def test_the_arm_chain_keeps_its_own_larger_bound(tmp_path: Path) -> None:
    """An arm's links are not hand-sized: a 0.6 m link and base still load."""
    arm = (
        '[arm]\nkind = "dynamixel"\nbase_xyz = [0.0, 0.0, 0.8]\ntool_xyz = [0.6, 0.0, 0.0]\n'
        'model = "XM430-W350-T"\n\n[[arm.joints]]\nname = "lift"\nservo_id = 30\naxis = [0.0, 1.0, 0.0]\n'
        "origin_xyz = [0.6, 0.0, 0.0]\nlower_rad = -1.0\nupper_rad = 1.0\nopen_rad = 0.0\n"
    )
    text = re.sub(r"^\[arm\]\n(?:(?!\[).*\n)*", arm + "\n", LEAP_TEXT, count=1, flags=re.MULTILINE)
    path = tmp_path / "hand.toml"
    path.write_text(text)
    hand = load_hand(path)
    assert hand.arm.joints[0].origin_xyz == (0.6, 0.0, 0.0) and hand.arm.base_xyz == (0.0, 0.0, 0.8)


# ---------------------------------------------------------------- D. TOML size and table caps
def test_a_1_gib_sparse_hand_file_is_refused_from_its_size_at_once(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "huge_hand.toml"
    with path.open("wb") as fh:
        fh.truncate(1024**3)
    start = time.perf_counter()
    message = _refused(path, "<file>")
    assert time.perf_counter() - start < 1.0
    assert "1 GiB" in message and str(1024**3) in message and "at most 2 MiB" in message
    rc, line = _cli_one_line(["lift-capacity", "--hand", str(path)], capsys)
    assert rc == 2 and str(path) in line and "1 GiB" in line


def test_a_hand_file_just_over_the_cap_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "hand.toml"
    path.write_text(LEAP_TEXT + "#" * (MAX_BYTES - len(LEAP_TEXT.encode()) + 1))
    assert f"{MAX_BYTES + 1} bytes" in _refused(path, "<file>")


def test_a_file_of_too_many_tables_and_arrays_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "hand.toml"
    path.write_text("x = [" + "[]," * MAX_CONTAINERS + "]\n" + LEAP_TEXT)
    assert f"at most {MAX_CONTAINERS} tables and arrays" in _refused(path, "<file>")


@pytest.mark.parametrize(
    "content, expected",
    [(b"name = \xff\n", "UTF-8 text (byte 7 is not)"), (b"name = = 1\n", "valid TOML ("), (b"[" * 5000, "valid TOML")],
)
def test_the_reader_keeps_its_one_line_messages(tmp_path: Path, content: bytes, expected: str) -> None:
    path = tmp_path / "hand.toml"
    path.write_bytes(content)
    assert expected in _refused(path, "<file>")


def test_a_missing_or_directory_hand_file_is_one_line(tmp_path: Path) -> None:
    assert _refused(tmp_path / "nope.toml", "<file>").endswith("file not found")
    assert _refused(tmp_path, "<file>").endswith("a TOML file, got a directory")
