"""One MuJoCo trial per controller on the Allegro hand (hand_configs/allegro_hand.toml): the
torque-controlled hand's scene builds, the three BioTac pads close on the object along their task
vectors, the ring finger stays out of the way, and the trial ends with a verdict of the judge."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.config.objects import load_objects
from grasp_ctrl.controller.registry import settings_for
from grasp_ctrl.files.paths import default_objects_file, hand_configs_dir
from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial, trial_seed

pytest.importorskip("mujoco")


@pytest.fixture(scope="module")
def allegro():  # type: ignore[no-untyped-def]
    return load_hand(hand_configs_dir() / "allegro_hand.toml")


@pytest.mark.parametrize(("controller", "object_name"), [("paper", "chips_can"), ("grip_load", "lego")])
def test_an_allegro_trial_lifts_and_places(allegro, controller: str, object_name: str) -> None:  # type: ignore[no-untyped-def]
    obj = load_objects(default_objects_file(), allegro.name)[object_name]
    touched: set[str] = set()

    def watch(world, ctrl) -> None:  # type: ignore[no-untyped-def]
        for name, normal in zip([f.name for f in allegro.fingers], np.asarray(world.normal_n)):
            if normal > 0.05:
                touched.add(name)
        currents = np.asarray(world.joint_current_a)
        assert np.isnan(currents).all()  # a torque-controlled hand reports no current

    result = run_sim_trial(
        allegro,
        obj,
        estimator_factory("oracle", allegro),
        trial_seed(0, obj.name, 0),
        "oracle",
        0,
        settings_for(controller, allegro),  # with the hand file's own choices ([controllers.paper])
        backend="mujoco",
        on_tick=watch,
    )
    states = [to for _, _, to in result.transitions]
    assert "ramp" in states, result.transitions
    assert touched >= {"index", "middle", "thumb"} and "ring" not in touched, touched
    assert math.isfinite(result.peak_grip_true_n) and result.peak_grip_true_n < allegro.safety.max_fingertip_force_n
    assert result.success, (result.reason, result.fault_detail)
