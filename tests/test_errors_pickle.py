"""Errors raised in trial worker processes cross back to the parent intact."""

from __future__ import annotations

import pickle

from grasp_ctrl.errors import ConfigError, HardwareError, SensorStaleError


def test_errors_survive_pickling_with_their_fields():
    config = pickle.loads(pickle.dumps(ConfigError("hand.toml", "cap.finger", "a grasping finger")))
    assert (config.path, config.key, config.expected) == ("hand.toml", "cap.finger", "a grasping finger")
    assert str(config) == "hand.toml: cap.finger: a grasping finger" and config.exit_status == 2
    hardware = pickle.loads(pickle.dumps(HardwareError("servo 3 overload", reason="overload")))
    assert str(hardware) == "servo 3 overload" and hardware.reason == "overload"
    stale = pickle.loads(pickle.dumps(SensorStaleError("index: no frame for 0.06 s")))
    assert isinstance(stale, SensorStaleError) and stale.reason == "sensor_stale"


def test_an_unreachable_reach_posture_fails_the_run_before_any_trial(tmp_path):
    # The index pad cannot reach the mustard cap on this hand. It used to surface inside the
    # worker processes of --jobs 2, where the unpicklable error broke the pool ("a worker
    # ended abruptly") after 9 trials were written; run_series now checks it up front.
    from grasp_ctrl.cli import main
    from grasp_ctrl.files.paths import default_hand_file

    text = default_hand_file().read_text()
    first = 'origin_rpy = [1.5707963, 1.5707963, 0.0]'
    assert first in text
    hand = tmp_path / "hand.toml"
    hand.write_text(text.replace(first, "origin_rpy = [0.0, 0.0, 0.0]", 1))
    rc = main(
        [
            "run",
            "--backend",
            "mock",
            "--hand",
            str(hand),
            "--objects",
            "mustard_bottle",
            "--trials",
            "2",
            "--jobs",
            "2",
            "--out",
            str(tmp_path / "run"),
            "--quiet",
        ]
    )
    assert rc == 2
    assert not (tmp_path / "run").exists()
