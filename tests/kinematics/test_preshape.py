"""The object preshape (pads facing the object) and the facing term of the closing IK."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.controller.registry import settings_for
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR
from grasp_ctrl.kinematics.pad_ik import Facing, PadIK
from grasp_ctrl.kinematics.preshape import side_gap, solve_preshape, surface_hit
from grasp_ctrl.sim.mock.world import WorldParams
from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial

STANDOFF_M = 0.01


def _pad(kin: HandKinematics, finger: str, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    R, p = kin.chains[finger].fk_rp(q[kin.slices[finger]])
    return R @ PAD_POINT_SENSOR + p, R @ PAD_NORMAL_SENSOR


@settings(max_examples=60, deadline=None)
@given(y=st.floats(-0.03, 0.03), x=st.floats(0.04, 0.2))
def test_a_closing_ray_meets_a_cylinder_on_its_surface_facing_back(objects, y, x):
    cup = objects["paper_cup"]
    hit = surface_hit(cup, np.array([x, y, -0.1]), np.array([-1.0, 0.0, 0.0]))
    assert hit is not None
    point, normal = hit
    assert math.hypot(point[0], point[1]) == pytest.approx(0.5 * cup.size_m[0], abs=1e-9)
    assert point[1] == pytest.approx(y) and point[0] > 0.0
    assert normal @ np.array([-1.0, 0.0, 0.0]) < 0.0  # the ray meets the outside
    gap, n_side = side_gap(cup, point)
    assert gap == pytest.approx(0.0, abs=1e-9) and np.allclose(n_side, normal)


def test_a_ray_past_a_box_or_from_inside_it_meets_nothing(objects):
    lego = objects["lego"]  # 32 x 64 mm footprint
    assert surface_hit(lego, np.array([0.05, 0.04, -0.1]), np.array([-1.0, 0.0, 0.0])) is None
    assert surface_hit(lego, np.array([0.0, 0.0, -0.1]), np.array([-1.0, 0.0, 0.0])) is None
    point, normal = surface_hit(lego, np.array([0.05, 0.01, -0.1]), np.array([-1.0, 0.0, 0.0]))
    assert point == pytest.approx([0.016, 0.01, -0.1]) and normal == pytest.approx([1.0, 0.0, 0.0])


@pytest.mark.parametrize("name", ["cleanser", "lego"])
def test_box_preshape_faces_the_pads_onto_the_sides(hand, objects, name):
    kin = HandKinematics(hand)
    shape = solve_preshape(hand, objects[name], STANDOFF_M, kin)
    lower = np.array([j.lower_rad for j in hand.joints])
    upper = np.array([j.upper_rad for j in hand.joints])
    assert np.all(shape.q >= lower) and np.all(shape.q <= upper)
    for finger in ("index", "middle"):
        i = [f.name for f in hand.fingers].index(finger)
        assert shape.pad_normals_hand[i] is not None, finger
        pad, normal = _pad(kin, finger, shape.q)
        # The pad faces the side it will touch (-x) within 10 degrees, 10 mm in front of it.
        assert math.degrees(math.acos(np.clip(-normal[0], -1, 1))) < 10.0
        assert pad[0] - shape.contacts_hand[i][0] == pytest.approx(STANDOFF_M, abs=1e-3)


def _turn_while_closing(hand, q0, facing: bool, travel_m: float, compiled: bool) -> tuple[np.ndarray, np.ndarray]:
    ik = PadIK(HandKinematics(hand), compiled=compiled)
    q = q0.copy()
    targets = ik.pad_points(q)
    n0 = ik.pad_normals(q)
    grasp = np.array([f.grasp for f in hand.fingers])
    vectors = np.array([f.task_vector_hand for f in hand.fingers], dtype=float)
    keep = Facing(grasp.copy(), n0.copy()) if facing else None
    steps = int(round(travel_m / 1e-4))
    for _ in range(steps):
        ik.advance(q, targets, vectors, np.where(grasp, 1e-4, 0.0), 0.002, keep)
    turn = np.degrees(np.arccos(np.clip(np.sum(n0 * ik.pad_normals(q), axis=1), -1.0, 1.0)))
    miss = np.linalg.norm(ik.pad_points(q) - targets, axis=1)
    return turn, miss


def test_keeping_the_pads_facing_turns_them_less_and_still_tracks_the_line(hand):
    q0 = np.array([j.pregrasp_rad for j in hand.joints])
    index = [f.name for f in hand.fingers].index("index")
    plain_turn, plain_miss = _turn_while_closing(hand, q0, False, 0.015, compiled=False)
    kept_turn, kept_miss = _turn_while_closing(hand, q0, True, 0.015, compiled=False)
    # Measured on the LEAP file: 10.4 degrees of pitch without, 0.8 with (15 mm of travel).
    assert plain_turn[index] > 5.0
    assert kept_turn[index] < 0.3 * plain_turn[index]
    assert kept_miss[index] < 5e-4 and plain_miss[index] < 5e-4


def test_the_facing_kernel_matches_the_numpy_path(hand):
    q0 = np.array([j.pregrasp_rad for j in hand.joints])
    fast = _turn_while_closing(hand, q0, True, 0.02, compiled=True)
    slow = _turn_while_closing(hand, q0, True, 0.02, compiled=False)
    np.testing.assert_allclose(fast[0], slow[0], atol=1e-8)
    np.testing.assert_allclose(fast[1], slow[1], atol=1e-10)


def _shear_over_normal_at_ramp_end(hand, obj, preshape: bool) -> float:
    seen: dict[str, float] = {}

    def on_tick(world, ctrl):
        if ctrl.state == "ramp":
            f = world.true_f_sensor("index")
            seen["ratio"] = float(math.hypot(f[0], f[1]) / abs(f[2]))

    # At the pad centre the pad's pitch shows as shear (the skin contact would move the
    # contact point along the skin instead).
    r = run_sim_trial(
        hand,
        obj,
        estimator_factory("oracle", hand),
        3,
        "oracle",
        settings=settings_for("grip_load", preshape=preshape),
        on_tick=on_tick,
        world_params=WorldParams(skin_contact=False),
        backend="mock",
    )
    assert r.success, (r.reason, r.events)
    return seen["ratio"]


def test_the_preshaped_grasp_presses_the_box_squarely(hand, objects):
    # Without the preshape the LEAP index pad reaches the cleanser pitched by ~20 degrees:
    # shear 0.29-0.40 of the normal force over seeds 0-4; with it 0.02-0.11.
    plain = _shear_over_normal_at_ramp_end(hand, objects["cleanser"], preshape=False)
    shaped = _shear_over_normal_at_ramp_end(hand, objects["cleanser"], preshape=True)
    assert plain > 0.25
    assert shaped < 0.15 and shaped < 0.4 * plain
