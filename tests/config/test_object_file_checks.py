"""Object files the statics and the preflight used to accept: an object the hand cannot close around
(cylinders 0.15-0.5 m across all gave "16.62x" in lift-capacity, and faulted in reach in MuJoCo), a
lift that would take the palm above the arm's z_max_m (trials then "aborted" or "slipped"), and
TOML files too big to read (a 50 MB object file took 58 s before anything happened)."""

from __future__ import annotations

import re
import time
from dataclasses import replace
from pathlib import Path

import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.config.checks import check_objects_for_hand, lift_above_arm, palm_lift_top_m
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.config.objects import load_objects
from grasp_ctrl.controller.grasp_capacity import NoGrasp, closing_blocked, object_capacity, pregrasp_gaps
from grasp_ctrl.errors import ConfigError
from grasp_ctrl.files.paths import hand_configs_dir
from grasp_ctrl.trials.episode.capacity_check import CapacityRefused, check_object, preflight_capacity

OBJECTS_TOML = (hand_configs_dir() / "objects.toml").read_text()


def _object_file(tmp_path: Path, diameter_m: float = 0.075, name: str = "drum", extra: str = "") -> Path:
    """An object file with one rigid cylinder."""
    path = tmp_path / f"{name}.toml"
    path.write_text(
        f'[objects.{name}]\nshape = "cylinder"\ndiameter_m = {diameter_m}\nheight_m = 0.2\nmass_kg = 0.2\n'
        f"mu = 0.8\nstiffness_n_per_m = 5000.0\ngrasp_height_m = 0.08\n{extra}"
    )
    return path


def _cli(argv: list[str], capsys) -> tuple[int, str, str]:  # type: ignore[no-untyped-def]
    rc = main(argv)
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return rc, out, err


# ---------------------------------------------------------------- B. the hand must close around it
def test_the_pregrasp_gap_between_opposing_pads(hand) -> None:  # type: ignore[no-untyped-def]
    """Index and middle close toward the thumb: two opposing pairs, 88 mm apart on the LEAP hand
    (pads at x = +46 and -42 mm) and 92 mm on the Allegro."""
    gaps = {g.fingers: g.gap_m for g in pregrasp_gaps(hand)}
    assert set(gaps) == {("index", "thumb"), ("middle", "thumb")}
    assert all(0.085 < g < 0.091 for g in gaps.values()), gaps
    allegro = load_hand(hand_configs_dir() / "allegro_hand.toml")
    assert all(0.090 < g.gap_m < 0.094 for g in pregrasp_gaps(allegro))


@pytest.mark.parametrize("diameter_m", [0.15, 0.3, 0.5])
def test_lift_capacity_gives_no_ratio_for_an_object_wider_than_the_gap(tmp_path: Path, capsys, diameter_m) -> None:  # type: ignore[no-untyped-def]
    path = _object_file(tmp_path, diameter_m)
    rc, out, _ = _cli(["lift-capacity", "--objects-file", str(path), "--objects", "drum"], capsys)
    row = next(line for line in out.splitlines() if line.strip().startswith("drum"))
    assert rc == 1
    assert f"no grasp: {1000 * diameter_m:.0f} mm across" in row and "pregrasp gap of 88 mm" in row, row
    assert "16.62" not in out and not re.search(r"drum\s+[\d.]+\s+[\d.]+\s+[\d.]+", row), row


def test_a_pad_that_starts_inside_the_object_is_no_grasp(tmp_path: Path, hand) -> None:  # type: ignore[no-untyped-def]
    """87 mm fits the 88 mm gap, but centred under the palm it reaches past the thumb's pad (42 mm
    behind the centre): the thumb would land on it, and the statics used to start the grasp there."""
    obj = load_objects(_object_file(tmp_path, 0.087))["drum"]
    with pytest.raises(NoGrasp, match=r"^the thumb pad starts 1 mm inside the object's side"):
        object_capacity(hand, obj)
    assert closing_blocked(hand, obj.with_params(size_m=(0.083, 0.083))) is None


def test_a_pad_that_never_reaches_the_object_is_no_grasp(tmp_path: Path, hand) -> None:  # type: ignore[no-untyped-def]
    """A 20 mm cylinder: the index and middle pads close on lines 23 mm off its axis and pass it."""
    obj = load_objects(_object_file(tmp_path, 0.02))["drum"]
    with pytest.raises(NoGrasp, match=r"the (index|middle) pad does not reach the object"):
        object_capacity(hand, obj)


def test_the_shipped_objects_still_close_on_both_hands(hand, objects) -> None:  # type: ignore[no-untyped-def]
    allegro = load_hand(hand_configs_dir() / "allegro_hand.toml")
    for h in (hand, allegro):
        for name, obj in load_objects(hand_configs_dir() / "objects.toml", h.name).items():
            assert closing_blocked(h, obj) is None, (h.name, name)


def test_runs_preflight_flags_it_in_simulation_and_refuses_it_on_the_hand(tmp_path: Path, hand) -> None:  # type: ignore[no-untyped-def]
    obj = load_objects(_object_file(tmp_path, 0.3))["drum"]
    verdict = check_object(hand, obj)
    assert verdict.no_grasp and not verdict.carried and "pregrasp gap" in verdict.binding
    said: list[str] = []
    short = preflight_capacity(hand, [obj], None, on_hand=False, force=False, say=said.append)
    assert [v.object for v in short] == ["drum"]
    assert len(said) == 1 and said[0].startswith("capacity: drum: no grasp: 300 mm across") and "carries" not in said[0]
    with pytest.raises(CapacityRefused) as info:
        preflight_capacity(hand, [obj], None, on_hand=True, force=False, say=said.append)
    message = str(info.value)
    assert "no grasp" in message and "raise the current limits" not in message and "\n" not in message


def test_run_on_the_emulated_hand_refuses_it_in_one_line(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    path = _object_file(tmp_path, 0.3)
    out = tmp_path / "run"
    argv = ["run", "--backend", "dynamixel", "--emulate", "--object-file", str(path), "--trials", "1"]
    rc, _, err = _cli([*argv, "--out", str(out), "--quiet"], capsys)
    errors = [line for line in err.splitlines() if "error:" in line]
    assert rc == 2 and len(errors) == 1 and "drum: no grasp" in errors[0] and "pregrasp gap" in errors[0]


# ---------------------------------------------------------------- C. the lift must stay under the arm's top
def test_a_lift_above_the_arms_z_max_is_refused_naming_object_key_and_numbers(tmp_path: Path, hand) -> None:  # type: ignore[no-untyped-def]
    path = _object_file(tmp_path, extra="lift_height_m = 1.0\n")
    obj = load_objects(path, hand.name)["drum"]
    assert palm_lift_top_m(obj, hand) == pytest.approx(0.08 + 0.1 + 1.0)
    with pytest.raises(ConfigError) as info:
        check_objects_for_hand([obj], hand, str(path))
    message = str(info.value)
    assert message.startswith(f"{path}: objects.drum.lift_height_m: ") and "\n" not in message
    assert "arm.z_max_m = 0.6 m" in message and "1 m takes it to 1.180 m" in message
    assert "at most 0.420 m" in message


def test_the_largest_lift_the_arm_allows_is_accepted(tmp_path: Path, hand) -> None:  # type: ignore[no-untyped-def]
    room = hand.arm.z_max_m - 0.08 - hand.grasp.palm_above_contact_m
    obj = load_objects(_object_file(tmp_path, extra=f"lift_height_m = {room!r}\n"), hand.name)["drum"]
    assert lift_above_arm(obj, hand) is None
    assert lift_above_arm(obj.with_params(lift_height_m=room + 0.001), hand) is not None


def test_a_hand_tables_lift_is_checked_too(tmp_path: Path, hand) -> None:  # type: ignore[no-untyped-def]
    path = _object_file(tmp_path, extra="\n[objects.drum.hands.leap_hand]\nlift_height_m = 0.5\n")
    with pytest.raises(ConfigError, match=r"objects\.drum\.lift_height_m: a lift_height_m of at most 0\.420 m"):
        check_objects_for_hand(list(load_objects(path, hand.name).values()), hand, str(path))
    other = replace(hand, name="other_hand")  # the leap_hand table does not apply to it: 0.1 m
    check_objects_for_hand(list(load_objects(path, other.name).values()), other, str(path))


@pytest.mark.parametrize("backend", [["--backend", "mock"], ["--backend", "mujoco"]])
def test_run_refuses_the_lift_before_any_trial(tmp_path: Path, capsys, backend) -> None:  # type: ignore[no-untyped-def]
    path = _object_file(tmp_path, extra="lift_height_m = 1.0\n")
    out = tmp_path / "run"
    rc, _, err = _cli(
        ["run", *backend, "--object-file", str(path), "--trials", "1", "--out", str(out), "--quiet"], capsys
    )
    lines = err.strip().splitlines()
    assert rc == 2 and len(lines) == 1 and "objects.drum.lift_height_m" in lines[0] and "0.6 m" in lines[0]
    assert not (out / "trials").exists()


def test_lift_capacity_flags_the_lift_and_exits_1(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    path = _object_file(tmp_path, extra="lift_height_m = 1.0\n")
    rc, out, _ = _cli(["lift-capacity", "--objects-file", str(path)], capsys)
    row = next(line for line in out.splitlines() if line.strip().startswith("drum"))
    assert rc == 1 and "no lift" in row and "objects.drum.lift_height_m" in row and "z_max_m = 0.6 m" in row
    assert "1 m takes it to 1.180 m" in row


def test_the_shipped_objects_lift_within_both_arms(objects, hand) -> None:  # type: ignore[no-untyped-def]
    allegro = load_hand(hand_configs_dir() / "allegro_hand.toml")
    for h in (hand, allegro):
        check_objects_for_hand(list(load_objects(hand_configs_dir() / "objects.toml", h.name).values()), h, "objects")


# ---------------------------------------------------------------- D. TOML size cap on object files
def test_a_50_mb_object_file_is_refused_from_its_size_at_once(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "objects.toml"
    with path.open("wb") as fh:
        fh.write(OBJECTS_TOML.encode())
        fh.truncate(50 * 1000 * 1000)
    start = time.perf_counter()
    with pytest.raises(ConfigError) as info:
        load_objects(path)
    assert time.perf_counter() - start < 1.0
    message = str(info.value)
    assert message.startswith(f"{path}: <file>: a TOML file of at most 2 MiB (got 47.7 MiB, 50000000 bytes)")
    rc, _, err = _cli(["lift-capacity", "--objects-file", str(path)], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "50000000 bytes" in err
    out = tmp_path / "run"
    rc, _, err = _cli(["run", "--backend", "mock", "--object-file", str(path), "--out", str(out), "--quiet"], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "50000000 bytes" in err and not out.exists()


def test_a_1_gib_sparse_pushed_object_file_is_refused(tmp_path: Path) -> None:
    from grasp_ctrl.pushing.box import load_box

    path = tmp_path / "box.toml"
    with path.open("wb") as fh:
        fh.truncate(1024**3)
    with pytest.raises(ConfigError, match=r"<file>: a TOML file of at most 2 MiB \(got 1 GiB, 1073741824 bytes\)"):
        load_box(path)
