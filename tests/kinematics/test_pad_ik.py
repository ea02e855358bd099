"""The controller's batched pad IK (compiled kernel) against the per-finger numpy methods."""

from __future__ import annotations

import numpy as np
import pytest

from grasp_ctrl.config import load_hand
from grasp_ctrl.files.paths import default_hand_file
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_POINT_SENSOR
from grasp_ctrl.kinematics.pad_ik import Facing, PadIK, shared_pad_ik


@pytest.fixture(scope="module")
def kin():
    return HandKinematics(load_hand(default_hand_file()))


@pytest.mark.parametrize("seed", range(6))
def test_kernel_matches_the_numpy_methods(kin, seed):
    rng = np.random.default_rng(seed)
    fast, slow = PadIK(kin, PAD_POINT_SENSOR, compiled=True), PadIK(kin, PAD_POINT_SENSOR, compiled=False)
    # Joints at and near their limits, so the kernel's limit freezing is exercised too.
    q = rng.uniform(fast.lower, fast.upper)
    at_lower, at_upper = rng.random(q.size) < 0.2, rng.random(q.size) < 0.2
    q[at_lower], q[at_upper] = fast.lower[at_lower], fast.upper[at_upper]
    np.testing.assert_allclose(fast.pad_points(q), slow.pad_points(q), atol=1e-12)
    np.testing.assert_allclose(fast.sensor_rotations(q), slow.sensor_rotations(q), atol=1e-12)
    targets = fast.pad_points(q) + rng.normal(0.0, 0.004, (len(fast.names), 3))
    move = rng.random(len(fast.names)) < 0.75
    q_fast, q_slow = q.copy(), q.copy()
    for _ in range(5):
        fast.step(q_fast, targets, move, 0.002)
        slow.step(q_slow, targets, move, 0.002)
        np.testing.assert_allclose(q_fast, q_slow, atol=1e-10)
    assert np.all(q_fast >= fast.lower) and np.all(q_fast <= fast.upper)
    for f, name in enumerate(fast.names):
        if not move[f]:
            assert np.array_equal(q_fast[kin.slices[name]], q[kin.slices[name]])


def test_steps_converge_to_a_reachable_target(kin):
    ik = PadIK(kin, PAD_POINT_SENSOR)
    q = (ik.lower + ik.upper) / 2
    goal_q = q + 0.1 * (ik.upper - ik.lower) * np.sign(np.sin(np.arange(q.size)))
    targets = ik.pad_points(goal_q)
    for _ in range(60):
        ik.step(q, targets, np.ones(len(ik.names), dtype=bool), 0.002)
    assert np.max(np.linalg.norm(ik.pad_points(q) - targets, axis=1)) < 1e-5


@pytest.mark.parametrize("seed", range(4))
def test_facing_steps_match_the_numpy_methods(kin, seed):
    """The null-space turn of the pad normals (compiled ``_facing_step``) against facing_dls_step."""
    rng = np.random.default_rng(seed)
    fast, slow = PadIK(kin, PAD_POINT_SENSOR, compiled=True), PadIK(kin, PAD_POINT_SENSOR, compiled=False)
    q = rng.uniform(fast.lower, fast.upper)
    F = len(fast.names)
    normals = fast.pad_normals(q) + rng.normal(0.0, 0.2, (F, 3))
    facing = Facing(rng.random(F) < 0.6, normals / np.linalg.norm(normals, axis=1, keepdims=True))
    targets = fast.pad_points(q) + rng.normal(0.0, 0.003, (F, 3))
    q_fast, q_slow = q.copy(), q.copy()
    for _ in range(4):
        fast.step(q_fast, targets, np.ones(F, dtype=bool), 0.002, facing)
        slow.step(q_slow, targets, np.ones(F, dtype=bool), 0.002, facing)
        np.testing.assert_allclose(q_fast, q_slow, atol=1e-10)


def test_one_pad_ik_per_kinematics(kin):
    assert shared_pad_ik(kin) is shared_pad_ik(kin)
    assert shared_pad_ik(HandKinematics(load_hand(default_hand_file()))) is not shared_pad_ik(kin)
