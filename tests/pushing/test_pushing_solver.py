"""Planar-pushing ground truth: the solver recovers the forces of simulated pushes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.pushing.box import PushedBox
from grasp_ctrl.pushing.kinematics import planar_motion
from grasp_ctrl.pushing.particles import footprint_particles, friction_force_moment
from grasp_ctrl.pushing.simulate import PAPER_BOX, simulate_push
from grasp_ctrl.pushing.solver import (
    build_problem,
    plane_force_to_sensor,
    pusher_forces,
    solve_closed_form,
    solve_slsqp,
)


def _errors(noise: bool, n_pushes: int = 6, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    errs = []
    for _ in range(n_pushes):
        push = simulate_push(rng)
        seen = push.tracked(rng, 3e-4, 3e-3) if noise else push
        motion = planar_motion(seen.t, seen.x, seen.y, seen.theta)
        f = pusher_forces(motion, seen.contact_object, seen.in_contact, PAPER_BOX)
        ok = ~np.isnan(f.f_world[:, 0])
        assert ok.sum() > 0.5 * push.in_contact.sum()
        errs.append(np.linalg.norm(f.f_world[ok] - push.f_world_true[ok], axis=1))
    return np.concatenate(errs)


def test_recovers_known_forces_from_clean_poses() -> None:
    e = _errors(noise=False)
    # 80 solver particles vs 2500 in the simulation, SG differentiation near the ramps
    print(f"clean poses: median {np.median(e):.4f} N, p90 {np.percentile(e, 90):.4f} N, max {e.max():.4f} N")
    assert np.median(e) < 0.01
    assert np.percentile(e, 90) < 0.05


def test_recovers_known_forces_from_noisy_tracking() -> None:
    e = _errors(noise=True)
    print(f"noisy poses (0.3 mm, 3 mrad): median {np.median(e):.4f} N, p90 {np.percentile(e, 90):.4f} N")
    assert np.median(e) < 0.05
    assert np.percentile(e, 90) < 0.12


def test_closed_form_and_slsqp_agree() -> None:
    rng = np.random.default_rng(3)
    push = simulate_push(rng).tracked(rng, 3e-4, 3e-3)
    motion = planar_motion(push.t, push.x, push.y, push.theta)
    a = pusher_forces(motion, push.contact_object, push.in_contact, PAPER_BOX, method="closed-form")
    b = pusher_forces(motion, push.contact_object, push.in_contact, PAPER_BOX, method="slsqp")
    np.testing.assert_array_equal(np.isnan(a.f_world), np.isnan(b.f_world))
    ok = ~np.isnan(a.f_world[:, 0])
    assert np.max(np.abs(a.f_world[ok] - b.f_world[ok])) < 1e-6


@settings(max_examples=40, deadline=None)
@given(
    b=st.lists(st.floats(-5, 5), min_size=2, max_size=2),
    br=st.floats(-0.5, 0.5),
    c=st.lists(st.floats(-0.2, 0.2), min_size=2, max_size=2),
    k=st.floats(0.5, 50),
)
def test_closed_form_is_the_least_squares_minimum(b: list[float], br: float, c: list[float], k: float) -> None:
    from grasp_ctrl.pushing.solver import Problem

    p = Problem(np.array([b]), np.array([br]), np.array([c]), k)
    f = solve_closed_form(p)[0]
    # same answer as a generic least-squares solve of the stacked system
    a_mat = np.vstack([np.sqrt(k) * np.eye(2), np.array([c])])
    rhs = np.concatenate([np.sqrt(k) * np.array(b), [br]])
    ref = np.linalg.lstsq(a_mat, rhs, rcond=None)[0]
    np.testing.assert_allclose(f, ref, atol=1e-9)
    np.testing.assert_allclose(solve_slsqp(p)[0], f, atol=1e-6)


def test_static_samples_are_flagged_and_nan() -> None:
    rng = np.random.default_rng(5)
    push = simulate_push(rng)
    motion = planar_motion(push.t, push.x, push.y, push.theta)
    f = pusher_forces(motion, push.contact_object, np.ones(len(push.t), bool), PAPER_BOX)
    assert not f.moving[0] and not f.moving[-1]  # the push starts and ends at rest
    assert np.all(np.isnan(f.f_world[~f.moving]))
    assert np.all(np.isfinite(f.f_world[f.moving]))


def test_friction_of_pure_translation_is_mu_m_g_against_motion() -> None:
    parts = footprint_particles((0.12, 0.16), 80)
    assert parts.shape == (80, 2)
    np.testing.assert_allclose(parts.mean(axis=0), 0.0, atol=1e-12)
    v = np.array([[0.03, 0.04]])
    f_f, n_f = friction_force_moment(v, np.zeros(1), np.array([0.7]), parts, 0.65, 0.1, 9.81)
    np.testing.assert_allclose(f_f[0], -0.1 * 0.65 * 9.81 * v[0] / np.linalg.norm(v[0]), atol=1e-12)
    np.testing.assert_allclose(n_f, 0.0, atol=1e-12)


def test_pure_rotation_gives_a_moment_and_no_force() -> None:
    parts = footprint_particles((0.1, 0.1), 100)
    f_f, n_f = friction_force_moment(np.zeros((1, 2)), np.array([1.0]), np.zeros(1), parts, 1.0, 0.5, 10.0)
    np.testing.assert_allclose(f_f, 0.0, atol=1e-12)
    # continuous square: n = -mu m g * (mean distance to the centre) = -5 * 0.0383 N m
    assert -0.2 < n_f[0] < -0.18


def test_uniform_box_inertia_and_explicit_override() -> None:
    assert PushedBox(2.0, (0.3, 0.4), 0.1).inertia == pytest.approx(2.0 * 0.25 / 12)
    assert PushedBox(2.0, (0.3, 0.4), 0.1, izz_kgm2=0.5).inertia == 0.5


def test_label_in_sensor_frame_is_the_reaction_rotated() -> None:
    f_plane = np.array([[1.0, 0.0]])
    # sensor x axis = world -y, sensor y = world x, z = z  (a yaw of -90 deg)
    r_world_sensor = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    f3 = plane_force_to_sensor(f_plane, r_world_sensor)
    # force on the skin is -x world; in the sensor frame that is -y_sensor
    np.testing.assert_allclose(f3[0], [0.0, -1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(plane_force_to_sensor(f_plane, r_world_sensor[None]), f3)


def test_build_problem_uses_the_contact_lever() -> None:
    from grasp_ctrl.pushing.kinematics import PlanarMotion

    m = PlanarMotion(np.zeros(1), np.zeros(1), np.array([[0.1, 0.0]]), np.zeros((1, 2)), np.zeros(1), np.zeros(1))
    p = build_problem(m, np.array([[-0.06, 0.02]]), PAPER_BOX)
    np.testing.assert_allclose(p.c_perp[0], [-0.02, -0.06])
