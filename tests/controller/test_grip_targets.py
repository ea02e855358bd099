"""Per-fingertip grip targets (controller/grip_targets.py): equal by default; with
force closure the closing forces cancel in the horizontal plane and the smallest is tau;
the weight margin scales them so that mu x their sum carries the object's weight."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from grasp_ctrl.controller.grip_targets import GRAVITY_M_S2, grip_targets
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.registry import settings_for
from grasp_ctrl.errors import ConfigError, UsageError
from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial
from grasp_ctrl.trials.runs.manifest import settings_from_json

LEAP_VECTORS = np.array([[-1.0, 0, 0], [-1.0, 0, 0], [-1.0, 0, 0], [1.0, 0, 0]])  # index, middle, ring, thumb
LEAP_GRASP = np.array([True, True, False, True])


def test_equal_targets_are_tau_for_every_fingertip():
    np.testing.assert_array_equal(grip_targets(LEAP_VECTORS, LEAP_GRASP, 2.0), [2.0, 2.0, 2.0, 2.0])


def test_force_closure_gives_the_single_thumb_what_the_two_fingers_push():
    t = grip_targets(LEAP_VECTORS, LEAP_GRASP, 2.0, "force_closure")
    np.testing.assert_allclose(t[LEAP_GRASP], [2.0, 2.0, 4.0], rtol=1e-9)
    assert min(t[LEAP_GRASP]) == pytest.approx(2.0)
    np.testing.assert_allclose((t[LEAP_GRASP, None] * LEAP_VECTORS[LEAP_GRASP])[:, :2].sum(axis=0), 0.0, atol=1e-8)


def test_force_closure_on_opposed_pairs_and_skewed_vectors_cancels_the_horizontal_push():
    pair = grip_targets(LEAP_VECTORS[[0, 3]], np.array([True, True]), 1.5, "force_closure")
    np.testing.assert_allclose(pair, [1.5, 1.5], rtol=1e-9)
    skewed = np.array([[-1.0, 0.2, 0.1], [-1.0, -0.2, 0.1], [1.0, 0.0, -0.3]])
    skewed /= np.linalg.norm(skewed, axis=1, keepdims=True)
    t = grip_targets(skewed, np.ones(3, dtype=bool), 2.0, "force_closure")
    assert t.min() == pytest.approx(2.0)
    np.testing.assert_allclose((t[:, None] * skewed)[:, :2].sum(axis=0), 0.0, atol=1e-6)


def test_the_weight_margin_scales_the_targets_only_when_they_cannot_carry_the_weight():
    heavy = grip_targets(LEAP_VECTORS, LEAP_GRASP, 2.0, "equal", mass_kg=0.45, mu=1.0, weight_margin=1.5)
    assert 1.0 * heavy[LEAP_GRASP].sum() == pytest.approx(1.5 * 0.45 * GRAVITY_M_S2)
    assert np.ptp(heavy[LEAP_GRASP]) == 0.0  # the same scale for every fingertip
    light = grip_targets(LEAP_VECTORS, LEAP_GRASP, 2.0, "equal", mass_kg=0.03, mu=0.8, weight_margin=1.5)
    np.testing.assert_array_equal(light, [2.0, 2.0, 2.0, 2.0])
    off = grip_targets(LEAP_VECTORS, LEAP_GRASP, 2.0, "equal", mass_kg=0.45, mu=1.0, weight_margin=0.0)
    np.testing.assert_array_equal(off, [2.0, 2.0, 2.0, 2.0])


def test_the_controller_keeps_its_targets_and_refuses_an_unknown_mode(hand, objects):
    obj = objects["cleanser"].with_params(grip_targets=None)  # the controller's mode decides
    default = GraspController(hand, obj, np.zeros(3))
    assert default.grip_targets.tolist() == [obj.tau_n] * 4
    closure = GraspController(hand, obj, np.zeros(3), PaperSettings(grip_targets="force_closure"))
    np.testing.assert_allclose(closure.grip_targets, [obj.tau_n, obj.tau_n, obj.tau_n, 2 * obj.tau_n], rtol=1e-9)
    with pytest.raises(ConfigError, match="grip_targets"):
        GraspController(hand, obj, np.zeros(3), PaperSettings(grip_targets="tighter"))


def test_run_json_settings_accept_the_modes_and_the_margin():
    s = settings_from_json({"grip_targets": "force_closure", "grip_weight_margin": 0.0}, "run.json")
    assert s.grip_targets == "force_closure" and s.grip_weight_margin == 0.0
    with pytest.raises(UsageError, match="grip_targets: one of equal, force_closure"):
        settings_from_json({"grip_targets": "tighter"}, "run.json")
    with pytest.raises(UsageError, match="grip_targets"):
        settings_from_json({"grip_targets": 1.0}, "run.json")


def _ramp_grips(hand, obj, settings):
    grips = []

    def on_tick(world, ctrl):
        if ctrl.state == "ramp":
            grips.append(ctrl.snap.grip_n.copy())

    run_sim_trial(
        hand, obj, estimator_factory("oracle", hand), 3, "oracle", settings=settings, on_tick=on_tick, backend="mock"
    )
    return np.array(grips)


def test_in_the_mock_world_the_thumb_ramps_toward_twice_tau_with_force_closure(hand, objects):
    obj = dataclasses.replace(objects["chips_can"], tau_n=1.5)
    equal = _ramp_grips(hand, obj, settings_for("paper"))
    closure = _ramp_grips(hand, obj, settings_for("paper", grip_targets="force_closure"))
    assert equal[:, 3].max() < 1.5 + 0.5
    assert closure[:, 3].max() > 1.5 + 1.0  # toward 3 N while the index and middle aim at 1.5 N


def test_a_profile_chooses_its_own_mode(hand, objects):
    """The heavy boxes ask for force-closure targets in objects.toml; the deformables keep 2 N, equal."""
    cleanser = GraspController(hand, objects["cleanser"], np.zeros(3))
    assert objects["cleanser"].grip_targets == "force_closure"
    np.testing.assert_allclose(cleanser.grip_targets, [2.5, 2.5, 2.5, 5.0], rtol=1e-9)
    for name in ("paper_cup", "plastic_bottle"):
        assert objects[name].tau_n == 2.0 and objects[name].grip_targets is None
        assert GraspController(hand, objects[name], np.zeros(3)).grip_targets.tolist() == [2.0] * 4


def test_an_object_file_grip_targets_key_is_checked_and_round_trips(tmp_path, objects):
    from grasp_ctrl.config.objects import load_objects, profile_table, revalidate
    from grasp_ctrl.errors import ConfigError
    from grasp_ctrl.files.paths import default_objects_file

    text = default_objects_file().read_text()
    bad = tmp_path / "objects.toml"
    bad.write_text(text.replace('grip_targets = "force_closure"', 'grip_targets = "tighter"', 1))
    with pytest.raises(ConfigError, match=r"cleanser\.hands\.leap_hand\.grip_targets.*one of equal, force_closure"):
        load_objects(bad)
    for obj in objects.values():  # run.json and tune's edits go through profile_table
        assert revalidate(obj, "x") == obj
        assert ("grip_targets" in profile_table(obj)) is (obj.grip_targets is not None)
