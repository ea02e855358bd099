"""Errors a trial worker of ``run --jobs N`` raises reach the parent pickled: each must come
back as itself (a ConfigError that cannot be rebuilt broke the whole worker pool)."""

from __future__ import annotations

import pickle

from grasp_ctrl.errors import ConfigError, HardwareError, SensorStaleError


def test_errors_survive_pickling_with_their_fields():
    config = pickle.loads(pickle.dumps(ConfigError("objects.toml", "cap.contact_height_m", "a reachable height")))
    assert isinstance(config, ConfigError) and config.exit_status == 2
    assert (config.path, config.key, config.expected) == ("objects.toml", "cap.contact_height_m", "a reachable height")
    assert str(config) == "objects.toml: cap.contact_height_m: a reachable height"
    hw = pickle.loads(pickle.dumps(HardwareError("servo 3: overload", reason="overload")))
    assert type(hw) is HardwareError and hw.reason == "overload" and str(hw) == "servo 3: overload"
    stale = pickle.loads(pickle.dumps(SensorStaleError("fingertip 'index': no frame")))
    assert type(stale) is SensorStaleError and stale.reason == "sensor_stale" and "index" in str(stale)
