"""The trial tick's compiled shortcuts (sensing halves, backends, tick log row, force
peaks) against the numpy code they replace: the same numbers bit for bit, signed
zeros and NaN included, and the same faults. Without numba the kernels run as plain
Python, so these compare the same arithmetic either way."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from grasp_ctrl.config.sensor_layout import FRAME_LEN, PDC
from grasp_ctrl.controller.snapshot import Command, Snapshot
from grasp_ctrl.estimators.registry import DEFAULT_POLICY, load_policy
from grasp_ctrl.hardware.base import JointState
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.loop.loop_kernels import log_row, place_forces, sense_forces, sense_inputs, track_peaks
from grasp_ctrl.loop.sensing import SensingPipeline
from grasp_ctrl.loop.ticklog import TickLog
from grasp_ctrl.numeric.limits import clamp_palm_height, clamped_palm_target
from grasp_ctrl.sim.mock.backends import joint_state_kernel
from grasp_ctrl.sim.mock.world import MockWorld, _clamped_target, _clip_into, _limited_goal
from grasp_ctrl.sim.world_backends import WorldSensors, checked_limit_goal
from grasp_ctrl.sim.world_parts import _finite_copy
from grasp_ctrl.tactile.tare import scatter_rows, tare_and_gate_bits


def same_bits(a, b) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


edge = st.sampled_from([0.0, -0.0, 1.0, -1.0, 0.25, 3e-9, -7.5, np.nan, np.inf, -np.inf, 1e300])
values = st.one_of(edge, st.floats(-1e3, 1e3))


@settings(max_examples=150, deadline=None)
@given(hnp.arrays(np.float64, (4, 3), elements=values), hnp.arrays(np.float64, (3, 4), elements=values))
def test_force_peaks_equal_the_numpy_maxima(f, peaks):
    grip, true_n = f[:, 0] * 2.0, f[:, 1] - 1.0
    expected = peaks.copy()
    with np.errstate(over="ignore", invalid="ignore"):
        np.maximum(expected[0], np.add.reduce(f * f, axis=1), out=expected[0])
    np.maximum(expected[1], grip, out=expected[1])
    np.maximum(expected[2], true_n, out=expected[2])
    got = peaks.copy()
    with np.errstate(over="ignore", invalid="ignore"):  # (the plain-Python kernel warns as numpy does)
        track_peaks(f, grip, true_n, got[0], got[1], got[2])
    assert same_bits(got, expected)


@settings(max_examples=150, deadline=None)
@given(hnp.arrays(np.float64, 3, elements=values), st.sampled_from([0.0, -0.0, 0.1]), st.sampled_from([0.3, 0.0, -0.0]))
def test_arm_target_clamps_like_python_min_max(p, z_min, z_max):
    expected = np.array(p, dtype=float)
    expected[2] = min(max(float(expected[2]), z_min), z_max)
    got = np.empty(3)
    clamp_palm_height(p, z_min, z_max, got)
    assert same_bits(got, expected)
    assert same_bits(clamped_palm_target(p, z_min, z_max), expected)  # every arm backend's clamp
    assert same_bits(clamped_palm_target(list(p), z_min, z_max), expected)
    got = np.full(3, 7.0)  # the mock world's one-pass command: also refuses a non-finite target
    finite = bool(np.isfinite(expected).all())
    assert _clamped_target(p, z_min, z_max, got) == finite
    if finite:
        assert same_bits(got, expected)


@settings(max_examples=150, deadline=None)
@given(hnp.arrays(np.float64, 6, elements=values), hnp.arrays(np.float64, 6, elements=values))
def test_goal_clip_copy_and_limit_equal_numpy(goal, prev):
    lower, upper = np.full(6, -1.0), np.array([1.0, 0.0, -0.0, 2.0, 0.5, 1e9])
    got = np.empty(6)
    _clip_into(goal, lower, upper, got)
    assert same_bits(got, np.minimum(np.maximum(goal, lower), upper))
    out = np.full(6, 7.0)
    finite = bool(np.isfinite(goal).all())
    assert _finite_copy(goal, out) == finite
    assert same_bits(out, goal if finite else np.full(6, 7.0))
    out = np.full(6, 7.0)
    assert checked_limit_goal(goal, prev, 0.05, lower, upper, out) == finite
    if finite:  # MockHand.write_goals's numpy arithmetic
        q = np.minimum(np.maximum(goal, prev - 0.05), prev + 0.05)
        assert same_bits(out, np.minimum(np.maximum(q, lower), upper))
    else:
        assert np.all(out == 7.0)
    # the mock world's one-pass write: the same, then the world's own joint limits
    joint_lower, joint_upper = np.full(6, -0.5), np.full(6, 0.5)
    got = np.full(6, 7.0)
    assert _limited_goal(goal, prev, 0.05, lower, upper, joint_lower, joint_upper, got) == finite
    if finite:
        assert same_bits(got, np.minimum(np.maximum(out, joint_lower), joint_upper))
    else:
        assert np.all(got == 7.0)


def test_joint_state_kernel_is_the_numpy_arithmetic():
    rng = np.random.default_rng(0)
    q, prev, servo = rng.normal(0, 1, 16), rng.normal(0, 1, 16), rng.normal(0, 1, 16)
    prev[3] = q[3] = -0.0
    out = [np.empty(16) for _ in range(3)]
    prev_in = prev.copy()
    joint_state_kernel(q, prev_in, servo, 0.01, 10.0, 0.5, *out)
    assert same_bits(out[0], q) and same_bits(prev_in, q)
    assert same_bits(out[1], (q - prev) / 0.01)
    assert same_bits(out[2], 10.0 * (servo - q) / 0.5)


@pytest.mark.parametrize("seed", range(3))
def test_gate_bits_gather_and_scatter(seed):
    rng = np.random.default_rng(seed)
    n = 4
    baseline = rng.uniform(1500, 3000, (n, FRAME_LEN))
    count = rng.integers(0, 12, n)
    raw = np.rint(baseline + rng.normal(0, 8, (n, FRAME_LEN)))
    raw[:, PDC] += rng.choice([0.0, 30.0], n)
    tared, contact, touching = np.empty((n, FRAME_LEN)), np.empty(n, dtype=bool), np.full((n, FRAME_LEN), 9.0)
    q, palm = np.zeros(16), np.zeros(3)
    bits = sense_inputs(q, palm, raw, baseline, count.copy(), 10.0, 10, tared, contact, touching)
    idx = np.flatnonzero(contact)
    assert bits == sum(1 << int(i) for i in idx)
    assert bits == tare_and_gate_bits(
        raw, baseline, count.copy(), 10.0, 10, np.empty((n, FRAME_LEN)), np.empty(n, dtype=bool)
    )
    assert same_bits(touching[: len(idx)], tared[idx]) and np.all(touching[len(idx) :] == 9.0)
    rows = rng.normal(0, 1, (len(idx), 3))
    expected, got = np.zeros((n, 3)), np.zeros((n, 3))
    expected[idx] = rows
    scatter_rows(rows, bits, got)
    assert same_bits(got, expected)


def test_sense_inputs_refuses_non_finite_angles_and_changes_nothing():
    n = 3
    count = np.array([3, 9, 0])
    tared = np.full((n, FRAME_LEN), 7.0)
    for q, palm in ((np.array([0.0, np.nan]), np.zeros(3)), (np.zeros(2), np.array([0.0, np.inf, 0.0]))):
        assert (
            sense_inputs(
                q,
                palm,
                np.full((n, FRAME_LEN), 2000.0),
                np.zeros((n, FRAME_LEN)),
                count,
                10.0,
                10,
                tared,
                np.zeros(n, dtype=bool),
                np.empty((n, FRAME_LEN)),
            )
            == -2
        )
    assert np.array_equal(count, [3, 9, 0]) and np.all(tared == 7.0)


def _snapshots_agree(a: Snapshot, b: Snapshot) -> bool:
    for name in Snapshot._fields:
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            if not same_bits(x, y):
                return False
        elif x != y:
            return False
    return True


@pytest.mark.parametrize("seed", range(3))
def test_compiled_snapshot_equals_the_long_way(hand, seed):
    """SensingPipeline's compiled halves against its numpy checks and PadIK.sensor_forces,
    over contacts coming and going, and faults (non-finite angles, a bad frame)."""
    kin = HandKinematics(hand)
    est = load_policy(DEFAULT_POLICY, hand)
    fast, slow = SensingPipeline(hand, kin, est), SensingPipeline(hand, kin, est)
    slow._compiled = False
    n, J = len(hand.fingers), len(hand.joints)
    rng = np.random.default_rng(seed)
    baseline = rng.uniform(1500, 3000, (n, FRAME_LEN)).round()
    for p in (fast, slow):
        p.tactile.set_baseline(baseline[None])
    for k in range(40):
        raw = np.rint(baseline + rng.normal(0, 5, (n, FRAME_LEN)))
        raw[:, PDC] += np.where(rng.random(n) < 0.6, 80.0, 0.0)
        raw[:, :19] -= np.where(rng.random((n, 1)) < 0.5, 200.0, 0.0)
        q = rng.uniform(-0.3, 1.0, J) * rng.choice([1.0, -0.0], J)
        palm = rng.normal(0, 0.1, 3)
        if k == 20:
            q[5] = np.nan
        if k == 30:
            raw[1, 7] = 5000.0
        joints = JointState(q, 0 * q, 0 * q, 0.01 * k)
        a = fast.snapshot(raw.copy(), joints, palm.copy(), False)
        b = slow.snapshot(raw.copy(), joints, palm.copy(), False)
        assert _snapshots_agree(a, b), k
        assert same_bits(fast.tared, slow.tared)
        assert np.array_equal(fast.tactile.gate.count, slow.tactile.gate.count)
    assert a.fault is None and b.fault is None


def test_mock_sensors_matrix_equals_the_frames_and_a_pause_keeps_the_last_one(hand, objects):
    world = MockWorld(hand, objects["chips_can"], 3)
    sensors = WorldSensors(world)
    sensors.start()
    pipeline = SensingPipeline(hand, HandKinematics(hand), load_policy(DEFAULT_POLICY, hand))
    ids = pipeline.sensor_ids
    for _ in range(3):
        world.step()
        matrix, t_recv = sensors.latest_matrix(ids)
        assert t_recv == world.t
        assert same_bits(matrix, pipeline.frames_matrix(sensors.read_latest(), world.t))
        world.step()
        delivered = sensors.latest_matrix(ids)[0]
    sensors.paused.add(ids[1])
    assert sensors.latest_matrix(ids) is None  # paused: the long way
    world.step()
    latest = sensors.read_latest()
    assert same_bits(latest[ids[1]].values, delivered[1]) and latest[ids[1]].t_recv == pytest.approx(world.t - world.dt)
    assert same_bits(latest[ids[0]].values, world.raw[0])
    assert sensors.latest_matrix(list(reversed(ids))) is None  # not the world's order


def _log_rows(compiled: bool, rng: np.random.Generator) -> np.ndarray:
    log = TickLog("unused_ticks.parquet", ["index", "thumb"], 3, truth=True)
    log._compiled = compiled
    for k in range(5):
        f = rng.normal(0, 2, (2, 3)) * rng.choice([1.0, -0.0], (2, 3))
        snap = Snapshot(
            t=0.01 * k,
            q=rng.normal(0, 1, 3),
            p_palm_world=rng.normal(0, 1, 3),
            tare_ready=True,
            in_contact=np.array([k % 2 == 0, True]),
            f_sensor=f,
            f_hand=f,
            f_world=-f,
            grip_n=np.hypot(f[:, 0], f[:, 1]),
        )
        raw = rng.integers(0, 4096, (2, FRAME_LEN)).astype(float)
        cmd = Command(q_goal=snap.q + 0.1, p_palm_world=rng.normal(0, 1, 3))
        log.append(
            "lift",
            snap,
            cmd,
            raw - 1000.0,
            true_f_sensor=f * 1.1,
            object_z=math.pi * k,
            table_force=np.nan,
            raw=raw,
            grip_target_n=2.0,
        )
    return log._block[: log._n].copy()


def test_tick_log_row_kernel_stores_what_the_numpy_path_stores():
    assert same_bits(_log_rows(True, np.random.default_rng(5)), _log_rows(False, np.random.default_rng(5)))


def test_tick_log_row_kernel_refuses_a_shape_that_does_not_fit():
    block = np.full((2, 6 + 2 * (FRAME_LEN + 12) + 2 * 3 + 2), 5.0)
    args = (
        np.zeros(3),
        np.zeros(3),
        0.0,
        np.zeros((2, FRAME_LEN)),
        np.zeros(2, dtype=bool),
        np.zeros((2, FRAME_LEN)),
        np.zeros(2),
        np.zeros((2, 3)),
        np.zeros((2, 3)),
        np.zeros(3),
        np.zeros(3),
    )
    assert log_row(block, 0, 0.0, *args, np.zeros((2, 3)), 0.0, 0.0)
    assert not log_row(block, 1, 0.0, *args, np.zeros((3, 3)), 0.0, 0.0)  # truth for 3 fingertips
    assert not log_row(block, 2, 0.0, *args, np.zeros((2, 3)), 0.0, 0.0)  # past the block
    assert np.all(block[1] == 5.0)


@pytest.mark.parametrize("seed", range(3))
def test_a_zero_force_turns_into_zeros(hand, seed):
    """The snapshot's shortcut without contact: +0.0 forces through the compiled rotation give +0.0."""
    from grasp_ctrl.kinematics.pad_ik import PadIK

    ik = PadIK(HandKinematics(hand), compiled=True)
    rng = np.random.default_rng(seed)
    q = rng.uniform(ik.lower, ik.upper) * rng.choice([1.0, -0.0], len(ik.lower))
    f_hand, grip = ik.sensor_forces(q, np.zeros((len(ik.names), 3)))
    assert same_bits(f_hand, np.zeros_like(f_hand)) and same_bits(grip, np.zeros_like(grip))


def test_mock_backends_write_like_the_long_way(hand, objects):
    """MockHand and MockArm through the world's one-pass writes and through the generic path."""
    from grasp_ctrl.errors import HardwareError
    from grasp_ctrl.sim.mock.backends import MockArm, MockHand

    worlds = [MockWorld(hand, objects["chips_can"], 1) for _ in range(2)]
    hands = [MockHand(w, hand) for w in worlds]
    arms = [MockArm(w, hand) for w in worlds]
    hands[1]._write_limited = None
    arms[1]._set_clamped = None
    rng = np.random.default_rng(2)
    for _ in range(20):
        goal = worlds[0].q_goal + rng.normal(0, 0.2, len(hand.joints))
        target = rng.normal(0, 0.3, 3)
        for h, a in zip(hands, arms):
            h.write_goals(goal)
            a.command(target)
        assert same_bits(worlds[0].q_goal, worlds[1].q_goal)
        assert same_bits(worlds[0].palm_target, worlds[1].palm_target)
    bad = worlds[0].q_goal.copy()
    bad[2] = np.nan
    for h, a, w in zip(hands, arms, worlds):
        before = w.q_goal.copy()
        with pytest.raises(HardwareError, match="bad goal vector"):
            h.write_goals(bad)
        with pytest.raises(ValueError, match="palm target must be finite"):
            a.command(np.array([0.0, np.inf, 0.1]))
        assert same_bits(w.q_goal, before)


@pytest.mark.parametrize("seed", range(4))
def test_placed_forces_equal_the_scatter_then_rotation(hand, seed):
    """place_forces: the policy's rows into their fingertips' places (zeros elsewhere), then
    the compiled rotation; a non-finite row: False, the placed forces still written."""
    from grasp_ctrl.kinematics.pad_ik import PadIK

    ik = PadIK(HandKinematics(hand), compiled=True)
    rng = np.random.default_rng(seed)
    F = len(ik.names)
    q = rng.uniform(ik.lower, ik.upper)
    bits = int(rng.integers(1, 2**F))
    k = bin(bits).count("1")
    rows = rng.normal(0, 2, (k, 3)) * rng.choice([1.0, -0.0], (k, 3))
    expected = np.zeros((F, 3))
    scatter_rows(rows, bits, expected)
    f_hand, grip = np.empty((F, 3)), np.empty(F)
    assert sense_forces(q, expected, ik.geometry, ik.layout, f_hand, grip)
    got, got_hand, got_grip = np.full((F, 3), 9.0), np.empty((F, 3)), np.empty(F)
    assert place_forces(rows, bits, q, ik.geometry, ik.layout, got, got_hand, got_grip)
    assert same_bits(got, expected) and same_bits(got_hand, f_hand) and same_bits(got_grip, grip)
    rows[0, 1] = np.nan
    assert not place_forces(rows, bits, q, ik.geometry, ik.layout, got, got_hand, got_grip)
    assert np.isnan(got).sum() == 1


@settings(max_examples=200, deadline=None)
@given(hnp.arrays(np.int64, (4, FRAME_LEN), elements=st.integers(0, 4095)), st.sampled_from([np.int64, np.float64]))
def test_pac_spread_is_numpys_std_to_the_bit(raw, dtype):
    from grasp_ctrl.config.sensor_layout import PAC
    from grasp_ctrl.loop.tick import pac_spread

    raw = raw.astype(dtype)
    assert same_bits(pac_spread(raw), np.asarray(raw, dtype=float)[:, PAC].std(axis=1))
