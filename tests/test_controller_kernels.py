"""The controller's compiled per-tick arithmetic (controller/tick_kernels.py) against its
Python code (GraspController._update_counters, _force_checks and _squeeze): the same
counters, flags, joint goals and pad targets bit for bit, NaN, inf and signed zeros
included. Without numba the kernels run as plain Python, so these compare the same
arithmetic either way."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.controller.settings import settings_for
from grasp_ctrl.controller.snapshot import Snapshot
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.pad_ik import PadIK
from grasp_ctrl.numeric.vec3 import norm3

edge = st.sampled_from([0.0, -0.0, 1.0, -1.0, 0.25, 2.0, 3e-9, -7.5, 14.9, 40.0, np.nan, np.inf, -np.inf])
values = st.one_of(edge, st.floats(-30.0, 30.0))


def same_bits(a, b) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def same_bits_any_nan(a, b) -> bool:
    """Bit for bit, except that a NaN's sign and payload are free (which operand's NaN an
    operation passes on is the compiler's choice; nothing reads it)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    nan = np.isnan(a)
    return a.shape == b.shape and np.array_equal(nan, np.isnan(b)) and same_bits(a[~nan], b[~nan])


@pytest.fixture(scope="module", params=[False, True], ids=["closing-vector", "stiffness-aware"])
def controllers(request, hand, objects):
    """A controller with its kernels and one with its Python code; both with the kernel pad IK
    (as before these kernels), squeezing along the closing vectors or stiffness-aware. Without
    numba the kernels run as plain Python."""
    kin = HandKinematics(hand)
    s = settings_for("paper", stiffness_aware_squeeze=request.param)
    fast = GraspController(hand, objects["chips_can"], np.zeros(3), s, kin=kin)
    slow = GraspController(hand, objects["chips_can"], np.zeros(3), s, kin=kin)
    for ctrl, compiled in ((fast, True), (slow, False)):
        ctrl.motion.ik = PadIK(kin, compiled=True)
        ctrl._compiled = compiled
    return fast, slow


def _snapshot(f_sensor, f_world, grip, contact, q=None) -> Snapshot:
    q = np.zeros(16) if q is None else q
    return Snapshot(
        t=0.0,
        q=q,
        p_palm_world=np.zeros(3),
        tare_ready=True,
        in_contact=contact,
        f_sensor=f_sensor,
        f_hand=f_world,
        f_world=f_world,
        grip_n=grip,
    )


@settings(max_examples=150, deadline=None)
@given(
    hnp.arrays(np.float64, (4, 3), elements=values),
    hnp.arrays(np.float64, (4, 3), elements=values),
    hnp.arrays(np.float64, 4, elements=values),
    hnp.arrays(np.bool_, 4),
    st.sampled_from(["tare", "ramp", "lift"]),
    st.lists(st.integers(0, 9), min_size=4, max_size=4),
)
def test_tick_checks_equal_the_python_counters(controllers, f_sensor, f_world, grip, contact, state, lost):
    fast, slow = controllers
    snap = _snapshot(f_sensor, f_world, grip, contact)
    for ctrl in (fast, slow):
        ctrl.machine.set_state(state, model=ctrl)
        ctrl.settle_count, ctrl.release_count, ctrl.lost_count = 3, 2, lost
        ctrl.ramp_settle.reset()
    limit = fast.hand.safety.max_fingertip_force_n
    with np.errstate(all="ignore"):  # (the Python path's numpy warns on NaN and inf as numpy does)
        got = fast._compiled_checks(snap, limit)
        slow._update_counters(snap)
        expected = slow._force_checks(snap, limit)
    assert got == expected >= 0
    assert (fast.settle_count, fast.release_count, fast.lost_count) == (
        slow.settle_count,
        slow.release_count,
        slow.lost_count,
    )
    assert (fast.ramp_settle.within_ticks, fast.ramp_settle.steady_ticks) == (
        slow.ramp_settle.within_ticks,
        slow.ramp_settle.steady_ticks,
    )


def test_tick_checks_leave_odd_snapshots_to_python(controllers):
    fast, _ = controllers
    f = np.zeros((4, 3))
    assert fast._compiled_checks(_snapshot(f.astype(np.float32), f, np.zeros(4), np.ones(4, bool)), 15.0) == -1
    assert fast._compiled_checks(_snapshot(f[:3], f[:3], np.zeros(3), np.ones(3, bool)), 15.0) == -1
    assert fast._compiled_checks(_snapshot(f.tolist(), f, np.zeros(4), np.ones(4, bool)), 15.0) == -1


@settings(max_examples=100, deadline=None)
@given(
    hnp.arrays(np.float64, 4, elements=values),
    st.sampled_from([(0.01, 0.01), (0.005, 0.004)]),
    st.integers(0, 2**31 - 1),
)
def test_squeeze_kernel_equals_the_python_speeds(controllers, grip, gains, seed):
    fast, slow = controllers
    rng = np.random.default_rng(seed)
    q = rng.uniform(fast.motion.lower, fast.motion.upper)
    for ctrl in (fast, slow):
        ctrl.motion.sync(q)
    assert same_bits(fast.motion.targets, slow.motion.targets)
    # the measured angles lag the goals (a squeezing hand)
    snap = _snapshot(np.zeros((4, 3)), np.zeros((4, 3)), grip, np.ones(4, bool), q - rng.normal(0.0, 0.02, q.size))
    palm, goal = rng.normal(0.0, 0.05, 3), rng.normal(0.0, 0.05, 3)
    for ctrl in (fast, slow):
        ctrl.palm_target = palm.copy()
    with np.errstate(all="ignore"):
        for k in range(3):
            for ctrl in (fast, slow):  # the lift and the lowering also move the palm
                ctrl._squeeze(snap, *gains, *((goal, 0.4) if k else ()))
    assert same_bits(fast.palm_target, slow.palm_target)
    assert same_bits(fast.motion.q_goal, slow.motion.q_goal)
    assert same_bits(fast.motion.targets, slow.motion.targets)
    assert same_bits(fast.motion._pad_along, slow.motion._pad_along)
    assert (fast.motion._posture is None) == (slow.motion._posture is None)


palm_values = st.one_of(st.sampled_from([0.0, -0.0, 1e-4, -3e-4, 0.5, np.nan, np.inf]), st.floats(-1.0, 1.0))


@settings(max_examples=300, deadline=None)
@given(
    hnp.arrays(np.float64, 3, elements=palm_values),
    hnp.arrays(np.float64, 3, elements=palm_values),
    st.sampled_from([0.0, 0.01, 0.04, 0.005]),
)
def test_palm_move_kernel_equals_the_numpy_step(controllers, palm, target, speed):
    """The compiled straight-line palm step against numpy's (its distance: vec3.norm3, the
    squares summed left to right on either path, so bit for bit on any CPU)."""
    fast, slow = controllers
    for ctrl in (fast, slow):
        ctrl.palm_target = palm.copy()
    with np.errstate(all="ignore"):
        fast._move_palm_toward(target, speed)
        slow._move_palm_toward(target, speed)
    assert same_bits_any_nan(fast.palm_target, slow.palm_target)


def test_palm_distance_sums_left_to_right():
    """vec3.norm3 is the fixed-order sum the kernels make, and within a few ulp of BLAS's
    dot product (whose own order depends on the CPU's kernels, so no bits are compared)."""
    rng = np.random.default_rng(0)
    d = rng.normal(0.0, 1.0, (20000, 3)) * rng.choice([1e-4, 1.0, 30.0], (20000, 3))
    plain = np.sqrt(0.0 + ((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2]))
    assert same_bits(plain, [norm3(v) for v in d])
    blas = np.sqrt([v.dot(v) for v in d])
    assert np.all(np.abs(plain - blas) <= 4 * np.finfo(float).eps * blas)
