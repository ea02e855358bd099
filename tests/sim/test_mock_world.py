"""The mock world: lift physics, outcomes judged from truth, BioTac model calibration."""

from __future__ import annotations

import csv

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.config.sensor_layout import ELECTRODES, PDC
from grasp_ctrl.controller.registry import settings_for
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR
from grasp_ctrl.sim.biotac.model import BioTacSensorModel
from grasp_ctrl.sim.mock.grip import solve_object_height, tangential_forces
from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial


def _trial(hand, obj, policy="oracle", seed=7, on_tick=None):
    # the paper's controller: these check the world against its fixed grip
    settings = settings_for("paper")
    return run_sim_trial(
        hand, obj, estimator_factory(policy, hand), seed, policy, settings=settings, on_tick=on_tick, backend="mock"
    )


def test_too_little_grip_lets_a_heavy_object_slip(hand, objects):
    weak = objects["cleanser"].with_params(tau_n=0.6)
    r = _trial(hand, weak)
    assert not r.success and r.reason == "slipped"
    assert r.max_object_z_m < 0.5 * weak.lift_height_m


class _WrongShearSign:
    """The true force with its vertical (world z) part mirrored: a policy that got the
    shear sign wrong sees the table take the load as soon as lowering starts."""

    has_variance = False
    name = "wrong_shear_sign"

    def __init__(self, world):
        self.world = world

    def estimate(self, tared, fingers):
        from grasp_ctrl.estimators.base import Estimate

        out = []
        for name in fingers:
            i = self.world.fingers.index(name)
            R = self.world._R_sensor[i]
            f_world = R @ self.world.f_sensor[i]
            f_world[2] = -f_world[2]
            out.append(R.T @ f_world)
        return Estimate(f_sensor=np.array(out).reshape(len(fingers), 3))


def test_an_early_release_drops_the_object(hand, objects):
    obj = objects["chips_can"]
    # the paper's release rule (grip_load reads the index from where it pressed in hold)
    r = run_sim_trial(hand, obj, _WrongShearSign, 7, "wrong_shear_sign", settings=settings_for("paper"), backend="mock")
    assert not r.success and r.reason == "dropped_early"
    assert any(e["kind"] == "fell" for e in r.events)
    released = [t for t, _, b in r.transitions if b == "release"][0]
    lowered = [t for t, _, b in r.transitions if b == "lower"][0]
    assert released - lowered < 0.5  # released right after lowering began


def test_a_late_release_is_a_failure(hand, objects):
    never = objects["chips_can"].with_params(release_threshold_n=9.0)
    r = _trial(hand, never)
    assert not r.success and r.reason in ("knocked_over", "no_release")


def test_oracle_succeeds_on_a_deformable_object(hand, objects):
    r = _trial(hand, objects["paper_cup"])
    assert r.success, (r.reason, r.events)
    assert r.peak_grip_true_n < objects["paper_cup"].crush_force_n


@settings(max_examples=300, deadline=None)
@given(
    anchors=st.lists(st.floats(-0.05, 0.05), min_size=1, max_size=4),
    caps=st.lists(st.floats(0.0, 5.0), min_size=4, max_size=4),
    caps_down=st.lists(st.floats(0.0, 5.0), min_size=4, max_size=4),
    weight=st.floats(0.01, 10.0),
)
def test_object_height_is_an_equilibrium(anchors, caps, caps_down, weight):
    a = np.array(anchors)
    up, down = np.array(caps[: len(a)]), np.array(caps_down[: len(a)])
    kt = 400.0
    z, table = solve_object_height(a, up, down, kt, weight)
    t, _ = tangential_forces(a, up, down, kt, z)
    assert z >= 0.0 and table >= 0.0
    assert abs(sum(t) + table - weight) < 1e-6
    assert np.all(t <= up + 1e-12) and np.all(t >= -down - 1e-12)
    if z > 0.0:
        assert table == 0.0


@settings(max_examples=300, deadline=None)
@given(normal=st.floats(0.01, 10.0), tilt=st.floats(-1.2, 1.2), mu=st.floats(0.1, 1.5))
def test_friction_limits_put_the_contact_force_on_its_own_friction_cone(normal, tilt, mu):
    """At either limit the finger's whole force on the object (normal push plus
    vertical drag), split on the surface's own normal, is exactly mu times its
    compressive part; on a wall both limits are mu N."""
    from grasp_ctrl.sim.mock.grip import friction_limits

    n = np.array([np.cos(tilt), 0.0, np.sin(tilt)])  # outward surface normal, tilted up or down
    up, down = friction_limits(normal, n[2], mu)
    for t in (up, -down):
        if np.sqrt(1 - n[2] ** 2) - mu * abs(n[2]) < 0.05:
            continue  # a wedge: the capped factor, not the cone
        f_on_object = -normal * n + t * np.array([0.0, 0.0, 1.0])
        compressive = -f_on_object @ n
        tangential = np.linalg.norm(f_on_object + compressive * n)
        assert compressive > 0
        assert tangential == pytest.approx(mu * compressive, rel=1e-9)
    if tilt == 0.0:
        assert up == pytest.approx(mu * normal) and down == pytest.approx(mu * normal)
    if tilt > 1e-6:  # a cap facing up: lifting unloads it
        assert up < down


def test_friction_limits_of_a_wall_are_mu_n():
    from grasp_ctrl.sim.mock.grip import friction_limits

    assert friction_limits(2.0, 0.0, 0.9) == pytest.approx((1.8, 1.8))
    assert friction_limits(0.0, 0.3, 0.9) == (0.0, 0.0)


def test_biotac_model_magnitudes_match_real_recordings(shared_data):
    """Baselines, electrode drops and pdc rises of simulated presses lie in the
    ranges seen in the real BioTac recordings."""
    rows = list(csv.DictReader((shared_data / "robotic_finger" / "robotic_finger_tidy.csv").open()))
    e_cols = [f"e{i}" for i in range(1, 20)]
    e = np.array([[float(r[c]) for c in e_cols] for r in rows])
    pdc = np.array([float(r["pdc"]) for r in rows])
    real_baseline = np.median(e[:50], axis=0)
    real_pdc_rise = np.percentile(pdc - np.median(pdc[:50]), 99)

    rng = np.random.default_rng(0)
    model = BioTacSensorModel(64, rng)
    assert np.all((model.baseline[:, ELECTRODES] >= 3000) & (model.baseline[:, ELECTRODES] <= 3500))
    assert 2500 < np.median(real_baseline) < 3600
    f = np.zeros((64, 3))
    f[:, 2] = np.linspace(0.5, 6.0, 64)  # pad presses from 0.5 to 6 N
    raw = model.frames(
        np.broadcast_to(PAD_POINT_SENSOR, (64, 3)),
        f,
        np.broadcast_to(PAD_NORMAL_SENSOR, (64, 3)),
        np.ones(64, bool),
        np.zeros(64),
        0.01,
    )
    tared = raw - model.baseline
    pdc_rise = tared[:, PDC]
    assert np.all(pdc_rise > 20) and real_pdc_rise > 100
    assert np.all(raw[:, PDC] < 4095)  # 6 N stays inside the ADC range
    assert np.corrcoef(f[:, 2], pdc_rise)[0, 1] > 0.95  # more force, more pdc (gain spread aside)
    drops = -tared[:, ELECTRODES].min(axis=1)
    assert drops.max() <= 2000 and drops.min() > 50


@settings(max_examples=200, deadline=None)
@given(st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(lambda v: np.linalg.norm(v) > 1e-3))
def test_skin_contact_points_lie_on_the_skin(v):
    from grasp_ctrl.kinematics.fingertip import PAD_X_MIN_M, SKIN_RADIUS_M, contact_on_skin

    c, n = contact_on_skin(np.array(v))
    assert abs(np.linalg.norm(n) - 1.0) < 1e-9
    if c[0] > 1e-12:  # on the cap: a sphere about the origin
        assert abs(np.linalg.norm(c) - SKIN_RADIUS_M) < 1e-9
    else:  # on the cylinder about x
        assert PAD_X_MIN_M - 1e-12 <= c[0] <= 0.0
        assert abs(np.hypot(c[1], c[2]) - SKIN_RADIUS_M) < 1e-9


def test_flat_press_lands_on_the_pad_centre():
    from grasp_ctrl.kinematics.fingertip import contact_on_skin

    c, n = contact_on_skin(PAD_NORMAL_SENSOR)  # pressing straight into a surface under the pad
    np.testing.assert_allclose(c, PAD_POINT_SENSOR, atol=1e-12)
    np.testing.assert_allclose(n, PAD_NORMAL_SENSOR, atol=1e-12)


def test_oracle_succeeds_with_contacts_on_the_skin(hand, objects):
    from grasp_ctrl.sim.mock.world import WorldParams

    obj = objects["chips_can"]
    r = run_sim_trial(
        hand,
        obj,
        estimator_factory("oracle", hand),
        7,
        "oracle",
        world_params=WorldParams(skin_contact=True),
        backend="mock",
    )
    assert r.success, (r.reason, r.events)


@pytest.mark.parametrize("name", ["mustard_bottle", "paper_cup", "cleanser"])
def test_the_sensor_feels_each_force_on_the_skin_patch_that_faces_it(hand, objects, name):
    """Every touching fingertip, every tick of a whole trial: the force on the skin
    (f_sensor) lies within the object's friction cone about the skin's inward normal
    at the contact point the sensor model is given. Slack: the pad's contact point
    ignores up to asin(0.17) = 10 deg of axial tilt (CAP_TILT_SIN), and the finger's
    deflection turns the frame by a few degrees. Before the skin point was derived from
    the contact's own normal, the mustard bottle's index (trial seed 117181520, held
    on the wall's top edge with its pad near the dome) felt a wall force on its tip
    cap 59 deg off the skin normal, where mu = 0.9 allows 42 deg."""
    from grasp_ctrl.trials.episode.runner import trial_seed

    obj = objects[name]
    if obj.grip_targets == "force_closure":
        # the mock holds the object still sideways, so a thumb target of 2 tau is never balanced
        # (ramp_timeout, docs/results.md): the contacts are checked at the grip of equal targets
        obj = obj.with_params(tau_n=2.0, grip_targets=None)
    limit = np.arctan(obj.mu) + np.deg2rad(10.0 + 4.0)
    worst = [0.0]

    def on_tick(world, ctrl):
        f, n = world._f_sensor, world._skin_normal_sensor
        for i in range(f.shape[0]):
            mag = float(np.linalg.norm(f[i]))
            if mag > 0.2:
                cos = float(-(f[i] @ n[i])) / (mag * float(np.linalg.norm(n[i])))
                worst[0] = max(worst[0], float(np.arccos(np.clip(cos, -1.0, 1.0))))

    r = _trial(hand, obj, seed=trial_seed(0, name, 1), on_tick=on_tick)
    assert r.success, r.reason
    assert worst[0] <= limit, (
        f"{np.rad2deg(worst[0]):.1f} deg off the skin normal, cone + slack {np.rad2deg(limit):.1f}"
    )
