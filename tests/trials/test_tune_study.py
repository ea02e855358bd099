"""`tune` as an Optuna study: the search space, the objective, pruning, the stored study's resume
(skipped without the tune extra), and --write through a symlink."""

from __future__ import annotations

import json
import math
import os
import shutil
import stat

import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.config.objects import load_objects
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.paths import REPO_ROOT
from grasp_ctrl.trials.tuning.search_space import corner_settings, parse_params, parse_space
from grasp_ctrl.trials.tuning.toml_edit import update_objects_file
from grasp_ctrl.trials.tuning.tune import wilson_interval

OBJECTS_TOML = REPO_ROOT / "hand_configs" / "objects.toml"


def test_ranges_logs_and_grids():
    p = parse_space("tau=1.0:3.5")
    assert (p.name, p.low, p.high, p.log, p.is_grid) == ("tau_n", 1.0, 3.5, False, False)
    assert parse_space("release_threshold_n=0.05:0.6:log").log
    assert parse_space("tau_n=1:2:0.5").values == (1.0, 1.5, 2.0)
    assert parse_space("release_debounce=2,4").values == (2, 4)
    d = parse_space("release_debounce=2:9")
    assert d.integer and d.ends() == (2, 9)
    assert corner_settings(parse_params(["tau=1:3", "release_debounce=2,4"])) == [
        {"tau_n": 1.0, "release_debounce": 2},
        {"tau_n": 1.0, "release_debounce": 2},
        {"tau_n": 3.0, "release_debounce": 2},
        {"tau_n": 1.0, "release_debounce": 2},
        {"tau_n": 1.0, "release_debounce": 4},
    ]


@pytest.mark.parametrize(
    "spec, why",
    [
        ("tau=1:inf:1", "finite"),
        ("tau=1:inf", "finite"),
        ("tau=nan:2", "finite"),
        ("tau=-inf:2", "finite"),
        ("tau=3:1", "LOW < HIGH"),
        ("tau=2:2", "LOW < HIGH"),
        ("tau=0:1:log", "LOW > 0"),
        ("tau=1,inf", "finite"),
        ("release_debounce=1.5:4", "whole"),
        ("tau=a:b", "not a number"),
        ("mass_kg=1:2", "not tunable"),
        ("tau=", "expected"),
        ("tau=1:2:3:4", "values must be numbers"),
    ],
)
def test_bad_ranges_are_one_line_errors(spec, why):
    with pytest.raises(UsageError, match=why):
        parse_space(spec)


def test_bad_param_on_the_command_line_is_one_line(capsys):
    assert main(["tune", "--object", "lego", "--param", "tau=1:inf:1", "--backend", "mock", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "finite" in err[0] and "Traceback" not in err[0]


def test_wilson_interval():
    lo, hi = wilson_interval(2, 2)
    assert math.isclose(lo, 0.3424, abs_tol=1e-4) and hi == 1.0
    lo, hi = wilson_interval(0, 10)
    assert lo == 0.0 and math.isclose(hi, 0.2775, abs_tol=1e-4)
    lo, hi = wilson_interval(5, 10)
    assert math.isclose(lo, 0.2366, abs_tol=1e-4) and math.isclose(hi, 0.7634, abs_tol=1e-4)


def test_write_follows_a_symlink_and_keeps_the_mode(tmp_path):
    target = tmp_path / "real" / "objects.toml"
    target.parent.mkdir()
    shutil.copy(OBJECTS_TOML, target)
    os.chmod(target, 0o640)
    link = tmp_path / "objects.toml"
    link.symlink_to(target)
    diff = update_objects_file(
        link, {"lego": {"tau_n": 1.75}, "paper_cup": {"release_threshold_n": 0.2}}, hand="leap_hand"
    )
    assert "+tau_n = 1.75" in diff and link.is_symlink() and os.readlink(link) == str(target)
    assert stat.S_IMODE(target.stat().st_mode) == 0o640
    profiles = load_objects(target, "leap_hand")
    assert profiles["lego"].tau_n == 1.75 and profiles["paper_cup"].release_threshold_n == 0.2
    assert not [p for p in target.parent.iterdir() if p.name != "objects.toml"]  # no temporary file left


# --- the study (the tune extra) --------------------------------------------------------------

optuna = pytest.importorskip("optuna")

from grasp_ctrl.trials.tuning.study import (
    StudyPlan,
    finished_settings,
    objective_value,
    open_study,
    run_study,
    setting_key,
)
from grasp_ctrl.trials.tuning.tune_executors import SerialExecutor


def test_objective_counts_successes_first_then_gentler_grip():
    assert objective_value(3, 3, 9.0) > objective_value(2, 3, 0.1)
    assert objective_value(2, 3, 1.0) > objective_value(2, 3, 1.5)
    assert objective_value(1, 50, 100.0) > objective_value(0, 50, 0.0)


class FakeTrials:
    """Records that depend on the setting only (a grip below 2 N slips), counting the calls;
    ``stop_after`` raises KeyboardInterrupt on that call (Ctrl-C mid-study)."""

    def __init__(self, stop_after: int | None = None) -> None:
        self.calls: list[tuple[float, float, int, int]] = []
        self.stop_after = stop_after

    def __call__(self, policy, profile, k, seed, log_path):
        if self.stop_after is not None and len(self.calls) == self.stop_after:
            raise KeyboardInterrupt
        self.calls.append((profile.tau_n, profile.release_threshold_n, k, seed))
        ok = profile.tau_n >= 2.0
        return {
            "success": ok,
            "reason": None if ok else "slipped",
            "peak_grip_true_n": profile.tau_n,
            "peak_grip_est_n": profile.tau_n,
        }


def _plan(objects, specs, budget, storage, trials=2, prune=True):
    return StudyPlan(objects["lego"], parse_params(specs), trials, 0, "oracle", "mock", budget, storage, prune=prune)


def test_an_interrupted_study_continues_without_repeating_finished_settings(objects, tmp_path):
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    plan = _plan(objects, ["tau=1.0:3.5", "release_threshold_n=0.05:0.6"], 6, storage, trials=3, prune=False)
    first = FakeTrials(stop_after=7)  # two settings finished, the third stopped after its first trial
    with pytest.raises(KeyboardInterrupt):
        run_study(open_study(plan), plan, SerialExecutor(first), jobs=1)
    study = optuna.load_study(study_name=plan.study_name(), storage=storage)
    assert len(finished_settings(study)) == 2
    dropped = [t for t in study.trials if t.state == optuna.trial.TrialState.FAIL]
    assert len(dropped) == 1 and dropped[0].user_attrs["interrupted"]
    # The same command again: the dropped setting runs again from its first trial, the rest are new.
    second = FakeTrials()
    ran = run_study(open_study(plan), plan, SerialExecutor(second), jobs=1)
    study = optuna.load_study(study_name=plan.study_name(), storage=storage)
    done = finished_settings(study)
    assert ran == 4 and len(done) == 6
    keys = [setting_key(t.params) for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    assert len(keys) == len(set(keys)) == 6
    first_settings = {(tau, thr) for tau, thr, _, _ in first.calls}
    second_settings = {(tau, thr) for tau, thr, _, _ in second.calls}
    assert setting_key(dropped[0].params) in {
        setting_key({"tau_n": a, "release_threshold_n": b}) for a, b in second_settings
    }
    assert len(first_settings & second_settings) == 1  # only the dropped one ran again
    # Every setting ran the same seeds, in order.
    for tau, thr in second_settings:
        assert [(k, s) for a, b, k, s in second.calls if (a, b) == (tau, thr)] == list(enumerate(plan.seeds))
    # A third run has nothing left to do.
    assert run_study(open_study(plan), plan, SerialExecutor(FakeTrials()), jobs=1) == 0


def test_a_grid_is_walked_once_even_across_an_interruption(objects, tmp_path):
    storage = f"sqlite:///{tmp_path / 'grid.db'}"
    plan = _plan(objects, ["tau=1.0:3.0:0.5", "release_debounce=2,4"], 10, storage, trials=1, prune=False)
    with pytest.raises(KeyboardInterrupt):
        run_study(open_study(plan), plan, SerialExecutor(FakeTrials(stop_after=4)), jobs=1)
    rest = FakeTrials()
    study = open_study(plan)
    assert isinstance(study.sampler, optuna.samplers.GridSampler)
    run_study(study, plan, SerialExecutor(rest), jobs=1)
    done = finished_settings(optuna.load_study(study_name=plan.study_name(), storage=storage))
    assert len(done) == 10 and len(rest.calls) == 6


def test_settings_that_can_no_longer_win_are_pruned(objects):
    plan = _plan(objects, ["tau=1.0,1.5,2.5,3.0"], 4, None, trials=3)
    fake = FakeTrials()
    study = open_study(plan)
    run_study(study, plan, SerialExecutor(fake), jobs=1)
    order = [tau for tau, _, k, _ in fake.calls if k == 0]  # settings in the order they started
    assert sorted(order) == [1.0, 1.5, 2.5, 3.0]
    by_tau = {t.params["tau_n"]: t for t in study.trials}
    first_good = min(order.index(2.5), order.index(3.0))
    for i, tau in enumerate(order):
        t = by_tau[tau]
        if tau >= 2.0 or i < first_good:  # nothing better had finished yet: all three trials
            assert t.state == optuna.trial.TrialState.COMPLETE and len(t.user_attrs["records"]) == 3
        else:  # 0/1 after a 3/3 setting: cannot win, stopped
            assert t.state == optuna.trial.TrialState.PRUNED and len(t.user_attrs["records"]) == 1


def test_tune_command_on_the_mock_keeps_and_continues_its_study(tmp_path, capsys):
    storage = f"sqlite:///{tmp_path / 'tune.db'}"
    out = tmp_path / "tune.json"
    objects_file = tmp_path / "objects.toml"
    shutil.copy(OBJECTS_TOML, objects_file)
    common = [
        "tune",
        "--backend",
        "mock",
        "--variation",
        "nominal",  # the mock lifts the lego here, so --write has a best setting to write
        "--object",
        "lego",
        "--param",
        "tau=1.5:3.0",
        "--param",
        "release_threshold_n=0.1:0.5:log",
        "--trials",
        "1",
        "--policy",
        "oracle",
        "--storage",
        storage,
        "--json",
        str(out),
        "--quiet",
        "--object-file",
        str(objects_file),
    ]
    assert main([*common, "--budget", "2"]) == 0
    doc = json.loads(out.read_text())
    assert len(doc["ranked"]) == 2 and doc["sampler"] == "TPE" and doc["trials"] == 1
    assert "95 % Wilson interval" in capsys.readouterr().out
    assert main([*common, "--budget", "3", "--write"]) == 0  # the seeded study's best setting lifts the lego
    doc = json.loads(out.read_text())
    printed = capsys.readouterr().out
    assert len(doc["ranked"]) == 3 and "(1 now" in printed
    assert len({json.dumps(r["setting"], sort_keys=True) for r in doc["ranked"]}) == 3
    best = doc["best"]
    assert best["successes"] == 1
    assert load_objects(objects_file, "leap_hand")["lego"].tau_n == best["setting"]["tau_n"]
    assert 0.0 <= best["wilson_95"][0] <= best["success_rate"] <= best["wilson_95"][1] <= 1.0


def test_tune_objects_writes_one_file_and_draws_the_study(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    objects_file = tmp_path / "objects.toml"
    shutil.copy(OBJECTS_TOML, objects_file)
    out = tmp_path / "all.json"
    status = main(
        [
            "tune",
            "--backend",
            "mock",
            "--objects",
            "lego,chips_can",
            "--param",
            "tau=2.0,2.5",
            "--trials",
            "1",
            "--policy",
            "oracle",
            "--json",
            str(out),
            "--quiet",
            "--write",
            "--object-file",
            str(objects_file),
            "--plots",
            str(tmp_path / "plots"),
        ]
    )
    docs = json.loads(out.read_text())["objects"]
    assert [d["object"] for d in docs] == ["lego", "chips_can"] and all(d["sampler"] == "grid" for d in docs)
    assert all(len(d["ranked"]) == 2 for d in docs)
    after = load_objects(objects_file, "leap_hand")
    for d in docs:
        if d["best"]["successes"]:
            assert status == 0 and after[d["object"]].tau_n == d["best"]["setting"]["tau_n"]
    assert (tmp_path / "plots" / "lego_history.png").is_file()
    assert (tmp_path / "plots" / "lego_importances.png").is_file()


def test_parallel_settings_rank_like_serial(tmp_path):
    common = [
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
        "--quiet",
        "--no-prune",
    ]
    assert main([*common, "--json", str(tmp_path / "serial.json")]) == 0
    assert main([*common, "--jobs", "2", "--json", str(tmp_path / "jobs.json")]) == 0
    strip = lambda d: [{k: v for k, v in r.items() if k != "study_trial"} for r in d["ranked"]]
    assert strip(json.loads((tmp_path / "jobs.json").read_text())) == strip(
        json.loads((tmp_path / "serial.json").read_text())
    )
