"""FK, Jacobian and IK on the LEAP Hand file."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.kinematics import FingerChain, HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_POINT_SENSOR
from grasp_ctrl.kinematics.ik import close_along_task_vectors, closing_vectors, point_position, solve_position_ik
from tests.dxl_helpers import leap

HAND = leap()
KIN = HandKinematics(HAND)
FINGERS = [f.name for f in HAND.fingers]


def random_q(chain: FingerChain, rng: np.random.Generator, margin: float = 0.05) -> np.ndarray:
    return rng.uniform(chain.lower + margin, chain.upper - margin)


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(FINGERS), st.integers(0, 2**31 - 1), st.booleans())
def test_jacobian_matches_finite_differences(finger: str, seed: int, pad: bool) -> None:
    chain = KIN.chains[finger]
    q = random_q(chain, np.random.default_rng(seed))
    p_s = PAD_POINT_SENSOR if pad else None
    J = chain.jacobian(q, p_s)
    h = 1e-6
    J_fd = np.empty_like(J)
    for i in range(chain.n):
        dq = np.zeros(chain.n)
        dq[i] = h
        J_fd[:, i] = (point_position(chain, q + dq, p_s) - point_position(chain, q - dq, p_s)) / (2 * h)
    np.testing.assert_allclose(J, J_fd, atol=1e-8)


def test_fk_is_a_rigid_transform_and_matches_the_open_pose() -> None:
    q = np.array([j.open_rad for j in HAND.joints])
    for name, T in KIN.sensor_poses(q).items():
        R = T[:3, :3]
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-9)
        assert np.linalg.det(R) == pytest.approx(1.0)
        # the grasping fingertips hang below the palm; the idle ring finger is held up out of the way
        if HAND.finger(name).grasp:
            assert T[2, 3] < -0.05, name


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(FINGERS), st.integers(0, 2**31 - 1))
def test_ik_converges_for_small_displacements(finger: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    chain = KIN.chains[finger]
    q0 = random_q(chain, rng, margin=0.3)
    # a target reachable from q0: FK of a nearby configuration
    q_goal = np.clip(q0 + rng.uniform(-0.1, 0.1, chain.n), chain.lower, chain.upper)
    target = point_position(chain, q_goal, PAD_POINT_SENSOR)
    res = solve_position_ik(chain, q0, target, PAD_POINT_SENSOR, tol_m=1e-5)
    assert res.converged, (res.error_m, res.iterations)
    np.testing.assert_allclose(point_position(chain, res.q, PAD_POINT_SENSOR), target, atol=1e-5)
    assert np.all(res.q >= chain.lower) and np.all(res.q <= chain.upper)


@settings(max_examples=30, deadline=None)
@given(st.sampled_from(FINGERS), st.integers(0, 2**31 - 1), st.floats(0.05, 0.5))
def test_unreachable_targets_keep_the_limits(finger: str, seed: int, far: float) -> None:
    rng = np.random.default_rng(seed)
    chain = KIN.chains[finger]
    q0 = random_q(chain, rng)
    direction = rng.normal(size=3)
    target = point_position(chain, q0) + far * direction / np.linalg.norm(direction)
    res = solve_position_ik(chain, q0, target, max_iters=30)
    assert np.all(res.q >= chain.lower) and np.all(res.q <= chain.upper)
    # never worse than where it started
    assert res.error_m <= np.linalg.norm(target - point_position(chain, q0)) + 1e-12
    for _ in range(20):  # single steps too
        q0 = chain.ik_step(q0, (target - point_position(chain, q0)) * 0.2)
        assert np.all(q0 >= chain.lower) and np.all(q0 <= chain.upper)


def test_closing_moves_grasp_fingertips_along_their_vectors() -> None:
    q = np.array([j.pregrasp_rad for j in HAND.joints])
    vectors = closing_vectors(KIN)
    q_new, results = close_along_task_vectors(KIN, q, 0.004, PAD_POINT_SENSOR)
    assert set(results) == {f.name for f in HAND.grasp_fingers}
    for name, res in results.items():
        sl, chain = KIN.slices[name], KIN.chains[name]
        moved = point_position(chain, q_new[sl], PAD_POINT_SENSOR) - point_position(chain, q[sl], PAD_POINT_SENSOR)
        assert res.converged
        np.testing.assert_allclose(moved, 0.004 * vectors[name], atol=1e-4)
    # the non-grasp ring finger did not move
    sl = KIN.slices["ring"]
    np.testing.assert_array_equal(q_new[sl], q[sl])
    # index and thumb close toward each other
    assert vectors["index"] @ vectors["thumb"] < 0
