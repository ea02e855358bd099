"""The control tick's compiled pieces (and their fast paths) against the numpy code they replace.

Each must give the numpy result bit for bit (trials repeat exactly), so the
comparisons are exact: ``np.array_equal`` on the bit patterns, signed zeros and
NaN included.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import grasp_ctrl
from grasp_ctrl.config.sensor_layout import FRAME_LEN, PDC
from grasp_ctrl.estimators.pipeline import TactilePipeline
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.pad_ik import PadIK
from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.finite import all_finite
from grasp_ctrl.numeric.limits import limit_goal, step_toward
from grasp_ctrl.tactile.tare import ContactGate, Tare, tare_and_gate


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def test_every_module_with_kernels_is_in_the_cache_key():
    """numba's cache misses edits to kernels called from other files, so every file with a
    kernel must be hashed into the cache folder's name (jit.KERNEL_SOURCES)."""
    package = Path(grasp_ctrl.__file__).parent
    with_kernels = set()
    for path in package.rglob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and any(
                (isinstance(d, ast.Name) and d.id == "njit") or (isinstance(d, ast.Attribute) and d.attr == "njit")
                for d in node.decorator_list
            ):
                with_kernels.add(path.relative_to(package).as_posix())
    assert with_kernels <= set(jit.KERNEL_SOURCES), sorted(with_kernels - set(jit.KERNEL_SOURCES))


floats = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=200, deadline=None)
@given(hnp.arrays(np.float64, st.integers(0, 20), elements=floats))
def test_all_finite_answers_like_isfinite(a):
    assert all_finite(a) == bool(np.isfinite(a).all())


def test_all_finite_on_other_shapes_and_types():
    assert all_finite(np.array([1e308, -1e308, 3.0]))  # no overflow: each value is checked
    assert not all_finite(np.array([[1.0, 2.0], [np.inf, 0.0]]))
    assert all_finite(np.zeros((4, 3))) and all_finite(np.zeros(0))
    assert all_finite(np.arange(5)) and not all_finite(np.array([1.0, np.nan], dtype=np.float32))
    strided = np.array([1.0, np.nan, 2.0, 3.0])
    assert all_finite(strided[::2]) and not all_finite(strided[1::2])


limits_values = st.sampled_from([0.0, -0.0, 0.05, -0.05, 1.0, -1.0, 0.3, np.nan, 2.5, -2.5])


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(limits_values, limits_values, st.floats(-3, 3), st.floats(-3, 3)), min_size=1, max_size=16))
def test_goal_limits_equal_the_numpy_clamps(rows):
    goal, sent = np.array([r[0] for r in rows]), np.array([r[1] + r[2] for r in rows])
    lower = np.array([min(r[2], r[3]) for r in rows])
    upper = np.array([max(r[2], r[3]) for r in rows])
    max_step = 0.05
    # FingertipMotion.next_goal's numpy arithmetic
    step = np.minimum(np.maximum(goal - sent, -max_step), max_step)
    expected = np.minimum(np.maximum(sent + step, lower), upper)
    got = sent.copy()
    step_toward(goal, got, max_step, lower, upper)
    assert same_bits(got, expected)
    # MockHand.write_goals's numpy arithmetic
    q = np.minimum(np.maximum(goal, sent - max_step), sent + max_step)
    expected = np.minimum(np.maximum(q, lower), upper)
    got = np.empty_like(goal)
    limit_goal(goal, sent, max_step, lower, upper, got)
    assert same_bits(got, expected)


def _numpy_tare_and_gate(raw, baseline, count, threshold, frames):
    tare = Tare(raw.shape[0])
    tare.baseline = baseline
    gate = ContactGate(raw.shape[0], threshold, frames)
    gate.count = count.copy()
    tared = tare.apply(raw)
    contact = gate.update(tared)
    return tared, contact, gate.count


@pytest.mark.parametrize("seed", range(5))
def test_tare_and_gate_equals_tare_and_gate_objects(seed):
    rng = np.random.default_rng(seed)
    n = 4
    baseline = rng.uniform(1500, 3000, (n, FRAME_LEN))
    count = rng.integers(0, 12, n)
    for _ in range(20):
        raw = np.rint(baseline + rng.normal(0, 8, (n, FRAME_LEN)))
        raw[:, PDC] += rng.choice([0.0, 5.0, 30.0], n)
        tared_np, contact_np, count_np = _numpy_tare_and_gate(raw, baseline, count, 10.0, 10)
        tared, contact = np.empty((n, FRAME_LEN)), np.empty(n, dtype=bool)
        touching = tare_and_gate(raw, baseline, count, 10.0, 10, tared, contact)
        assert same_bits(tared, tared_np)
        assert np.array_equal(contact, contact_np) and np.array_equal(count, count_np)
        assert touching == int(contact_np.sum())


@pytest.mark.parametrize("bad", [np.nan, -1.0, 4096.0, np.inf])
def test_tare_and_gate_refuses_a_bad_count_and_changes_nothing(bad):
    n = 3
    raw = np.full((n, FRAME_LEN), 2000.0)
    raw[1, 7] = bad
    count = np.array([3, 9, 0])
    tared, contact = np.full((n, FRAME_LEN), 7.0), np.zeros(n, dtype=bool)
    assert tare_and_gate(raw, np.zeros((n, FRAME_LEN)), count, 10.0, 10, tared, contact) == -1
    assert np.array_equal(count, [3, 9, 0]) and np.all(tared == 7.0)


class _Scaled:
    """A stand-in policy: one row of output per row of input, from that row alone."""

    name = "scaled"
    has_variance = True

    def estimate(self, tared, fingers):
        from grasp_ctrl.estimators.base import Estimate

        e = np.asarray(tared, dtype=float)[:, :19]
        return Estimate(f_sensor=e[:, :3] * 1e-3, variance=np.abs(e[:, 3:6]) * 1e-4)


@pytest.mark.parametrize("touching", [0, 2, 4])
def test_tactile_step_fast_paths_match_the_numpy_path(touching):
    """The compiled tare+gate and the all-in-contact shortcut give what the numpy path gives."""
    fingers = ["index", "middle", "ring", "thumb"]
    rng = np.random.default_rng(touching)
    baseline = rng.uniform(1500, 3000, (1, 4, FRAME_LEN)).round()
    fast, slow = (TactilePipeline(_Scaled(), fingers, frames=2) for _ in range(2))
    fast.set_baseline(baseline)
    slow.set_baseline(baseline)
    for _ in range(4):
        raw = np.rint(baseline[0] + rng.normal(0, 5, (4, FRAME_LEN)))
        raw[:touching, PDC] += 50.0
        a = fast.step(raw)
        b = slow.step(raw.tolist())  # not an ndarray: the numpy path
        assert same_bits(a.tared, b.tared) and np.array_equal(a.in_contact, b.in_contact)
        # what the pipeline did before its shortcuts: the policy on the rows in contact, scattered
        f_sensor, variance = np.zeros((4, 3)), np.zeros((4, 3))
        idx = np.flatnonzero(b.in_contact)
        if idx.size:
            est = _Scaled().estimate(b.tared[idx], [fingers[i] for i in idx])
            f_sensor[idx], variance[idx] = est.f_sensor, est.variance
        for tips in (a, b):
            assert same_bits(tips.f_sensor, f_sensor) and same_bits(tips.variance, variance)
    assert int(a.in_contact.sum()) == touching


@pytest.mark.parametrize("seed", range(4))
def test_force_rotation_kernel_is_bit_identical_to_its_rotations_and_within_1e_12_of_the_numpy_path(hand, seed):
    kin = HandKinematics(hand)
    fast, slow = PadIK(kin, compiled=True), PadIK(kin, compiled=False)
    rng = np.random.default_rng(seed)
    q = rng.uniform(fast.lower, fast.upper)
    f_sensor = rng.normal(0, 2, (len(fast.names), 3)) * rng.choice([0.0, -0.0, 1.0], (len(fast.names), 3))
    f_fast, g_fast = fast.sensor_forces(q, f_sensor)
    f_hand = np.einsum("nij,nj->ni", fast.sensor_rotations(q), f_sensor)  # the rotations agree to 1e-12 (test_pad_ik)
    assert same_bits(f_fast, f_hand)
    assert same_bits(g_fast, np.sqrt(f_hand[:, 0] ** 2 + f_hand[:, 1] ** 2))
    f_slow, g_slow = slow.sensor_forces(q, f_sensor)
    np.testing.assert_allclose(f_fast, f_slow, atol=1e-12)
    np.testing.assert_allclose(g_fast, g_slow, atol=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_target_advance_kernel_matches_the_numpy_path(hand, seed):
    kin = HandKinematics(hand)
    fast, slow = PadIK(kin, compiled=True), PadIK(kin, compiled=False)
    rng = np.random.default_rng(seed)
    q = rng.uniform(fast.lower, fast.upper)
    vectors = rng.normal(0, 1, (len(fast.names), 3))
    distances = rng.choice([0.0, 1e-4, -2e-4], len(fast.names))
    targets = fast.pad_points(q)
    q_fast, t_fast, q_slow, t_slow = q.copy(), targets.copy(), q.copy(), targets.copy()
    moved = fast.advance(q_fast, t_fast, vectors, distances, 0.002)
    assert moved == slow.advance(q_slow, t_slow, vectors, distances, 0.002) == bool(np.any(distances != 0.0))
    assert same_bits(t_fast, targets + vectors * distances[:, None])
    np.testing.assert_allclose(q_fast, q_slow, atol=1e-10)
    assert not fast.advance(q_fast, t_fast, vectors, np.zeros(len(fast.names)), 0.002)
