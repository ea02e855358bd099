"""The fused tick paths against the code they stand in for, bit for bit: the controller's
squeeze-state tick in one compiled call (``GraspController.squeeze_plan``,
``tick_kernels.squeeze_state_tick``) against its Python tick, the mock world's packed
step against the step on its separate arrays, the linear policy's product and bias,
and the small compiled checks (a held posture, the palm's distance). Without numba the
kernels run as plain Python, so these compare the same arithmetic either way."""

from __future__ import annotations

import json
import types

import numpy as np
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from grasp_ctrl.controller import tick_kernels as tk
from grasp_ctrl.controller.machine import GraspController, _distance
from grasp_ctrl.controller.settings import settings_for
from grasp_ctrl.controller.snapshot import Snapshot
from grasp_ctrl.estimators import linear
from grasp_ctrl.estimators.registry import DEFAULT_POLICY, load_policy
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.numeric import jit
from grasp_ctrl.numeric.limits import clipped_equals
from grasp_ctrl.numeric.vec3 import dot3, norm3
from grasp_ctrl.sim.mock import world as world_mod
from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial

edge = st.sampled_from([0.0, -0.0, 1.0, -1.0, 0.25, 2.0, 3e-9, -7.5, 14.9, np.nan, np.inf, -np.inf])
values = st.one_of(edge, st.floats(-30.0, 30.0))


def same_bits(a, b) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def _record(hand, obj, seed, path, settings=None, policy=DEFAULT_POLICY, disturb=None):
    ticks = [0]

    def on_tick(world, ctrl):
        ticks[0] += 1
        if disturb:
            disturb(ticks[0], world, ctrl)

    rec = run_sim_trial(
        hand,
        obj,
        estimator_factory(policy, hand),
        seed,
        policy,
        settings=settings,
        log_path=path,
        kin=HandKinematics(hand),
        on_tick=on_tick,
        backend="mock",
    ).to_json()
    rec.pop("wall_duration_s")
    return rec


def _counting(monkeypatch, cls, name, counts):
    real = getattr(cls, name)

    def counted(self, *args):
        counts[name] = counts.get(name, 0) + 1
        return real(self, *args)

    monkeypatch.setattr(cls, name, counted)


def _nan_goal(tick, world, ctrl):
    if tick == 700:  # in the lift or the lowering: the next command is not finite
        ctrl.motion.q_goal[2] = np.nan


@pytest.mark.parametrize(
    "name, seed, stiffness_aware, disturb",
    [
        ("chips_can", 3, False, None),
        ("paper_cup", 1, False, None),
        ("mustard_bottle", 5, True, None),
        ("cleanser", 2, False, None),
        ("lego", 7, False, _nan_goal),
    ],
)
def test_squeeze_state_ticks_equal_the_python_controller(
    hand, objects, tmp_path, monkeypatch, name, seed, stiffness_aware, disturb
):
    """Whole trials (with the fused mock tick) with and without the compiled squeeze-state
    tick: the same record and tick log, bit for bit."""
    s = settings_for("paper", stiffness_aware_squeeze=stiffness_aware)  # the compiled one
    counts: dict[str, int] = {}
    _counting(monkeypatch, GraspController, "squeeze_done", counts)
    # the compiled tick takes one target for every fingertip: the heavy boxes at equal targets
    obj = objects[name] if objects[name].grip_targets is None else objects[name].with_params(grip_targets=None)
    fused = _record(hand, obj, seed, tmp_path / "a.parquet", s, disturb=disturb)
    monkeypatch.undo()
    monkeypatch.setattr(GraspController, "squeeze_plan", lambda self, palm_z: None)
    plain = _record(hand, obj, seed, tmp_path / "b.parquet", s, disturb=disturb)
    assert counts.get("squeeze_done", 0) > (100 if jit.JIT else -1)
    assert json.dumps(fused) == json.dumps(plain)
    assert pq.read_table(tmp_path / "a.parquet").equals(pq.read_table(tmp_path / "b.parquet"))


@pytest.fixture(scope="module")
def controllers(hand, objects):
    """A controller with its kernels and one with its Python code (both with the kernel pad IK),
    at equal grip targets: the compiled tick's case (unequal targets run the Python tick)."""
    import dataclasses

    from grasp_ctrl.kinematics.pad_ik import PadIK

    kin = HandKinematics(hand)
    obj = dataclasses.replace(objects["mustard_bottle"], grip_targets="equal")
    made = []
    for compiled in (True, False):
        ctrl = GraspController(hand, obj, np.array([0.0, 0.0, 0.15]), kin=kin)
        ctrl.motion.ik = PadIK(kin, compiled=True)
        ctrl._compiled = compiled
        made.append(ctrl)
    return made


@settings(max_examples=120, deadline=None)
@given(
    st.sampled_from(["lift", "hold", "lower", "close", "release", "reach", "retreat"]),
    hnp.arrays(np.float64, (4, 3), elements=values),
    hnp.arrays(np.float64, 4, elements=st.one_of(edge, st.floats(0.0, 4.0))),
    hnp.arrays(np.bool_, 4),
    st.sampled_from([0, 1, 39, 40, 41, 49, 50, 51, 399, 400, 401, 999, 1000, 1001]),
    st.integers(0, 4),
    st.lists(st.integers(0, 12), min_size=4, max_size=4),
    st.sampled_from([0.0, 0.1495, 0.15, 0.2449, 0.25, 0.25004, 0.3]),
    st.tuples(*[st.sampled_from([0.0, 0.0004, -0.0007, 0.002])] * 3),
    st.integers(0, 2**31 - 1),
)
def test_squeeze_state_tick_equals_the_python_tick(
    controllers, state, f_sensor, grip, contact, ticks, releases, lost, palm_z, offset, seed
):
    """One tick of each squeeze state from the same controller state and snapshot, through
    the compiled call and through the Python tick: the same command, counters, goals,
    targets and transition (guards near their limits: lift height, hold time, release
    debounce, lowest height, lost contact, closing time-out, opening time, reach pose and
    time-out, retreat goal)."""
    fast, slow = controllers
    rng = np.random.default_rng(seed)
    q = rng.uniform(fast.motion.lower, fast.motion.upper)
    palm = np.array([offset[0], offset[1], palm_z])
    for ctrl in (fast, slow):
        ctrl.machine.set_state(state, model=ctrl)
        ctrl.history.clear()
        ctrl.failure_reason = ctrl.failure_detail = None
        ctrl.torque_on = True
        ctrl.motion.sync(q)
        if state == "reach":  # the posture that the first reach tick sets
            ctrl.motion.set_posture(ctrl.reach_q)
        ctrl._retreat_goal = palm + np.array([offset[2], 0.0, offset[1]]) if state == "retreat" else None
        ctrl.palm_target = palm + 0.003
        ctrl.ticks_in_state, ctrl.release_count, ctrl.settle_count = ticks, releases, 0
        ctrl.lost_count = lost
    snap = Snapshot(
        t=1.0,
        q=q - rng.normal(0.0, 0.02, q.size),
        p_palm_world=palm,
        tare_ready=True,
        in_contact=contact,
        f_sensor=f_sensor,
        f_hand=f_sensor * 0.5,
        f_world=f_sensor * 0.5,
        grip_n=grip,
    )
    with np.errstate(all="ignore"):
        a, b = fast.tick(snap), slow.tick(snap)
    assert same_bits(a.q_goal, b.q_goal) and same_bits(a.p_palm_world, b.p_palm_world)
    assert a.torque_on == b.torque_on
    assert fast.state == slow.state and fast.failure_reason == slow.failure_reason
    assert (fast.ticks_in_state, fast.release_count, fast.settle_count, fast.lost_count) == (
        slow.ticks_in_state,
        slow.release_count,
        slow.settle_count,
        slow.lost_count,
    )
    assert same_bits(fast.motion.q_goal, slow.motion.q_goal) and same_bits(fast.motion.targets, slow.motion.targets)
    assert same_bits(fast.motion.q_sent, slow.motion.q_sent)


def test_squeeze_plan_leaves_other_states_and_odd_palms_to_python(controllers):
    fast, _ = controllers
    fast.machine.set_state("lift", model=fast)
    fast.palm_target = np.zeros(3)
    assert fast.squeeze_plan(0.1) is not None
    fast.palm_target = [0.0, 0.0, 0.1]
    assert fast.squeeze_plan(0.1) is None
    fast.palm_target = np.zeros(3)
    fast.motion.sync(fast.motion.open_q)
    fast._retreat_goal = None
    for state in ("tare", "ramp", "done", "fault", "reach", "retreat"):  # reach: no posture set, retreat: no goal
        fast.machine.set_state(state, model=fast)
        assert fast.squeeze_plan(0.1) is None


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


@settings(max_examples=300, deadline=None)
@given(hnp.arrays(np.float64, 3, elements=values), hnp.arrays(np.float64, 3, elements=values))
def test_palm_distance_kernel_equals_numpy(a, b):
    with np.errstate(all="ignore"):
        d = a - b
        expected = np.sqrt(0.0 + ((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2]))  # left to right, as vec3
        got = tk.distance3(a, b)
        assert same_bits(got, expected) or (np.isnan(got) and np.isnan(expected))
        assert same_bits(_distance(a, b), expected) or (np.isnan(expected) and np.isnan(_distance(a, b)))


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
