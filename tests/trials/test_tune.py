"""Threshold sweeps: parameter parsing, ranking, editing the object file in place."""

from __future__ import annotations

import json
import shutil

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.cli import main
from grasp_ctrl.config.objects import load_objects
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.paths import REPO_ROOT
from grasp_ctrl.trials.tuning.toml_edit import set_object_value, update_object_file
from grasp_ctrl.trials.tuning.tune import (
    SweepRow,
    apply_setting,
    format_sweep,
    parse_param,
    rank,
    run_sweep,
    settings_grid,
)

OBJECTS_TOML = REPO_ROOT / "hand_configs" / "objects.toml"


def test_parse_ranges_lists_and_aliases():
    assert parse_param("tau_n=1.0:3.0:0.5") == ("tau_n", [1.0, 1.5, 2.0, 2.5, 3.0])
    assert parse_param("tau=1.0:1.3:0.1") == ("tau_n", [1.0, 1.1, 1.2, 1.3])
    assert parse_param("release_threshold=0.2,0.4") == ("release_threshold_n", [0.2, 0.4])
    assert parse_param("release_debounce=2:6:2") == ("release_debounce", [2, 4, 6])
    assert len(settings_grid([parse_param("tau=1:2:0.5"), parse_param("release_debounce=3,5")])) == 6


@pytest.mark.parametrize(
    "spec",
    [
        "tau_n",
        "mass_kg=1",
        "tau_n=3:1:0.5",
        "tau_n=1:2:0",
        "tau_n=a:b:c",
        "release_debounce=1.5",
        "tau_n=1:2",
        "tau_n=nan",
        "tau_n=0:1000:0.001",
        "tau_n=1:20:1e-320",  # a step so small that the count overflows: one line, not OverflowError
        "tau_n=1:20:1e-300",
    ],
)
def test_bad_params_are_usage_errors(spec):
    with pytest.raises(UsageError):
        parse_param(spec)


def test_settings_outside_the_files_limits_are_refused(objects):
    with pytest.raises(UsageError, match="tau_n"):
        apply_setting(objects["lego"], {"tau_n": 50.0})
    assert apply_setting(objects["lego"], {"tau_n": 1.5}).tau_n == 1.5


def _row(setting, ok, n, peak):
    r = SweepRow(setting)
    for i in range(n):
        r.add(
            {
                "success": i < ok,
                "reason": None if i < ok else "slipped",
                "peak_grip_true_n": peak,
                "peak_grip_est_n": peak,
            }
        )
    return r


def test_rank_by_success_then_gentler_grip():
    rows = [_row({"tau_n": 1.0}, 1, 3, 1.0), _row({"tau_n": 2.0}, 3, 3, 2.2), _row({"tau_n": 1.5}, 3, 3, 1.6)]
    ranked = rank(rows)
    assert [r.setting["tau_n"] for r in ranked] == [1.5, 2.0, 1.0]
    table = format_sweep(ranked, {"tau_n": 2.0})
    assert table.splitlines()[2].split()[0] == "2*" and "slipped x2" in table


def test_sweep_rows_do_not_depend_on_the_order_results_arrive(objects):
    def fake(profile, k):
        ok = profile.tau_n * 10 + k
        return {
            "success": ok % 3 != 0,
            "reason": None if ok % 3 else "slipped",
            "peak_grip_true_n": profile.tau_n + 0.1 * k,
            "peak_grip_est_n": profile.tau_n,
        }

    grid = settings_grid([parse_param("tau=1:2:0.5"), parse_param("release_debounce=2,3")])
    seen = []
    in_order = run_sweep(objects["lego"], grid, 3, fake, on_trial=lambda i, s, r: seen.append(i))
    reverse = run_sweep(
        objects["lego"],
        grid,
        3,
        fake,
        run_many=lambda tasks: reversed([(n, fake(p, k)) for n, (_, p, k) in enumerate(tasks)]),
    )
    assert [r.to_json() for r in in_order] == [r.to_json() for r in reverse]
    assert seen == sorted(seen) and len(seen) == 18
    assert [r.trials for r in in_order] == [3] * 6


def test_edit_keeps_comments_and_other_objects():
    text = OBJECTS_TOML.read_text()
    new = set_object_value(text, "lego", "tau_n", 1.75)  # absent key: inserted
    new = set_object_value(new, "lego", "mu", 0.85)  # present key: replaced
    old_lines, new_lines = text.splitlines(), new.splitlines()
    assert len(new_lines) == len(old_lines) + 1
    assert [l for l in old_lines if l.lstrip().startswith("#")] == [l for l in new_lines if l.lstrip().startswith("#")]
    changed = [l for l in new_lines if l not in old_lines]
    assert changed == ["mu = 0.85", "tau_n = 1.75"]


def test_edit_keeps_an_inline_comment(tmp_path):
    text = '[objects.a]\nshape = "box"\ntau_n = 2.0   # tuned 2026\n\n[objects.b]\ntau_n = 1.0\n'
    new = set_object_value(text, "a", "tau_n", 2.5)
    assert new == '[objects.a]\nshape = "box"\ntau_n = 2.5   # tuned 2026\n\n[objects.b]\ntau_n = 1.0\n'
    with pytest.raises(UsageError, match="objects.c"):
        set_object_value(text, "c", "tau_n", 1.0)


@settings(max_examples=25, deadline=None)
@given(
    name=st.sampled_from(["chips_can", "lego", "paper_cup", "mustard_bottle"]),
    tau=st.floats(0.1, 20.0),
    threshold=st.floats(0.0, 10.0, exclude_min=True),
    debounce=st.integers(1, 1000),
)
def test_written_values_read_back_exactly(tmp_path_factory, name, tau, threshold, debounce):
    path = tmp_path_factory.mktemp("tune") / "objects.toml"
    shutil.copy(OBJECTS_TOML, path)
    values = {"tau_n": tau, "release_threshold_n": threshold, "release_debounce": debounce}
    diff = update_object_file(path, name, values, hand="leap_hand")
    profiles = load_objects(path, "leap_hand")
    before = load_objects(OBJECTS_TOML, "leap_hand")
    for key, value in values.items():
        assert getattr(profiles[name], key) == value
    assert all(profiles[o] == before[o] for o in before if o != name)
    assert diff.startswith("---") or diff == ""


def test_tune_command_ranks_and_writes_the_best_setting(tmp_path, capsys):
    objects_file = tmp_path / "objects.toml"
    shutil.copy(OBJECTS_TOML, objects_file)
    out = tmp_path / "sweep.json"
    pytest.importorskip("optuna")
    status = main(
        [
            "tune",
            "--backend",
            "mock",
            "--object",
            "lego",
            "--param",
            "tau=1.5,2.5",
            "--trials",
            "1",
            "--policy",
            "oracle",
            "--object-file",
            str(objects_file),
            "--write",
            "--json",
            str(out),
            "--quiet",
            "--jobs",
            "2",
        ]
    )
    doc = json.loads(out.read_text())
    ranked = doc["ranked"]
    assert [r["trials"] for r in ranked] == [1, 1] and {r["setting"]["tau_n"] for r in ranked} == {1.5, 2.5}
    keys = [(-r["success_rate"], r["mean_peak_grip_true_n"]) for r in ranked]
    assert keys == sorted(keys)
    printed = capsys.readouterr().out
    after = load_objects(objects_file)["lego"].tau_n
    if ranked[0]["successes"]:
        assert status == 0 and after == ranked[0]["setting"]["tau_n"]
        assert f"+tau_n = {after}" in printed
    else:
        assert status == 1 and objects_file.read_text() == OBJECTS_TOML.read_text()


def test_tune_on_the_real_hand_ranks_by_the_operators_labels(tmp_path, capsys, monkeypatch):
    """`tune --backend dynamixel`: no ground truth, so each trial is labelled at the
    prompt; the sweep ranks by those labels and writes the winner."""
    import io

    pytest.importorskip("optuna")
    import grasp_ctrl.trials.episode.hardware as hardware

    seen = []

    def fake_hardware_trial_fn(hand, policies, settings, jobs, port=None, sensor_port=None):
        assert (port, sensor_port) == ("/dev/ttyUSB7", "/dev/ttyACM7")

        def trial(policy, obj, k, seed, log_path):
            seen.append(obj.tau_n)
            return {
                "object": obj.name,
                "policy": policy,
                "trial": k,
                "seed": seed,
                "success": True,
                "reason": None,
                "final_state": "done",
                "backend": "dynamixel",
                "judged_by": "controller",
                "controller": {"final_state": "done", "success": True, "reason": None},
                "peak_grip_est_n": obj.tau_n,
            }

        return trial

    monkeypatch.setattr(hardware, "hardware_trial_fn", fake_hardware_trial_fn)
    # The controller thinks both went well; the operator saw the gentler grasp slip.
    monkeypatch.setattr("sys.stdin", io.StringIO("f\nslipped\nslid down\ns\n\n"))
    objects_file = tmp_path / "objects.toml"
    shutil.copy(OBJECTS_TOML, objects_file)
    out = tmp_path / "sweep.json"
    status = main(
        [
            "tune",
            "--object",
            "lego",
            "--param",
            "tau=1.5,2.5",
            "--trials",
            "1",
            "--policy",
            "linear_mock",
            "--backend",
            "dynamixel",
            "--port",
            "/dev/ttyUSB7",
            "--sensor-port",
            "/dev/ttyACM7",
            "--object-file",
            str(objects_file),
            "--write",
            "--json",
            str(out),
            "--quiet",
        ]
    )
    assert status == 0 and seen == [1.5, 2.5]
    ranked = json.loads(out.read_text())["ranked"]
    assert [(r["setting"]["tau_n"], r["successes"], r["failures"]) for r in ranked] == [
        (2.5, 1, {}),
        (1.5, 0, {"slipped": 1}),
    ]
    assert load_objects(objects_file, "leap_hand")["lego"].tau_n == 2.5
    assert "+tau_n = 2.5" in capsys.readouterr().out
    assert main(["tune", "--object", "lego", "--param", "tau=2", "--backend", "dynamixel", "--jobs", "2"]) == 2
    assert "one trial at a time" in capsys.readouterr().err
