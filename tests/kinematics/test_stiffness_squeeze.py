"""The stiffness-aware squeeze (controller/motion.py, PadIK.squeeze_directions and
squeeze_targets): the pad goal moves so that, through the joints' position springs, a pad
held by the object is pushed along its closing vector; joint limits are kept; without
servo gains the squeeze falls back to the closing vectors."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.controller.joint_stiffness import joint_stiffness, servo_kp_nm_per_rad
from grasp_ctrl.controller.motion import FingertipMotion, squeeze_mode
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_POINT_SENSOR
from grasp_ctrl.kinematics.pad_ik import PadIK
from grasp_ctrl.kinematics.stiffness_squeeze import MAX_SQUEEZE_STRETCH


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(min(1.0, float(a @ b) / (np.linalg.norm(a) * np.linalg.norm(b)))))


def _spring_force(
    kin: HandKinematics, compliance: np.ndarray, name: str, q: np.ndarray, dx_goal: np.ndarray
) -> np.ndarray:
    """The force of the finger's joint springs on a pad held in place when its goal's pad
    point moves by ``dx_goal`` (hand frame): F = (J C J^T)^-1 dx, C = 1/kp per joint."""
    sl = kin.slices[name]
    _, J = kin.chains[name].point_and_jacobian(q[sl], PAD_POINT_SENSOR)
    return np.linalg.solve(J @ np.diag(compliance[sl]) @ J.T, dx_goal)


@pytest.fixture(scope="module")
def kin(hand):
    return HandKinematics(hand)


def test_leap_joint_stiffness_from_the_hand_file(hand):
    stiffness = joint_stiffness(hand)
    kp = servo_kp_nm_per_rad(600)
    assert kp == pytest.approx(3.2, abs=0.05)
    expected = np.array([kp * j.gain_scale for j in hand.joints])
    np.testing.assert_allclose(stiffness.kp_nm_per_rad, expected)
    assert {round(k / kp, 6) for k in stiffness.kp_nm_per_rad} == {1.0, 0.75}  # abduction joints x 0.75
    assert squeeze_mode(hand, True).startswith("stiffness-aware")


def test_without_servo_gains_the_squeeze_moves_along_the_closing_vectors(hand, kin):
    no_gains = dataclasses.replace(hand, dynamixel=dataclasses.replace(hand.dynamixel, position_p_gain=None))
    assert joint_stiffness(no_gains).kp_nm_per_rad is None
    assert "position_p_gain" in squeeze_mode(no_gains, True) and "closing vector" in squeeze_mode(no_gains, True)
    plain, aware_off = FingertipMotion(no_gains, kin, stiffness_aware=True), FingertipMotion(hand, kin)
    reference = FingertipMotion(hand, kin)
    assert plain.compliance.size == 0 and aware_off.compliance.size == 0
    distances = np.array([1e-3, 1e-3, 0.0, 1e-3])
    for m in (plain, aware_off, reference):
        m.sync(m.pregrasp_q)
    plain.squeeze_all(distances, plain.pregrasp_q, 1e-4)
    aware_off.squeeze_all(distances, aware_off.pregrasp_q, 1e-4)
    reference.advance_all(distances)
    np.testing.assert_array_equal(plain.q_goal, reference.q_goal)
    np.testing.assert_array_equal(aware_off.q_goal, reference.q_goal)


@pytest.mark.parametrize("compiled", [True, False])
def test_squeeze_direction_gives_a_spring_force_along_the_closing_vector(hand, kin, compiled):
    """At the pregrasp posture (and near it) the pad goal's squeeze direction u pushes a held
    pad along v through the joint springs; the plain closing vector does not (on the LEAP
    fingers its spring force points tens of degrees off v), so the check can fail."""
    ik = PadIK(kin, compiled=compiled)
    compliance = joint_stiffness(hand).compliance_rad_per_nm
    v = np.array([f.task_vector_hand for f in hand.fingers], dtype=float)
    grasping = [f.name for f in hand.fingers if f.grasp]
    rng = np.random.default_rng(0)
    q0 = np.array([j.pregrasp_rad for j in hand.joints])
    worst_plain = 0.0
    for _ in range(5):
        q = np.clip(q0 + rng.normal(0.0, 0.1, q0.size), ik.lower + 0.05, ik.upper - 0.05)
        u = ik.squeeze_directions(q, v, np.ones(len(v)) * 1e-4, compliance)
        for f, name in enumerate(ik.names):
            if name not in grasping:
                continue
            assert float(u[f] @ v[f]) == pytest.approx(1.0)
            assert _angle_deg(_spring_force(kin, compliance, name, q, u[f]), v[f]) < 0.1
            worst_plain = max(worst_plain, _angle_deg(_spring_force(kin, compliance, name, q, v[f]), v[f]))
    assert worst_plain > 10.0


@pytest.mark.parametrize("compiled", [True, False])
def test_a_joint_at_its_limit_is_left_out(hand, kin, compiled):
    """A joint that the squeeze would push past its limit adds no torque that way, so the
    direction comes from the other joints' springs (and stays a valid push along v)."""
    ik = PadIK(kin, compiled=compiled)
    compliance = joint_stiffness(hand).compliance_rad_per_nm
    v = np.array([f.task_vector_hand for f in hand.fingers], dtype=float)
    q = np.array([j.pregrasp_rad for j in hand.joints])
    f = ik.names.index("index")
    sl = kin.slices["index"]
    blocked = []  # (joint, posture): the joint at a limit that closing pushes it past
    for i in range(sl.stop - sl.start):
        for limit, sign in ((ik.lower, -1.0), (ik.upper, 1.0)):
            q_try = q.copy()
            q_try[sl.start + i] = limit[sl.start + i]
            _, J = kin.chains["index"].point_and_jacobian(q_try[sl], PAD_POINT_SENSOR)
            if sign * (J.T @ v[f])[i] > 1e-3:
                blocked.append((i, q_try))
    assert blocked
    pushed, q = blocked[0]
    _, J = kin.chains["index"].point_and_jacobian(q[sl], PAD_POINT_SENSOR)
    u = ik.squeeze_directions(q, v, np.full(len(v), 1e-4), compliance)[f]
    free = compliance[sl].copy()
    free[pushed] = 0.0
    expected = J @ (free * (J.T @ v[f]))
    np.testing.assert_allclose(u, expected / (expected @ v[f]), atol=1e-9)
    # opening (a negative distance) turns that joint away from its limit: it is used again
    u_open = ik.squeeze_directions(q, v, np.full(len(v), -1e-4), compliance)[f]
    full = J @ (compliance[sl] * (J.T @ v[f]))
    np.testing.assert_allclose(u_open, full / (full @ v[f]), atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(-2e-4, 2e-4), st.booleans())
def test_squeezing_keeps_joint_goals_within_limits(hand, kin, seed, distance, at_limits):
    rng = np.random.default_rng(seed)
    motion = FingertipMotion(hand, kin, stiffness_aware=True)
    assert motion.compliance.size
    q = rng.uniform(motion.lower, motion.upper)
    if at_limits:
        pick = rng.random(q.size) < 0.4
        q[pick] = np.where(rng.random(q.size) < 0.5, motion.lower, motion.upper)[pick]
    motion.sync(q)
    q_measured = q + rng.normal(0.0, 0.02, q.size)
    distances = np.where([f.grasp for f in hand.fingers], distance, 0.0)
    for _ in range(30):
        motion.squeeze_all(distances * 20.0, q_measured, 2e-4)
        assert np.all(motion.q_goal >= motion.lower) and np.all(motion.q_goal <= motion.upper)
        assert np.all(np.isfinite(motion.targets))


@pytest.mark.parametrize("compiled", [True, False])
def test_what_the_pad_followed_moves_the_goal_along_v(hand, kin, compiled):
    """A pad that did not move gets the full stiffness-aware step u d; a pad that moved
    along v by the whole distance (the object carried it) gets v d: the springs' cross
    force comes from the pad's deflection, not from where it went; the cross part is capped."""
    ik = PadIK(kin, compiled=compiled)
    compliance = joint_stiffness(hand).compliance_rad_per_nm
    v = np.array([f.task_vector_hand for f in hand.fingers], dtype=float)
    q = np.array([j.pregrasp_rad for j in hand.joints])
    d = np.array([1e-4, 1e-4, 0.0, -1e-4])
    u = ik.squeeze_directions(q, v, d, compliance)
    along = np.einsum("fr,fr->f", ik.pad_points(q), v)
    for followed, expected in ((np.zeros(4), v * d[:, None] + (u - v) * d[:, None]), (d, v * d[:, None])):
        targets = np.zeros((4, 3))
        pad_along = along - followed
        assert ik.squeeze_targets(q, q, targets, v, d, compliance, pad_along, 1.0)
        np.testing.assert_allclose(targets, expected, atol=1e-15)
        np.testing.assert_allclose(pad_along, along)
    targets, pad_along = np.zeros((4, 3)), along - np.array([-0.01, 0.0, 0.0, 0.0])  # a 1 cm jump
    ik.squeeze_targets(q, q, targets, v, d, compliance, pad_along, 2e-4)
    np.testing.assert_allclose(targets[0], v[0] * d[0] + (u[0] - v[0]) * 2e-4, atol=1e-15)
    targets, pad_along = np.zeros((4, 3)), np.full(4, np.nan)  # the first squeeze tick: nothing followed
    ik.squeeze_targets(q, q, targets, v, d, compliance, pad_along, 1.0)
    np.testing.assert_allclose(targets, u * d[:, None], atol=1e-15)
    assert np.all(np.linalg.norm(u, axis=1) <= MAX_SQUEEZE_STRETCH)


@pytest.mark.parametrize("seed", range(4))
def test_compiled_squeeze_matches_the_numpy_form(hand, kin, seed):
    rng = np.random.default_rng(seed)
    fast, slow = PadIK(kin, compiled=True), PadIK(kin, compiled=False)
    compliance = joint_stiffness(hand).compliance_rad_per_nm
    v = np.array([f.task_vector_hand for f in hand.fingers], dtype=float)
    q = rng.uniform(fast.lower, fast.upper)
    at_upper = rng.random(q.size) < 0.2
    q[at_upper] = fast.upper[at_upper]
    d = rng.normal(0.0, 1e-4, 4)
    np.testing.assert_allclose(
        fast.squeeze_directions(q, v, d, compliance), slow.squeeze_directions(q, v, d, compliance), atol=1e-12
    )
    q_measured = q + rng.normal(0.0, 0.01, q.size)
    start = fast.pad_points(q)
    along0 = np.einsum("fr,fr->f", start, v) + rng.normal(0.0, 1e-4, 4)
    along0[1] = np.nan
    results = []
    for ik in (fast, slow):
        targets, pad_along = start.copy(), along0.copy()
        ik.squeeze_targets(q, q_measured, targets, v, d, compliance, pad_along, 1e-4)
        results.append((targets, pad_along))
    np.testing.assert_allclose(results[0][0], results[1][0], atol=1e-12)
    np.testing.assert_allclose(results[0][1], results[1][1], atol=1e-12)
