"""The grasp as object-file keys (approach offset, standoff, posture offsets) and `tune`'s search of
them: loading and validation, what the controller and the worlds make of them, the Wilson ranking,
`tune --write` with the command that chose the values, and runs that resume as before."""

from __future__ import annotations

import dataclasses
import json
import shutil

import numpy as np
import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.config.checks import check_objects_for_hand
from grasp_ctrl.config.objects import load_objects, profile_from_json, profile_json
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.registry import settings_for
from grasp_ctrl.errors import ConfigError, UsageError
from grasp_ctrl.files.paths import REPO_ROOT
from grasp_ctrl.trials.tuning.toml_edit import CHOSEN_BY, set_object_value
from grasp_ctrl.trials.tuning.tune import SweepRow, apply_setting, controller_settings, rank, wilson_lower

OBJECTS_TOML = REPO_ROOT / "hand_configs" / "objects.toml"
GRASP_KEYS = ("approach_offset_m", "standoff_m", "posture_offsets_rad")


def _objects_with(tmp_path, obj: str, **values):
    """A copy of the shipped object file with ``values`` set in ``[objects.OBJ]``; its path."""
    text = OBJECTS_TOML.read_text()
    for key, value in values.items():
        text = set_object_value(text, obj, key, value)
    path = tmp_path / "objects.toml"
    path.write_text(text)
    return path


# --- the keys ---------------------------------------------------------------------------------


def test_the_grasp_keys_load_with_their_defaults(tmp_path, objects):
    lego = objects["lego"]
    assert (lego.approach_offset_m, lego.standoff_m, lego.posture_offsets_rad) == (0.0, None, None)
    path = _objects_with(
        tmp_path,
        "lego",
        approach_offset_m=0.004,
        standoff_m=0.02,
        posture_offsets_rad={"index": [0.0, 0.05, 0.0, -0.1], "thumb": [0.1, 0.0, 0.0, 0.0]},
    )
    tuned = load_objects(path)["lego"]
    assert tuned.approach_offset_m == 0.004 and tuned.standoff_m == 0.02
    assert tuned.posture_offsets() == {"index": (0.0, 0.05, 0.0, -0.1), "thumb": (0.1, 0.0, 0.0, 0.0)}
    hash(tuned)  # the preshape and posture caches key on the profile


@pytest.mark.parametrize(
    ("key", "value", "named"),
    [
        ("approach_offset_m", 0.2, "objects.lego.approach_offset_m"),
        ("approach_offset_m", -0.04, "objects.lego.approach_offset_m"),  # the grasp below the table
        ("standoff_m", 0.0, "objects.lego.standoff_m"),
        ("standoff_m", 0.5, "objects.lego.standoff_m"),
        ("posture_offsets_rad", {"index": [0.0, 0.3, 0.0, 0.0]}, "objects.lego.posture_offsets_rad.index"),
        ("posture_offsets_rad", {"index": []}, "objects.lego.posture_offsets_rad.index"),
    ],
)
def test_bad_grasp_values_are_one_line_naming_the_key(tmp_path, key, value, named):
    path = _objects_with(tmp_path, "lego", **{key: value})
    with pytest.raises(ConfigError) as err:
        load_objects(path)
    text = str(err.value)
    assert named in text and str(path) in text and "\n" not in text


def test_posture_fingers_and_joint_counts_are_checked_against_the_hand(hand, objects):
    lego = objects["lego"]
    check_objects_for_hand([lego.with_params(posture_offsets_rad=(("index", (0.0, 0.1, 0.0, 0.0)),))], hand, "x")
    for posture, said in [
        ((("pinky", (0.1,)),), "posture_offsets_rad.pinky"),
        ((("index", (0.1, 0.0)),), "4 offsets, one per joint of finger index"),
    ]:
        with pytest.raises(ConfigError, match=said) as err:
            check_objects_for_hand([lego.with_params(posture_offsets_rad=posture)], hand, "objects.toml")
        assert "\n" not in str(err.value)


# --- what the controller and the worlds make of them -------------------------------------------


def test_the_objects_standoff_replaces_the_controllers(hand, objects):
    lego = objects["lego"]
    pose = np.array([0.0, 0.0, 0.15])
    shipped = GraspController(hand, lego, pose)
    own = GraspController(hand, lego.with_params(standoff_m=0.025), pose)
    same = GraspController(hand, lego, pose, PaperSettings(preshape_standoff_m=0.025))
    assert shipped._preshape_standoff_m() == PaperSettings().preshape_standoff_m
    assert own._preshape_standoff_m() == 0.025
    assert not np.allclose(shipped.reach_q, own.reach_q)
    np.testing.assert_array_equal(own.reach_q, same.reach_q)


def test_a_posture_offset_moves_that_joint_clamped_to_its_limit(hand, objects):
    lego = objects["lego"]
    pose = np.array([0.0, 0.0, 0.15])
    base = GraspController(hand, lego, pose).reach_q
    sl = hand.joint_slice("index")
    moved = GraspController(hand, lego.with_params(posture_offsets_rad=(("index", (0.0, 0.0, 0.05, 0.0)),)), pose)
    expected = base.copy()
    expected[sl.start + 2] += 0.05
    np.testing.assert_allclose(moved.reach_q, expected, atol=1e-12)
    # past the joint's limit (the object file bounds offsets to 0.2 rad; a profile made in code may not)
    far = GraspController(hand, lego.with_params(posture_offsets_rad=(("index", (0.0, 0.0, 5.0, 0.0)),)), pose)
    assert far.reach_q[sl.start + 2] == hand.joints[sl.start + 2].upper_rad
    with pytest.raises(ConfigError, match="posture_offsets_rad.index"):
        GraspController(hand, lego.with_params(posture_offsets_rad=(("index", (0.1,)),)), pose)


def test_an_approach_offset_moves_every_worlds_reach_pose_by_exactly_it(hand, objects):
    from grasp_ctrl.sim.mock.world import MockWorld
    from grasp_ctrl.sim.mujoco.world import MuJoCoWorld
    from grasp_ctrl.trials.episode.hardware import reach_pose_world

    lego = objects["lego"]
    raised = lego.with_params(approach_offset_m=0.007)
    for make in (lambda o: MuJoCoWorld(hand, o, 3), lambda o: MockWorld(hand, o, 3)):
        a, b = make(lego).reach_pose_world(), make(raised).reach_pose_world()
        assert b[2] - a[2] == pytest.approx(0.007, abs=1e-12) and a[:2].tolist() == b[:2].tolist()
    assert reach_pose_world(hand, raised)[2] - reach_pose_world(hand, lego)[2] == pytest.approx(0.007, abs=1e-12)


# --- the search ---------------------------------------------------------------------------------


def test_wilson_lower_bound_known_values():
    assert wilson_lower(5, 5) == pytest.approx(0.566, abs=5e-4)
    assert wilson_lower(0, 5) == 0.0
    assert wilson_lower(3, 5) == pytest.approx(0.231, abs=5e-4)


def _row(setting, ok, n, peak=1.0):
    r = SweepRow(setting)
    for i in range(n):
        r.add({"success": i < ok, "reason": None if i < ok else "slipped", "peak_grip_true_n": peak})
    return r


def test_wilson_ranking_weighs_the_evidence_and_breaks_ties_by_the_gentler_grip():
    few, many = _row({"a": 1}, 2, 2), _row({"a": 2}, 9, 10)
    assert [r.setting["a"] for r in rank([few, many], "mean")] == [1, 2]  # 100 % over 90 %
    assert [r.setting["a"] for r in rank([few, many])] == [2, 1]  # 0.60 over 0.34
    soft, hard = _row({"a": 3}, 4, 5, peak=1.0), _row({"a": 4}, 4, 5, peak=2.0)
    assert [r.setting["a"] for r in rank([hard, soft])] == [3, 4]


def test_the_objective_never_trades_a_success_for_a_gentler_grip():
    pytest.importorskip("optuna")
    from grasp_ctrl.trials.tuning.study import objective_value

    for k in (1, 2, 5, 8, 30):
        for s in range(k):
            assert objective_value(s + 1, k, 1e9) > objective_value(s, k, 0.0)
        assert objective_value(k, k, 1.0) > objective_value(k, k, 2.0)


def test_setting_and_posture_params_parse_and_apply(hand, objects):
    from grasp_ctrl.trials.tuning.search_space import check_params_for_hand, parse_params

    params = parse_params(["posture.thumb.2=-0.1:0.1", "setting.grip_margin=1.1:1.6", "approach_offset_m=-0.01:0.01"])
    joints = check_params_for_hand(params, hand)
    setting = {"posture.thumb.2": 0.05, "setting.grip_margin": 1.4, "approach_offset_m": -0.003}
    tuned = apply_setting(objects["cleanser"], setting, joints)
    assert tuned.posture_offsets() == {"thumb": (0.0, 0.0, 0.05, 0.0)} and tuned.approach_offset_m == -0.003
    assert controller_settings(settings_for("grip_load"), setting).coordination.grip_margin == 1.4
    for spec, said in [
        ("posture.pinky.0=0:0.1", "not a finger"),
        ("posture.index.4=0:0.1", "joints 0 to 3"),
    ]:
        with pytest.raises(UsageError, match=said):
            check_params_for_hand(parse_params([spec]), hand)
    for spec in ("setting.controller=1:2", "setting.slip_pac_ticks=1:3", "posture.index=0:0.1", "nothing=1:2"):
        with pytest.raises(UsageError, match="--param"):
            parse_params([spec])
    with pytest.raises(UsageError, match="posture_offsets_rad.index"):
        apply_setting(objects["lego"], {"posture.index.1": 0.5}, joints)  # beyond the file's 0.2 rad


def test_tune_searches_the_standoff_in_mujoco_and_writes_it_with_the_command(tmp_path, capsys):
    pytest.importorskip("optuna")
    objects_file = tmp_path / "objects.toml"
    shutil.copy(OBJECTS_TOML, objects_file)
    out = tmp_path / "tune.json"
    argv = [
        "tune",
        "--object",
        "lego",
        "--policy",
        "oracle",
        "--controller",
        "paper",
        "--param",
        "standoff_m=0.008:0.012",  # around the controller's 0.01 m: the seed-0 trial succeeds
        "--trials",
        "1",
        "--budget",
        "2",
        "--object-file",
        str(objects_file),
        "--json",
        str(out),
        "--quiet",
        "--write",
    ]
    status = main(argv)
    doc = json.loads(out.read_text())
    printed = capsys.readouterr().out
    assert doc["backend"] == "mujoco" and doc["variation"]["name"] == "bench" and doc["rank"] == "wilson"
    assert "wilson lb" in printed and len(doc["ranked"]) == 2
    for r in doc["ranked"]:
        assert r["wilson_lower"] == pytest.approx(wilson_lower(r["successes"], r["trials"]), abs=1e-4)
    best = doc["best"]
    assert status == 0 and best["successes"] == 1
    tuned = load_objects(objects_file, "leap_hand")["lego"]
    assert tuned.standoff_m == pytest.approx(best["setting"]["standoff_m"], abs=1e-12)
    assert tuned.tuned_for == "leap_hand" and load_objects(objects_file)["lego"].standoff_m is None
    lines = objects_file.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("[objects.lego.hands.leap_hand]"))
    assert lines[header - 1].startswith(CHOSEN_BY + "grasp-ctrl tune --object lego --policy oracle --controller")
    assert "standoff_m=0.008:0.012" in lines[header - 1] and "--write" in lines[header - 1]
    assert "(hand file hand_configs/leap_hand.toml, " in lines[header - 1]
    # Written again: the comment is replaced, not repeated.
    assert main(argv) == 0
    assert sum(line.startswith(CHOSEN_BY) for line in objects_file.read_text().splitlines()) == 1


def test_write_puts_a_posture_table_in_the_file(tmp_path):
    from grasp_ctrl.trials.tuning.toml_edit import update_objects_file

    objects_file = tmp_path / "objects.toml"
    shutil.copy(OBJECTS_TOML, objects_file)
    diff = update_objects_file(
        objects_file,
        {"mustard_bottle": {"posture_offsets_rad": {"thumb": [0.0, 0.0, -0.05, 0.1]}, "approach_offset_m": 0.005}},
        "grasp-ctrl tune --object mustard_bottle ... (2026-11-27)",
        hand="leap_hand",
    )
    assert "+posture_offsets_rad = {thumb = [0.0, 0.0, -0.05, 0.1]}" in diff
    after = load_objects(objects_file, "leap_hand")["mustard_bottle"]
    assert after.posture_offsets() == {"thumb": (0.0, 0.0, -0.05, 0.1)} and after.approach_offset_m == 0.005
    assert after.cap is not None  # the keys went into the LEAP hand's table, before the cap's
    assert load_objects(objects_file)["mustard_bottle"].posture_offsets_rad is None  # not the object's own


# --- runs ---------------------------------------------------------------------------------------


def test_runs_store_the_grasp_keys_only_where_set_and_resume(tmp_path, objects, capsys):
    # A profile at the defaults is stored as before the keys existed: older runs keep their fingerprint.
    stored = profile_json(objects["lego"])
    assert not set(GRASP_KEYS) & set(stored)
    assert stored == {
        k: v for k, v in dataclasses.asdict(objects["lego"]).items() if k not in (*GRASP_KEYS, "tuned_for")
    }
    tuned = objects["lego"].with_params(
        approach_offset_m=0.003, standoff_m=0.02, posture_offsets_rad=(("index", (0.0, 0.1, 0.0, 0.0)),)
    )
    back = profile_from_json("lego", json.loads(json.dumps(profile_json(tuned))), "run.json", "objects.")
    assert back == tuned
    # A run on an object file with the keys resumes; a change of one of them refuses to.
    path = _objects_with(tmp_path, "lego", approach_offset_m=0.003, standoff_m=0.02)
    run_dir = tmp_path / "run"
    common = ["--backend", "mock", "--policy", "oracle", "--quiet"]
    assert (
        main(["run", "--objects", "lego", "--trials", "2", "--object-file", str(path), "--out", str(run_dir), *common])
        == 0
    )
    run_json = json.loads((run_dir / "run.json").read_text())
    assert run_json["objects"][0]["standoff_m"] == 0.02 and run_json["objects"][0]["approach_offset_m"] == 0.003
    record = next((run_dir / "trials").rglob("trial_001.json"))
    record.unlink()
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 0
    assert record.is_file()
    record.unlink()
    path.write_text(path.read_text().replace("standoff_m = 0.02", "standoff_m = 0.021"))
    capsys.readouterr()
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 2
    assert "object_file" in capsys.readouterr().err


def test_controller_settings_are_searched_alike_here_and_in_workers(tmp_path):
    pytest.importorskip("optuna")
    common = [
        "tune",
        "--backend",
        "mock",
        "--object",
        "lego",
        "--controller",
        "paper",
        "--param",
        "setting.preshape_standoff_m=0.005,0.025",
        "--trials",
        "1",
        "--policy",
        "oracle",
        "--quiet",
        "--no-prune",
    ]
    assert main([*common, "--json", str(tmp_path / "serial.json")]) == 0
    assert main([*common, "--jobs", "2", "--json", str(tmp_path / "jobs.json")]) == 0
    serial, jobs = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("serial", "jobs"))
    assert serial["controller"] == "paper" and serial["current"] == {"setting.preshape_standoff_m": 0.01}
    strip = [{k: r[k] for k in ("setting", "successes", "mean_peak_grip_true_n")} for r in serial["ranked"]]
    assert strip == [{k: r[k] for k in ("setting", "successes", "mean_peak_grip_true_n")} for r in jobs["ranked"]]
    # each setting ran with its own standoff: the two grasps differ
    assert len({r["mean_peak_grip_true_n"] for r in serial["ranked"]}) == 2
