"""Each controller's settings class (controller/paper_settings.py, controller/grip_load_settings.py):
at most 40 fields a class, its own checks, and the one flat table users and files name settings
by. run.json and trial records keep exactly the table the single settings class before them
wrote, and a run.json in that layout resumes."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.controller.grip_load_settings import GripLoadSettings
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.registry import (
    controller_names,
    entry,
    flat_defaults,
    flat_settings,
    settings_for,
    settings_from_flat,
)
from grasp_ctrl.errors import ConfigError, UsageError
from grasp_ctrl.files.paths import hand_configs_dir
from grasp_ctrl.trials.episode import runner as episode_runner
from grasp_ctrl.trials.runs.manifest import read_manifest
from grasp_ctrl.trials.tuning.search_space import check_settings_values, parse_params

# grip_load's flat table as run.json and trial records have held it (the key order too)
GRIP_LOAD_TABLE = {
    "controller": "grip_load",
    "close_speed_m_s": 0.02,
    "close_timeout_s": 4.0,
    "ramp_gain_m_s_per_n": 0.01,
    "ramp_max_speed_m_s": 0.01,
    "ramp_tolerance_n": 0.15,
    "ramp_settle_s": 0.1,
    "ramp_balance_band_n": 0.4,
    "ramp_steady_n": 0.05,
    "ramp_steady_s": 0.5,
    "ramp_filter_s": 0.1,
    "ramp_cycle_s": 1.5,
    "ramp_cycle_swing_n": 2.5,
    "ramp_timeout_s": 6.0,
    "hold_gain_m_s_per_n": 0.005,
    "hold_max_speed_m_s": 0.004,
    "reach_tolerance_m": 0.001,
    "reach_timeout_s": 10.0,
    "lift_speed_m_s": 0.04,
    "lower_speed_m_s": 0.03,
    "lower_overshoot_m": 0.03,
    "lower_slow_zone_m": 0.008,
    "lower_slow_speed_m_s": 0.005,
    "grip_lost_fraction": 0.3,
    "contact_lost_s": 0.05,
    "open_s": 1.0,
    "release_back_off_m_s": 0.02,
    "retreat_m": 0.05,
    "preshape": True,
    "preshape_standoff_m": 0.01,
    "stiffness_aware_squeeze": True,
    "grip_targets": "force_closure",
    "grip_weight_margin": 0.0,
    "reach_standoff_m": 0.025,
    "guarded_standoff_m": 0.01,
    "load_speed_m_s": 0.005,
    "load_min_rise_m": 0.006,
    "load_max_rise_m": 0.015,
    "load_gain_m_s_per_n": 0.005,
    "load_max_speed_m_s": 0.004,
    "load_weight_fraction": 0.8,
    "load_settle_s": 0.1,
    "grip_margin": 1.3,
    "slip_cone_fraction": 0.9,
    "slip_grip_rate_n_s": 15.0,
    "slip_rate_n_s": 25.0,
    "slip_filter_s": 0.03,
    "slip_pac_counts": 20.0,
    "slip_pac_window_s": 0.5,
    "slip_pac_ticks": 2,
    "slip_boost": 0.15,
    "slip_adapts_mu": True,
    "min_mu_hat": 0.3,
    "slip_max_pause_s": 1.0,
    "pause_when_short": False,
    "release_relative": True,
    "grip_relax_per_s": 0.5,
    "min_grip_scale": 0.6,
    "grip_cap_fraction": 0.8,
    "unwind_fraction": 0.9,
    "windup_lag_factor": 1.5,
    "servo_limited_s": 0.5,
    "ramp_mode": "regulate",
    "low_confidence_slowdown": False,
    "variance_scale_n2": 0.05,
}
# the paper's: grip_load's with the paper controller's own choices
PAPER_TABLE = {
    **GRIP_LOAD_TABLE,
    "controller": "paper",
    "lower_speed_m_s": 0.015,
    "lower_slow_zone_m": 0.015,
    "open_s": 0.4,
    "release_back_off_m_s": 0.05,
    "stiffness_aware_squeeze": False,
    "grip_targets": "equal",
}


def test_no_settings_class_has_more_than_40_fields():
    for name in controller_names():
        cls = entry(name).settings
        defaults = cls()
        groups = [
            type(v) for v in (getattr(defaults, f.name) for f in dataclasses.fields(cls)) if dataclasses.is_dataclass(v)
        ]
        for c in (cls, *groups):
            assert len(dataclasses.fields(c)) <= 40, c.__name__


def test_the_flat_table_is_the_one_records_and_run_json_keep():
    for name, table in (("grip_load", GRIP_LOAD_TABLE), ("paper", PAPER_TABLE)):
        flat = flat_settings(settings_for(name))
        assert flat == table and list(flat) == list(table), name
        assert settings_from_flat(table, "run.json") == settings_for(name)
    assert list(flat_defaults()) == list(GRIP_LOAD_TABLE)[1:]


def test_a_setting_is_read_and_replaced_by_its_flat_key():
    s = settings_for("grip_load")
    t = s.replace(grip_margin=1.1, open_s=0.5, ramp_cycle_s=0.0)
    assert (t.coordination.grip_margin, t.open_s, t.cycle.ramp_cycle_s) == (1.1, 0.5, 0.0)
    assert t.setting("grip_margin") == 1.1 and s.coordination.grip_margin == 1.3
    assert t.load == s.load  # the untouched groups stay
    with pytest.raises(TypeError, match="grip_margin"):
        settings_for("paper").replace(grip_margin=1.1)  # not a setting of the paper's controller


@pytest.mark.parametrize(
    ("cls", "values", "need"),
    [
        (PaperSettings, {"ramp_mode": "hold"}, "one of regulate, push_then_hold"),
        (PaperSettings, {"preshape": 1}, "true or false"),
        (PaperSettings, {"open_s": 0.0}, "a finite number > 0"),
        (PaperSettings, {"open_s": 2e6}, "<= 1e+06"),
        (PaperSettings, {"open_s": float("nan")}, "a finite number"),
        (PaperSettings, {"grip_margin": 1.2}, "a known setting"),  # grip_load's, not the paper's
        (PaperSettings, {"windup_lag_factor": 0.0}, "a known setting"),
        (GripLoadSettings, {"windup_lag_factor": -1.0}, "a finite number >= 0"),
        (GripLoadSettings, {"slip_boost": 0.0}, "a finite number > 0"),
        (GripLoadSettings, {"grip_targets": "tighter"}, "one of equal, force_closure"),
    ],
)
def test_each_class_checks_its_own_settings(cls, values, need):
    with pytest.raises(UsageError, match=rf"^x: settings\.{next(iter(values))}: .*{re.escape(need)}"):
        cls.check(values, "x")


def test_each_class_takes_what_it_allows():
    assert PaperSettings.check({"retreat_m": 0.0, "ramp_mode": "push_then_hold"}, "x") == {
        "retreat_m": 0.0,
        "ramp_mode": "push_then_hold",
    }
    ok = {"windup_lag_factor": 0.0, "servo_limited_s": 0.0, "ramp_cycle_s": 0.0, "slip_pac_ticks": 3}
    assert GripLoadSettings.check(ok, "x") == ok
    s = GripLoadSettings.from_flat(ok, "x")
    assert (s.limits.windup_lag_factor, s.coordination.slip_pac_ticks) == (0.0, 3)


def test_run_json_tables_name_the_key_that_is_wrong():
    assert settings_from_flat({k: v for k, v in PAPER_TABLE.items() if k != "controller"}, "r") == settings_for(
        "paper"
    )  # a run from before the controllers had names ran the paper's
    with pytest.raises(UsageError, match=r"settings\.slip_boost: a finite number > 0"):
        settings_from_flat({**PAPER_TABLE, "slip_boost": -1.0}, "r")  # grip_load's key, by grip_load's rules
    with pytest.raises(UsageError, match=r"settings\.ramp_speed: a known setting"):
        settings_from_flat({**PAPER_TABLE, "ramp_speed": 0.01}, "r")
    with pytest.raises(UsageError, match=r"settings\.controller: one of paper, grip_load"):
        settings_from_flat({"controller": "pid"}, "r")
    with pytest.raises(UsageError, match="a table of controller settings"):
        settings_from_flat([1, 2], "r")


def _hand_with(tmp_path: Path, table: str) -> Path:
    allegro = hand_configs_dir() / "allegro_hand.toml"
    text = allegro.read_text()
    path = tmp_path / "hand.toml"
    path.write_text(text.replace('[controllers.paper]\nramp_mode = "push_then_hold"', table))
    return path


def test_a_hand_files_table_takes_its_controllers_settings_only(tmp_path):
    hand = load_hand(_hand_with(tmp_path, "[controllers.grip_load]\ngrip_margin = 1.2"))
    assert settings_for("grip_load", hand).coordination.grip_margin == 1.2
    assert settings_for("paper", hand) == settings_for("paper")
    hand = load_hand(_hand_with(tmp_path, "[controllers.paper]\ngrip_margin = 1.2"))
    with pytest.raises(ConfigError) as err:
        settings_for("paper", hand)
    assert err.value.key == "controllers.paper.grip_margin"


def test_tune_searches_the_settings_of_its_controller():
    params = parse_params(["setting.grip_margin=1.1:1.6"])
    check_settings_values(params, settings_for("grip_load"))
    with pytest.raises(UsageError, match=r"--param setting\.grip_margin=1\.1:1\.6: settings\.grip_margin: a known"):
        check_settings_values(params, settings_for("paper"))


def test_a_run_json_in_the_single_settings_layout_resumes(tmp_path, monkeypatch, capsys):
    """A paper run interrupted after its first trial, its run.json's settings the table the single
    settings class wrote: ``run --resume`` reads it, finds the plan unchanged and finishes."""
    calls = []

    def fake_trial_fn(hand, policies, settings=None, threads=1, **_kw):
        assert flat_settings(settings) == PAPER_TABLE

        def run(policy, obj, trial, seed, log_path):
            calls.append(trial)
            if len(calls) == 2:
                raise KeyboardInterrupt
            return {"object": obj.name, "policy": policy, "trial": trial, "seed": seed, "success": True, "reason": None}

        return run

    monkeypatch.setattr(episode_runner, "sim_trial_fn", fake_trial_fn)
    run_dir = tmp_path / "run"
    argv = ["run", "--backend", "mock", "--controller", "paper", "--objects", "lego", "--trials", "2"]
    assert main([*argv, "--out", str(run_dir), "--quiet"]) == 130
    doc = json.loads((run_dir / "run.json").read_text())
    doc["controller"], doc["settings"] = "paper", dict(PAPER_TABLE)  # (what the single class wrote)
    (run_dir / "run.json").write_text(json.dumps(doc, indent=2))
    assert read_manifest(run_dir).settings == settings_for("paper")
    capsys.readouterr()
    assert main(["run", "--resume", str(run_dir)]) == 0
    assert "resuming: 1 of 2 trials already recorded" in capsys.readouterr().err
    assert calls == [0, 1, 1]
    assert json.loads((run_dir / "run.json").read_text())["settings"] == PAPER_TABLE
