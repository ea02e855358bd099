"""Per-hand object thresholds: ``[objects.NAME.hands.HAND]`` applies to that hand only.

A threshold or grasp value tuned on one hand must never apply silently to another: the LEAP
hand's values sit in ``hands.leap_hand`` tables, another hand gets the object-level values (the
defaults), and ``tune --write`` writes into the table of the hand it tuned on.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import pickle
import shutil
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from grasp_ctrl.config.objects import (
    HAND_KEYS,
    ObjectProfile,
    default_set,
    load_objects,
    profile_from_json,
    profile_json,
    revalidate,
)
from grasp_ctrl.errors import ConfigError, UsageError
from grasp_ctrl.files.paths import REPO_ROOT
from grasp_ctrl.trials.runs.selection import select_objects
from grasp_ctrl.trials.tuning.toml_edit import CHOSEN_BY, update_object_file, update_objects_file

OBJECTS_TOML = REPO_ROOT / "hand_configs" / "objects.toml"
LEAP = "leap_hand"
OTHER = "other_hand"

_DEFAULTS = {
    "cap": None,
    "tau_n": 2.0,
    "release_threshold_n": 0.3,
    "release_debounce": 3,
    "lift_height_m": 0.1,
    "hold_s": 0.5,
    "grip_targets": None,
    "approach_offset_m": 0.0,
    "standoff_m": None,
    "posture_offsets_rad": None,
}

# The LEAP hand's profiles as the object file gave them before the per-hand tables (every field
# of ObjectProfile then), copied here: the move into [objects.NAME.hands.leap_hand] must not
# change one of them.
LEAP_BEFORE: dict[str, dict] = {
    "chips_can": {
        **_DEFAULTS,
        "shape": "cylinder",
        "size_m": (0.075, 0.075),
        "height_m": 0.25,
        "mass_kg": 0.205,
        "mu": 0.9,
        "stiffness_n_per_m": 2500.0,
        "deformable": False,
        "crush_force_n": None,
        "grasp_height_m": 0.08,
        "tip_force_n": 6.0,
    },
    "cleanser": {
        **_DEFAULTS,
        "shape": "box",
        "size_m": (0.065, 0.098),
        "height_m": 0.25,
        "mass_kg": 0.45,
        "mu": 1.0,
        "stiffness_n_per_m": 3000.0,
        "deformable": False,
        "crush_force_n": None,
        "grasp_height_m": 0.08,
        "tip_force_n": 12.0,
        "tau_n": 2.5,
        "grip_targets": "force_closure",
    },
    "lego": {
        **_DEFAULTS,
        "shape": "box",
        "size_m": (0.032, 0.064),
        "height_m": 0.06,
        "mass_kg": 0.06,
        "mu": 0.8,
        "stiffness_n_per_m": 4000.0,
        "deformable": False,
        "crush_force_n": None,
        "grasp_height_m": 0.04,
        "tip_force_n": 4.0,
    },
    "plastic_bottle": {
        **_DEFAULTS,
        "shape": "cylinder",
        "size_m": (0.065, 0.065),
        "height_m": 0.21,
        "mass_kg": 0.05,
        "mu": 0.7,
        "stiffness_n_per_m": 900.0,
        "deformable": True,
        "crush_force_n": 3.6,
        "grasp_height_m": 0.08,
        "tip_force_n": 2.5,
    },
    "paper_cup": {
        **_DEFAULTS,
        "shape": "cylinder",
        "size_m": (0.075, 0.075),
        "height_m": 0.11,
        "mass_kg": 0.03,
        "mu": 0.8,
        "stiffness_n_per_m": 600.0,
        "deformable": True,
        "crush_force_n": 3.2,
        "grasp_height_m": 0.06,
        "tip_force_n": 2.5,
    },
    "mustard_bottle": {
        **_DEFAULTS,
        "shape": "box",
        "size_m": (0.058, 0.095),
        "height_m": 0.16,
        "mass_kg": 0.38,
        "mu": 0.9,
        "stiffness_n_per_m": 2000.0,
        "deformable": False,
        "crush_force_n": None,
        "grasp_height_m": 0.148,
        "tip_force_n": 8.0,
        "cap": {
            "diameter_m": 0.04,
            "height_m": 0.015,
            "offset_m": (0.0, 0.02),
            "finger": "index",
            "contact_height_m": 0.162,
        },
        "tau_n": 3.0,
        "grip_targets": "force_closure",
    },
}
LEAP_TUNED = {"cleanser", "mustard_bottle"}  # the objects with a [objects.NAME.hands.leap_hand] table


def _fields(obj: ObjectProfile) -> dict:
    out = dataclasses.asdict(obj)
    out.pop("name")
    out.pop("tuned_for")
    return out


def _file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "objects.toml"
    path.write_text(text)
    return path


def _with_table(tmp_path: Path, table: str, body: str) -> Path:
    """The shipped object file with ``[TABLE]`` and ``body`` appended."""
    return _file(tmp_path, OBJECTS_TOML.read_text() + f"\n[{table}]\n{body}\n")


def _one_line(exc: BaseException) -> str:
    text = str(exc)
    assert "\n" not in text
    return text


# --- the LEAP hand keeps its profiles -----------------------------------------------------------


def test_the_leap_profiles_are_unchanged():
    profiles = load_objects(OBJECTS_TOML, LEAP)
    assert list(profiles) == list(LEAP_BEFORE) == default_set(OBJECTS_TOML)
    for name, expected in LEAP_BEFORE.items():
        assert _fields(profiles[name]) == expected, name
        assert profiles[name].tuned_for == (LEAP if name in LEAP_TUNED else None)


def test_the_shipped_hand_file_is_the_leap_hand(hand):
    assert hand.name == LEAP  # the tables the shipped runs use are named after it


def test_another_hand_gets_the_object_level_values():
    leap = load_objects(OBJECTS_TOML, LEAP)
    for hand in (OTHER, None):
        other = load_objects(OBJECTS_TOML, hand)
        for name, obj in other.items():
            assert obj.tuned_for is None
            for key in HAND_KEYS:  # no file value at the object level: the defaults
                assert getattr(obj, key) == _DEFAULTS[key], (hand, name, key)
            physical = {k: v for k, v in _fields(obj).items() if k not in HAND_KEYS}
            assert physical == {k: v for k, v in _fields(leap[name]).items() if k not in HAND_KEYS}
        # never the LEAP's 2.5 N and force-closure targets on the cleanser, its 3 N on the bottle
        assert (other["cleanser"].tau_n, other["cleanser"].grip_targets) == (2.0, None)
        assert other["mustard_bottle"].tau_n == 2.0


def test_selection_resolves_for_the_hand_it_is_given():
    assert [o.tau_n for o in select_objects(OBJECTS_TOML, "cleanser,mustard_bottle", hand=LEAP)] == [2.5, 3.0]
    assert [o.tau_n for o in select_objects(OBJECTS_TOML, "cleanser,mustard_bottle", hand=OTHER)] == [2.0, 2.0]


def test_load_objects_takes_a_hand_name_not_a_hand():
    with pytest.raises(TypeError, match="hand's name"):
        load_objects(OBJECTS_TOML, object())  # type: ignore[arg-type]


# --- resolution ---------------------------------------------------------------------------------


def test_object_level_values_are_for_every_hand_and_a_hand_table_overrides_them(tmp_path):
    text = OBJECTS_TOML.read_text().replace(
        "tip_force_n = 4.0\n", "tip_force_n = 4.0\nhold_s = 1.5\ntau_n = 1.5\n", 1
    )  # the lego's own table
    text += "\n[objects.lego.hands.other_hand]\ntau_n = 1.25\nposture_offsets_rad = {thumb = [0.0, 0.1]}\n"
    path = _file(tmp_path, text)
    leap, other, none = (load_objects(path, h)["lego"] for h in (LEAP, OTHER, None))
    assert (leap.tau_n, leap.hold_s, leap.tuned_for, leap.posture_offsets_rad) == (1.5, 1.5, None, None)
    assert (none.tau_n, none.hold_s, none.tuned_for) == (1.5, 1.5, None)
    assert (other.tau_n, other.hold_s, other.tuned_for) == (1.25, 1.5, OTHER)
    assert other.posture_offsets() == {"thumb": (0.0, 0.1)}
    assert load_objects(path, LEAP)["cleanser"].tau_n == 2.5  # the LEAP's own tables still apply


def test_a_hand_table_applies_only_to_the_hand_it_names(tmp_path):
    path = _with_table(tmp_path, "objects.cleanser.hands.other_hand", "tau_n = 1.75\nrelease_debounce = 5")
    leap, other = load_objects(path, LEAP)["cleanser"], load_objects(path, OTHER)["cleanser"]
    assert (leap.tau_n, leap.release_debounce, leap.grip_targets) == (2.5, 3, "force_closure")
    assert (other.tau_n, other.release_debounce, other.grip_targets) == (1.75, 5, None)
    assert load_objects(path, "shadow_hand")["cleanser"].tau_n == 2.0


def test_profiles_with_a_hand_pickle_and_hash():
    obj = load_objects(OBJECTS_TOML, LEAP)["cleanser"]
    assert pickle.loads(pickle.dumps(obj)) == obj and hash(obj) == hash(pickle.loads(pickle.dumps(obj)))
    assert revalidate(obj, "x") == obj  # tune's edits keep the hand
    assert obj.with_params(tau_n=2.25).tuned_for == LEAP


# --- what a hand table may hold -----------------------------------------------------------------


@pytest.mark.parametrize(
    ("body", "key"),
    [
        ("mass_kg = 0.5", "mass_kg"),
        ("mu = 0.5", "mu"),
        ("shape = 'box'", "shape"),
        ("diameter_m = 0.05", "diameter_m"),
        ("grasp_height_m = 0.05", "grasp_height_m"),
        ("stiffness_n_per_m = 100.0", "stiffness_n_per_m"),
        ("crush_force_n = 3.0", "crush_force_n"),
        ("cap = {diameter_m = 0.01}", "cap"),
    ],
)
def test_a_physical_key_in_a_hand_table_is_refused_in_one_line(tmp_path, body, key):
    path = _with_table(tmp_path, "objects.lego.hands.other_hand", body)
    for hand in (LEAP, OTHER, None):  # whichever hand loads the file
        with pytest.raises(ConfigError) as exc:
            load_objects(path, hand)
        line = _one_line(exc.value)
        assert line.startswith(f"{path}: objects.lego.hands.other_hand.{key}: not a per-hand key")
        assert "[objects.lego]" in line


@pytest.mark.parametrize(
    ("table", "body", "named"),
    [
        ("objects.lego.hands.other_hand", "tua_n = 2.0", "objects.lego.hands.other_hand.tua_n: a known key"),
        ("objects.lego.hands.other_hand", "hands = {}", "objects.lego.hands.other_hand.hands: a known key"),
        ("objects.lego.hands.other_hand", "tau_n = 99.0", "objects.lego.hands.other_hand.tau_n: a value <= 20"),
        ("objects.lego.hands.other_hand", "tau_n = 'x'", "objects.lego.hands.other_hand.tau_n: a finite number"),
        ("objects.lego.hands.other_hand", "grip_targets = 'x'", "objects.lego.hands.other_hand.grip_targets"),
        (
            "objects.lego.hands.other_hand",
            "approach_offset_m = -0.04",  # below the table: grasp_height_m 0.04 + -0.04
            "objects.lego.hands.other_hand.approach_offset_m: an offset that keeps",
        ),
        (
            "objects.lego.hands.other_hand",
            "posture_offsets_rad = {thumb = [0.0, 0.5]}",
            "objects.lego.hands.other_hand.posture_offsets_rad.thumb",
        ),
        ("objects.lego.hands", "other_hand = 3", "objects.lego.hands.other_hand: a table"),
        ("objects.lego.hands", "'bad name' = {tau_n = 2.0}", "objects.lego.hands.<hand name>: an identifier"),
    ],
)
def test_a_bad_hand_table_is_refused_in_one_line_whichever_hand_loads(tmp_path, table, body, named):
    path = _with_table(tmp_path, table, body)
    for hand in (LEAP, OTHER, None):
        with pytest.raises(ConfigError) as exc:
            load_objects(path, hand)
        assert _one_line(exc.value).startswith(f"{path}: {named}")


def test_hands_must_be_a_table(tmp_path):
    text = OBJECTS_TOML.read_text().replace("tip_force_n = 4.0\n", "tip_force_n = 4.0\nhands = 3\n", 1)
    with pytest.raises(ConfigError) as exc:
        load_objects(_file(tmp_path, text), LEAP)
    assert _one_line(exc.value) == f"{tmp_path / 'objects.toml'}: objects.lego.hands: a table"


_KEYS = st.sampled_from([*HAND_KEYS, "mass_kg", "mu", "shape", "cap", "hands", "tua_n", "x"])
_VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**30), 10**30),
    st.booleans(),
    st.sampled_from(["equal", "force_closure", "", "x\ny"]),
    st.dictionaries(st.sampled_from(["thumb", "index", "bad name"]), st.lists(st.floats(-1, 1), max_size=10)),
)


def _toml(v: object) -> str:
    """``v`` as a TOML value (the stdlib has no TOML writer)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    assert isinstance(v, dict)
    return "{" + ", ".join(f"{json.dumps(k)} = {_toml(x)}" for k, x in v.items()) + "}"


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    hand_name=st.sampled_from([LEAP, OTHER, "bad name", "", "ok-1.2", "a.b"]),
    table=st.dictionaries(_KEYS, _VALUES, max_size=4),
)
def test_any_hand_table_loads_or_is_refused_in_one_line(tmp_path, hand_name, table):
    """An object file is untrusted input: whatever a hand table holds, loading gives profiles
    or one ConfigError line naming the file and the hand table, never another exception; a
    table that loads applies to its hand only."""
    body = "\n".join(f"{json.dumps(k)} = {_toml(v)}" for k, v in table.items())
    path = _file(tmp_path, OBJECTS_TOML.read_text() + f"\n[objects.lego.hands.{json.dumps(hand_name)}]\n{body}\n")
    try:
        mine = load_objects(path, hand_name)["lego"]
    except ConfigError as exc:
        assert _one_line(exc).startswith(f"{path}: objects.lego.hands.")
        with pytest.raises(ConfigError):  # refused whichever hand loads the file
            load_objects(path, "zz_hand")
        return
    assert mine.tuned_for == hand_name
    for key, value in table.items():
        if key != "posture_offsets_rad":
            assert getattr(mine, key) == value
    assert load_objects(path, "zz_hand")["lego"] == load_objects(OBJECTS_TOML, LEAP)["lego"]


# --- run.json ------------------------------------------------------------------------------------


def test_run_json_records_the_hand_whose_table_applied():
    profiles = load_objects(OBJECTS_TOML, LEAP)
    stored = json.loads(json.dumps(profile_json(profiles["cleanser"])))
    assert stored["tuned_for"] == LEAP and stored["tau_n"] == 2.5
    assert profile_from_json("cleanser", stored, "run.json", "objects.") == profiles["cleanser"]
    # an object without a table (and a run made before the tables): no key, as before
    assert "tuned_for" not in profile_json(profiles["lego"])
    old = {k: v for k, v in stored.items() if k != "tuned_for"}
    assert profile_from_json("cleanser", old, "run.json", "objects.").tuned_for is None
    with pytest.raises(ConfigError) as exc:
        profile_from_json("cleanser", dict(stored, tuned_for="a/b"), "run.json", "objects.")
    assert _one_line(exc.value).startswith("run.json: objects.cleanser.tuned_for: an identifier")
    with pytest.raises(ConfigError, match=r"objects\.cleanser\.hands: a known key"):
        profile_from_json("cleanser", dict(stored, hands={}), "run.json", "objects.")


def test_a_run_on_another_hand_runs_the_object_level_values(tmp_path):
    from grasp_ctrl.cli import main
    from grasp_ctrl.files.paths import default_hand_file

    hand_file = tmp_path / "other_hand.toml"
    text = default_hand_file().read_text()
    assert text.count('\nname = "leap_hand"\n') == 1
    hand_file.write_text(text.replace('\nname = "leap_hand"\n', '\nname = "other_hand"\n'))
    out = tmp_path / "run"
    argv = ["run", "--backend", "mock", "--policy", "oracle", "--objects", "cleanser", "--trials", "1"]
    assert main([*argv, "--no-tick-logs", "--quiet", "--hand", str(hand_file), "--out", str(out)]) in (0, 1)
    (cleanser,) = json.loads((out / "run.json").read_text())["objects"]
    assert (cleanser["tau_n"], cleanser["grip_targets"], cleanser.get("tuned_for")) == (2.0, None, None)
    (record,) = (out / "trials").rglob("trial_000.json")
    assert json.loads(record.read_text())["settings"]["tau_n"] == 2.0


# --- tune --write -------------------------------------------------------------------------------


@pytest.fixture
def objects_copy(tmp_path) -> Path:
    path = tmp_path / "objects.toml"
    shutil.copy(OBJECTS_TOML, path)
    return path


def test_write_lands_in_the_tuned_hands_table_only(objects_copy):
    leap_before = load_objects(objects_copy, LEAP)
    diff = update_objects_file(
        objects_copy,
        {"cleanser": {"tau_n": 1.75}, "lego": {"hold_s": 0.75}},
        "grasp-ctrl tune --objects cleanser,lego ... (hand file hand_configs/other_hand.toml, 2026-11-28)",
        hand=OTHER,
    )
    added = [line[1:] for line in diff.splitlines() if line.startswith("+") and not line.startswith("+++")]
    assert not [line for line in diff.splitlines() if line.startswith("-") and not line.startswith("---")]
    assert "[objects.cleanser.hands.other_hand]" in added and "[objects.lego.hands.other_hand]" in added
    assert load_objects(objects_copy, LEAP) == leap_before  # the LEAP's tables and the object level untouched
    assert load_objects(objects_copy) == load_objects(OBJECTS_TOML)
    other = load_objects(objects_copy, OTHER)
    assert (other["cleanser"].tau_n, other["cleanser"].grip_targets, other["cleanser"].tuned_for) == (1.75, None, OTHER)
    assert (other["lego"].hold_s, other["lego"].tau_n) == (0.75, 2.0)
    lines = objects_copy.read_text().splitlines()
    for obj in ("cleanser", "lego"):
        header = lines.index(f"[objects.{obj}.hands.other_hand]")
        assert lines[header - 1].startswith(CHOSEN_BY + "grasp-ctrl tune --objects cleanser,lego")
        assert "other_hand.toml" in lines[header - 1]
    # the LEAP's explanation stays above its own table
    leap_header = lines.index("[objects.cleanser.hands.leap_hand]")
    assert lines[leap_header - 1].startswith("# seed 0, 5 trials): tau 2.25 2/5")


def test_write_for_the_leap_changes_its_table_and_replaces_its_chosen_by_line(objects_copy):
    comment = "grasp-ctrl tune --object mustard_bottle ... (hand file hand_configs/leap_hand.toml, 2026-11-28)"
    for _ in range(2):
        diff = update_objects_file(objects_copy, {"mustard_bottle": {"tau_n": 2.75}}, comment, hand=LEAP)
    assert diff == ""  # the second write found the value there
    text = objects_copy.read_text()
    lines = text.splitlines()
    assert sum(line.startswith(CHOSEN_BY) for line in lines) == 1
    header = lines.index("[objects.mustard_bottle.hands.leap_hand]")
    assert lines[header - 1] == CHOSEN_BY + comment and lines[header + 1] == "tau_n = 2.75"
    assert text.count("tau_n = ") == OBJECTS_TOML.read_text().count("tau_n = ")  # replaced, not added
    assert load_objects(objects_copy, LEAP)["mustard_bottle"].tau_n == 2.75
    assert load_objects(objects_copy, OTHER)["mustard_bottle"].tau_n == 2.0


def test_write_adds_a_leap_table_where_the_object_has_none(objects_copy):
    update_object_file(objects_copy, "paper_cup", {"release_threshold_n": 0.2}, hand=LEAP)
    text = objects_copy.read_text()
    assert "\n[objects.paper_cup.hands.leap_hand]\nrelease_threshold_n = 0.2\n\n[objects.mustard_bottle]" in text
    assert load_objects(objects_copy, LEAP)["paper_cup"].release_threshold_n == 0.2
    assert load_objects(objects_copy, OTHER)["paper_cup"].release_threshold_n == 0.3


def test_write_refuses_a_hand_name_that_cannot_name_a_table(objects_copy):
    before = objects_copy.read_text()
    for bad in ("LEAP Hand", "", "a]b", ".hidden"):
        with pytest.raises(UsageError) as exc:
            update_objects_file(objects_copy, {"lego": {"tau_n": 1.5}}, hand=bad)
        assert "the hand's name" in _one_line(exc.value)
    assert objects_copy.read_text() == before


def test_write_refuses_hands_written_as_one_table(tmp_path):
    path = _with_table(tmp_path, "objects.lego.hands", "other_hand = {tau_n = 1.5}")
    before = path.read_text()
    with pytest.raises(UsageError, match=r"tables of their own"):
        update_objects_file(path, {"lego": {"tau_n": 1.25}}, hand=OTHER)
    assert path.read_text() == before


def test_the_chosen_by_line_names_the_hand_file(tmp_path):
    from grasp_ctrl.cli.cmd_tune import _chosen_by
    from grasp_ctrl.files.paths import default_hand_file

    args = argparse.Namespace(_argv=["tune", "--object", "lego", "--write"], hand=str(default_hand_file()))
    assert "(hand file hand_configs/leap_hand.toml, " in _chosen_by(args)
    elsewhere = tmp_path / "other_hand.toml"
    args = argparse.Namespace(_argv=["tune", "--write"], hand=str(elsewhere))
    assert f"(hand file {elsewhere.resolve()}, " in _chosen_by(args)


def test_tune_write_on_the_mock_writes_the_tuned_hand(tmp_path, capsys):
    pytest.importorskip("optuna")
    from grasp_ctrl.cli import main
    from grasp_ctrl.files.paths import default_hand_file

    hand_file = tmp_path / "other_hand.toml"
    hand_file.write_text(default_hand_file().read_text().replace('\nname = "leap_hand"\n', '\nname = "other_hand"\n'))
    objects_file = tmp_path / "objects.toml"
    shutil.copy(OBJECTS_TOML, objects_file)
    argv = ["tune", "--backend", "mock", "--object", "chips_can", "--param", "tau=2.0", "--trials", "1"]
    argv += ["--policy", "oracle", "--quiet", "--write", "--object-file", str(objects_file), "--hand", str(hand_file)]
    status = main(argv)
    out = capsys.readouterr().out
    if status != 0:
        pytest.skip(f"the one mock trial did not succeed, nothing to write: {out[-300:]}")
    assert "+[objects.chips_can.hands.other_hand]" in out
    assert load_objects(objects_file, "other_hand")["chips_can"].tuned_for == "other_hand"
    assert load_objects(objects_file, LEAP) == load_objects(OBJECTS_TOML, LEAP)
    lines = objects_file.read_text().splitlines()
    header = lines.index("[objects.chips_can.hands.other_hand]")
    assert lines[header - 1].startswith(CHOSEN_BY + "grasp-ctrl tune --backend mock --object chips_can")
    assert f"(hand file {hand_file.resolve()}, " in lines[header - 1]


def test_the_allegro_never_runs_with_the_leaps_thresholds():
    from grasp_ctrl.config.checks import check_objects_for_hand
    from grasp_ctrl.config.hand import load_hand

    allegro = load_hand(REPO_ROOT / "hand_configs" / "allegro_hand.toml")
    shipped = REPO_ROOT / "hand_configs" / "objects.toml"
    leap_profiles = list(load_objects(shipped, "leap_hand").values())
    assert any(o.tuned_for == "leap_hand" for o in leap_profiles)
    with pytest.raises(ConfigError) as info:
        check_objects_for_hand(leap_profiles, allegro, "test")
    assert "hands.leap_hand" in str(info.value) and "allegro_hand" in str(info.value)
    own = list(load_objects(shipped, allegro.name).values())
    check_objects_for_hand(own, allegro, "test")
    assert all(o.tuned_for in (None, "allegro_hand") for o in own)


def test_a_tuning_study_on_anallegro_hand_is_another_study():
    from grasp_ctrl.trials.tuning.search_space import parse_params
    from grasp_ctrl.trials.tuning.study import StudyPlan

    lego = load_objects(REPO_ROOT / "hand_configs" / "objects.toml", "leap_hand")["lego"]
    params = parse_params(["tau_n=1.5:2.5"])
    leap = StudyPlan(lego, params, 2, 0, "oracle", "mujoco", 4)
    allegro = StudyPlan(lego, params, 2, 0, "oracle", "mujoco", 4, hand="allegro_hand")
    assert "hand" not in leap.identity()  # a study stored before hands were named keeps its identity
    assert allegro.identity()["hand"] == "allegro_hand" and allegro.identity() != leap.identity()


def test_a_hand_table_named_almost_like_the_hand_is_named_in_a_note(tmp_path, capsys):
    """A typo in a hand table's name (leap_hnad) would leave the hand's tuned thresholds unused
    without a word: selecting the object names it; another hand's table (allegro_hand) does not."""
    from grasp_ctrl.files.paths import default_objects_file
    from grasp_ctrl.trials.runs.selection import select_objects

    text = (
        default_objects_file()
        .read_text()
        .replace("[objects.cleanser.hands.leap_hand]", "[objects.cleanser.hands.leap_hnad]")
    )
    typo = tmp_path / "objects.toml"
    typo.write_text(text)
    [cleanser] = select_objects(typo, "cleanser", hand="leap_hand")
    err = capsys.readouterr().err
    assert "objects.cleanser.hands.leap_hnad" in err and "typo" in err and cleanser.tuned_for is None
    select_objects(default_objects_file(), "cleanser,mustard_bottle", hand="allegro_hand")
    select_objects(default_objects_file(), "cleanser", hand="leap_hand")
    assert capsys.readouterr().err == ""
