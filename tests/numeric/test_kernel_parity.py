"""The fused tick paths against the code they stand in for, bit for bit: the mock world's
packed step against the step on its separate arrays, the linear policy's product and bias,
the small compiled checks (a held posture), and the fixed-order 3-vector sums. Without numba
the kernels run as plain Python, so these compare the same arithmetic either way."""

from __future__ import annotations

import json
import types

import numpy as np
import pyarrow.parquet as pq
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from grasp_ctrl.estimators import linear
from grasp_ctrl.estimators.registry import DEFAULT_POLICY, load_policy
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.numeric.limits import clipped_equals
from grasp_ctrl.numeric.vec3 import dot3, norm3
from grasp_ctrl.sim.mock import world as world_mod
from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial

edge = st.sampled_from([0.0, -0.0, 1.0, -1.0, 0.25, 2.0, 3e-9, -7.5, 14.9, np.nan, np.inf, -np.inf])
values = st.one_of(edge, st.floats(-30.0, 30.0))


def same_bits(a, b) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def _record(hand, obj, seed, path, policy=DEFAULT_POLICY):
    rec = run_sim_trial(
        hand,
        obj,
        estimator_factory(policy, hand),
        seed,
        policy,
        log_path=path,
        kin=HandKinematics(hand),
        backend="mock",
    ).to_json()
    rec.pop("wall_duration_s")
    return rec


def test_packed_world_step_equals_the_step_on_separate_arrays(hand, objects, tmp_path, monkeypatch):
    """A whole trial whose world steps with ``step_packed`` (one state buffer) and one whose
    world takes its plain path (``world_step`` on its separate arrays, ``_record`` every
    step): the same record, events and tick log."""
    obj = objects[
        "paper_cup"
    ]  # contacts, a lift and, with the oracle at half the force (a squeeze twice too hard), a crush
    packed = _record(hand, obj, 4, tmp_path / "a.parquet", policy="oracle:scale=0.5")
    monkeypatch.setattr(world_mod, "jit", types.SimpleNamespace(JIT=False))
    plain = _record(hand, obj, 4, tmp_path / "b.parquet", policy="oracle:scale=0.5")
    assert any(e["kind"] == "crushed" for e in packed["events"])
    assert json.dumps(packed) == json.dumps(plain)
    assert pq.read_table(tmp_path / "a.parquet").equals(pq.read_table(tmp_path / "b.parquet"))


def test_world_views_share_the_packed_state(hand, objects):
    w = world_mod.MockWorld(hand, objects["lego"], 0)
    for name in world_mod.PACKED:
        assert np.shares_memory(getattr(w, name), w._state), name
    w.max_obj_z = 0.25
    assert w.max_obj_z == 0.25 and w._watch[world_mod.MAX_Z] == 0.25


@settings(max_examples=150, deadline=None)
@given(hnp.arrays(np.float64, (4, 44), elements=st.one_of(edge, st.floats(-3000.0, 3000.0))), st.integers(1, 4))
def test_linear_policy_equals_the_numpy_product(rows, k):
    """ndarray.dot (the BLAS call ``@`` makes) and the compiled bias add: the same bits as
    ``tared[:, :19] @ W.T + b``, on views of several fingertips' rows as the pipeline hands them."""
    est = load_policy("linear_mock")
    tared = rows[:k]
    with np.errstate(all="ignore"):
        expected = tared[:, :19] @ est.W.T + est.b
        got = est.estimate(tared, ["x"] * k).f_sensor
    assert same_bits(np.where(np.isnan(expected), 0.0, expected), np.where(np.isnan(got), 0.0, got))
    assert np.array_equal(np.isnan(expected), np.isnan(got))


def test_linear_bias_add_without_numba_is_the_same(monkeypatch):
    est = load_policy("linear_mock")
    tared = np.random.default_rng(3).normal(0.0, 200.0, (3, 44))
    compiled = est.estimate(tared, ["a", "b", "c"]).f_sensor
    monkeypatch.setattr(linear, "jit", types.SimpleNamespace(JIT=False))
    assert same_bits(compiled, est.estimate(tared, ["a", "b", "c"]).f_sensor)


@settings(max_examples=300, deadline=None)
@given(
    hnp.arrays(np.float64, 5, elements=values),
    hnp.arrays(np.float64, 5, elements=values),
    hnp.arrays(np.float64, 5, elements=values),
    st.booleans(),
)
def test_clipped_equals_is_clip_then_array_equal(q, a, b, same):
    lower, upper = np.full(5, -2.0), np.full(5, 2.0)
    with np.errstate(all="ignore"):
        clipped = np.clip(q, lower, upper)
        if same:  # mostly equal: the case the check exists for
            a, b = clipped.copy(), clipped.copy()
        expected = np.array_equal(clipped, a) and np.array_equal(clipped, b)
    assert clipped_equals(q, lower, upper, a, b) == expected


def test_mujoco_wrist_step_equals_the_numpy_step():
    """MuJoCoWorld's mocap wrist moved on Python floats: numpy's arithmetic with the distance
    summed left to right (vec3.norm3), bit for bit on any CPU."""
    from grasp_ctrl.sim.mujoco.world import mocap_step

    rng = np.random.default_rng(5)
    for _ in range(3000):
        mocap = rng.normal(0.0, 0.1, 3) * rng.choice([1e-4, 1.0], 3)
        target = mocap + rng.normal(0.0, 1e-3, 3) * rng.choice([1e-3, 1.0, 30.0])
        max_move = float(rng.choice([1e-4, 4e-4, 1e-2]))
        for _ in range(5):
            expected = mocap.copy()
            delta = target - expected
            dist = norm3(delta)
            expected += delta if dist <= max_move else delta * (max_move / dist)
            got = np.array(mocap_step(mocap.tolist(), *target.tolist(), max_move))
            assert same_bits(got, expected)
            mocap = expected


def test_three_vector_dot_is_fixed_order_and_near_blas():
    """The plain sums that stand in for ``x @ y`` of 3-vectors (vec3.dot3, MuJoCoWorld's slip
    speed, ``mocap_step``): 0 + left to right, whatever the CPU; within a few ulp of BLAS's
    dot product, whose summation order depends on the kernels the CPU gets."""
    rng = np.random.default_rng(2)
    x = rng.normal(0.0, 1.0, (20000, 3)) * rng.choice([1e-4, 1.0, 30.0], (20000, 3))
    y = rng.normal(0.0, 1.0, (20000, 3)) * rng.choice([1e-4, 1.0, 30.0], (20000, 3))
    plain = 0.0 + ((x[:, 0] * y[:, 0] + x[:, 1] * y[:, 1]) + x[:, 2] * y[:, 2])
    assert same_bits(plain, [dot3(a, b) for a, b in zip(x, y)])
    blas = np.array([a @ b for a, b in zip(x, y)])
    assert np.all(np.abs(plain - blas) <= 4 * np.finfo(float).eps * np.abs(x * y).sum(axis=1))


def test_palm_distance_sums_left_to_right():
    """vec3.norm3 (the controller's palm distances) is the fixed-order sum, and within a few ulp
    of BLAS's dot product (whose own order depends on the CPU's kernels, so no bits are compared)."""
    rng = np.random.default_rng(0)
    d = rng.normal(0.0, 1.0, (20000, 3)) * rng.choice([1e-4, 1.0, 30.0], (20000, 3))
    plain = np.sqrt(0.0 + ((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2]))
    assert same_bits(plain, [norm3(v) for v in d])
    blas = np.sqrt([v.dot(v) for v in d])
    assert np.all(np.abs(plain - blas) <= 4 * np.finfo(float).eps * blas)
