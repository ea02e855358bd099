"""The tick's list arithmetic and compiled passes against the numpy code they replace, bit for
bit: numpy's small sums, the PAC spread, the force checks' squared norms, the ramp's windows of
recent errors, the MuJoCo goal's clip, the squeeze in one call, and the grip-load controller's
per-tick rules (coordination, vibration, carried load, unwind, safety cap) against their numpy
forms kept here as the reference."""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from grasp_ctrl.config.sensor_layout import FRAME_LEN, PAC
from grasp_ctrl.controller.grip_load import GripLoadController
from grasp_ctrl.controller.ramp_settle import RecentRows
from grasp_ctrl.controller.registry import make_controller, settings_for
from grasp_ctrl.controller.snapshot import Snapshot
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.pad_ik import Facing, shared_pad_ik
from grasp_ctrl.loop.tick import pac_spread
from grasp_ctrl.numeric.limits import offset_clamp
from grasp_ctrl.numeric.reductions import np_sum


def same_bits(a, b) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


edge = st.sampled_from([0.0, -0.0, 1.0, -1.0, 0.1, 3e-9, -7.5, 1e16, -1e16, 1e300, np.nan, np.inf, -np.inf])
values = st.one_of(edge, st.floats(-1e6, 1e6), st.floats(-1e-3, 1e-3))


@settings(max_examples=300, deadline=None)
@given(st.lists(values, max_size=12))
def test_np_sum_is_numpys_sum(xs):
    with np.errstate(invalid="ignore", over="ignore"):
        assert same_bits(np_sum(xs), np.sum(np.array(xs, dtype=float)))


@settings(max_examples=200, deadline=None)
@given(hnp.arrays(np.float64, (4, FRAME_LEN), elements=values))
def test_pac_spread_is_numpys_std_for_any_floats(raw):
    with np.errstate(invalid="ignore", over="ignore"):
        assert same_bits(pac_spread(raw), raw[:, PAC].std(axis=1))


@settings(max_examples=200, deadline=None)
@given(hnp.arrays(np.float64, (4, 3), elements=values))
def test_force_checks_square_norms_as_einsum_does(hand, objects, f):
    ctrl = make_controller(hand, objects["mustard_bottle"], np.zeros(3), settings_for("grip_load"))
    snap = Snapshot(0.0, np.zeros(16), np.zeros(3), True, np.ones(4, bool), f, f, f, np.zeros(4))
    with np.errstate(invalid="ignore", over="ignore"):
        assert same_bits(ctrl._force_sq(snap), np.einsum("ij,ij->i", f, f))


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 12), st.lists(hnp.arrays(np.float64, 3, elements=values), max_size=40), st.integers(0, 39))
def test_recent_rows_are_the_deques_array(cap, rows, clear_at):
    recent, kept = RecentRows(cap), deque(maxlen=cap)
    for i, row in enumerate(rows):
        if i == clear_at:
            recent.clear()
            kept.clear()
        recent.append(row)
        kept.append(np.array(row))
        got = recent.rows()
        assert len(recent) == len(kept) and got.flags.c_contiguous
        assert same_bits(got, np.array(kept))
        with np.errstate(invalid="ignore", over="ignore"):
            assert same_bits(np.mean(got, axis=0), np.mean(kept, axis=0))


@settings(max_examples=200, deadline=None)
@given(
    hnp.arrays(np.float64, 6, elements=values),
    hnp.arrays(np.float64, 6, elements=st.sampled_from([0.0, -0.0, 0.01, -0.01, np.nan])),
)
def test_mujoco_goal_clamp_is_np_clip(q, offset):
    lower = np.array([-1.0, 0.0, -0.0, 0.0, -0.5, -np.inf])
    upper = np.array([1.0, 0.0, 0.0, 2.0, -0.0, 1e9])
    out = np.empty(6)
    offset_clamp(q, offset, lower, upper, out)
    with np.errstate(invalid="ignore", over="ignore"):
        assert same_bits(out, np.clip(q + offset, lower, upper))


@pytest.mark.parametrize("seed", range(6))
def test_squeeze_in_one_call_is_squeeze_targets_then_step(hand, seed):
    ik = shared_pad_ik(HandKinematics(hand))
    if not ik.compiled:
        pytest.skip("the one-call squeeze is the compiled one")
    rng = np.random.default_rng(seed)
    lower = np.array([j.lower_rad for j in hand.joints])
    upper = np.array([j.upper_rad for j in hand.joints])
    q_goal = rng.uniform(lower, upper)
    q_measured = np.clip(q_goal + rng.normal(0.0, 0.02, q_goal.size), lower, upper)
    v = np.array([f.task_vector_hand for f in hand.fingers], dtype=float)
    distances = rng.choice([0.0, 1e-4, -2e-4, 3e-4], size=len(hand.fingers))
    compliance = rng.uniform(0.5, 2.0, q_goal.size)
    along = np.where(rng.random(len(hand.fingers)) < 0.5, np.nan, rng.normal(0.0, 0.01, len(hand.fingers)))
    facing = Facing(rng.random(len(hand.fingers)) < 0.5, rng.normal(0.0, 1.0, (len(hand.fingers), 3)))
    targets = ik.pad_points(q_goal) + rng.normal(0.0, 1e-3, (len(hand.fingers), 3))
    expected = [q_goal.copy(), targets.copy(), along.copy()]
    moved = ik.squeeze_targets(expected[0], q_measured, expected[1], v, distances, compliance, expected[2], 5e-4)
    if moved:
        ik.step(expected[0], expected[1], distances != 0.0, 0.002, facing)
    got = [q_goal.copy(), targets.copy(), along.copy()]
    assert ik.squeeze_step(got[0], q_measured, got[1], v, distances, compliance, got[2], 5e-4, 0.002, facing) == moved
    for a, b in zip(got, expected):
        assert same_bits(a, b)


class NumpyRules(GripLoadController):
    """The grip-load controller's per-tick rules in their numpy form: the reference."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        n = len(self.names)
        self.slipping = np.zeros(n, dtype=bool)
        self._prev_grip = np.zeros(n)
        self._pac_usual = np.full(n, np.inf)
        self._pac_ticks = np.zeros(n, dtype=np.int64)

    def _unwind(self, snap):
        fraction = self.s.limits.unwind_fraction
        if fraction >= 1.0:
            return
        f = np.asarray(snap.f_sensor, dtype=float)
        limit = fraction * self.hand.safety.max_fingertip_force_n
        over = self.grasp_mask & (np.einsum("ij,ij->i", f, f) > limit * limit)
        if over.any():
            q = np.asarray(snap.q, dtype=float)
            self.motion.hold_at(q, [self.kin.slices[self.names[i]] for i in np.flatnonzero(over)])

    def _vibrating(self, snap, touching):
        spread = snap.pac_spread
        if spread is None:
            return np.zeros(len(self.names), dtype=bool)
        spread = np.asarray(spread, dtype=float)
        usual = np.where(np.isfinite(self._pac_usual), self._pac_usual, spread)
        loud = touching & (spread > usual + self.s.coordination.slip_pac_counts)
        k = min(1.0, self.dt / max(self.s.coordination.slip_pac_window_s, self.dt))
        self._pac_usual = np.where(touching, np.where(loud, usual, usual + k * (spread - usual)), np.inf)
        self._pac_ticks = np.where(loud, self._pac_ticks + 1, 0)
        return self._pac_ticks >= self.s.coordination.slip_pac_ticks

    def _carried(self, snap):
        touching = np.asarray(snap.in_contact, dtype=bool) & self.grasp_mask
        return float(-np.sum(np.asarray(snap.f_world, dtype=float)[touching, 2]))

    def _limit_to_safety(self, snap):
        f = np.asarray(snap.f_sensor, dtype=float)[self.grasp_mask]
        peak = float(np.sqrt(np.max(np.sum(f * f, axis=1), initial=0.0)))
        if peak > self.grip_cap_n:
            self.scale = max(self.s.limits.min_grip_scale, self.scale * self.grip_cap_n / peak)
            self._targets = [b * self.scale for b in self._base]

    def _coordinate(self, snap):
        s, dt = self.s, self.dt
        c = s.coordination
        f = np.asarray(snap.f_sensor, dtype=float)
        f_t = np.hypot(f[:, 0], f[:, 1])
        grip = np.asarray(snap.grip_n, dtype=float)
        touching = np.asarray(snap.in_contact, dtype=bool) & self.grasp_mask
        self.carried_n = self._carried(snap)
        if self.state == "load":
            enough = self.carried_n >= s.load.load_weight_fraction * self.weight_n
            self.carried_ticks = self.carried_ticks + 1 if enough else 0
        mu = max(self.mu_hat, 1e-3)
        load = -np.asarray(snap.f_world, dtype=float)[:, 2]
        need = [
            c.grip_margin * max(float(load[i]), 0.0) / (mu * max(self._base[i], 1e-3)) for i in np.flatnonzero(touching)
        ]
        wanted = max(need, default=1.0)
        k = min(1.0, dt / max(c.slip_filter_s, dt))
        if self._prev_ft is None:
            self._prev_ft, self._prev_grip = f_t.copy(), grip.copy()
        ft_filtered = self._prev_ft + k * (f_t - self._prev_ft)
        grip_filtered = self._prev_grip + k * (grip - self._prev_grip)
        ft_rate = (ft_filtered - self._prev_ft) / dt
        grip_rate = (grip_filtered - self._prev_grip) / dt
        self._prev_ft, self._prev_grip = ft_filtered, grip_filtered
        vibrating = self._vibrating(snap, touching)
        slipping = touching & (
            (np.abs(load) > c.slip_cone_fraction * mu * np.maximum(grip, 0.0))
            | (grip_rate < -c.slip_grip_rate_n_s)
            | (np.abs(ft_rate) > c.slip_rate_n_s)
            | vibrating
        )
        if slipping.any() and not self.slipping.any():
            self.slip_events += 1
            self.scale += c.slip_boost
        total_grip = float(np.sum(np.where(touching, grip, 0.0)))
        if vibrating.any() and self.state in ("lift", "hold") and c.slip_adapts_mu:
            if total_grip > 0.1 and self._held_ratio > 0.0:
                self.mu_hat = max(c.min_mu_hat, min(self.mu_hat, self._held_ratio))
        self.slipping = slipping
        self._held_ratio = max(self.carried_n, 0.0) / total_grip if total_grip > 0.1 else 0.0
        caps = []
        for i in np.flatnonzero(self.grasp_mask):
            room = self.grip_cap_n**2 - float(f_t[i]) ** 2
            caps.append(math.sqrt(room) / max(self._base[i], 1e-3) if room > 0 else 1.0)
        cap = min(caps, default=1.0)
        wanted = max(wanted, self.ramp_scale)
        if wanted > self.scale:
            self.scale = wanted
        else:
            self.scale = max(wanted, self.scale - c.grip_relax_per_s * dt)
        self.scale = min(max(self.scale, s.limits.min_grip_scale), cap)
        self._targets = [b * self.scale for b in self._base]


def _snapshots(rng: np.random.Generator, hand, n: int, ticks: int, cap_n: float):
    """Force traces that wander about the friction cone, slip, spike past the safety cap and now
    and then carry a signed zero, an infinity or a NaN."""
    q = np.array([j.pregrasp_rad for j in hand.joints])
    grip = rng.uniform(0.5, 4.0, n)
    load = rng.uniform(-0.5, 2.0, n)
    for t in range(ticks):
        grip = np.maximum(grip + rng.normal(0.0, 0.3, n), -0.2)
        load = load + rng.normal(0.0, 0.2, n)
        f_sensor = np.column_stack([load, rng.normal(0.0, 0.5, n), grip])
        f_world = np.column_stack([grip, rng.normal(0.0, 0.3, n), -load])
        if rng.random() < 0.05:
            f_sensor[rng.integers(n)] *= cap_n  # past the caps
        for a in (f_sensor, f_world):
            if rng.random() < 0.04:
                a[rng.integers(n), rng.integers(3)] = rng.choice([0.0, -0.0, np.inf, -np.inf, np.nan])
        spread = rng.uniform(0.0, 6.0, n) * (1.0 + 20.0 * (rng.random(n) < 0.1))
        if rng.random() < 0.03:
            spread[rng.integers(n)] = np.nan
        contact = rng.random(n) < 0.9
        yield Snapshot(
            t * hand.dt,
            q + rng.normal(0.0, 0.01, q.size),
            np.zeros(3),
            True,
            contact,
            f_sensor,
            f_world,
            f_world,
            np.where(contact, grip, 0.0),
            pac_spread=None if rng.random() < 0.02 else spread,
        )


@pytest.mark.parametrize(
    ("name", "state", "seed"),
    [("mustard_bottle", "lift", 0), ("paper_cup", "load", 1), ("lego", "hold", 2), ("cleanser", "lower", 3)],
)
def test_grip_load_rules_on_lists_match_their_numpy_form(hand, objects, name, state, seed):
    obj, settings_ = objects[name], settings_for("grip_load")
    fast = make_controller(hand, obj, np.array([0.0, 0.0, 0.2]), settings_)
    slow = NumpyRules(hand, obj, np.array([0.0, 0.0, 0.2]), settings_)
    assert type(fast) is GripLoadController
    rng = np.random.default_rng(seed)
    for ctrl in (fast, slow):
        ctrl.machine.set_state(state)
        ctrl.motion.sync(np.array([j.pregrasp_rad for j in hand.joints]))
    with np.errstate(invalid="ignore", over="ignore"):
        for i, snap in enumerate(_snapshots(rng, hand, len(hand.fingers), 400, fast.grip_cap_n)):
            for ctrl in (fast, slow):
                ctrl.ramp_scale = 1.0 + 0.2 * math.sin(i / 30.0)
                ctrl._unwind(snap)
                ctrl._coordinate(snap)
                if i % 3 == 0:
                    ctrl._limit_to_safety(snap)
            assert same_bits(fast._carried(snap), slow._carried(snap))
            assert same_bits(
                [fast.scale, fast.mu_hat, fast.carried_n, fast._held_ratio],
                [slow.scale, slow.mu_hat, slow.carried_n, slow._held_ratio],
            )
            assert (fast.slip_events, fast.carried_ticks) == (slow.slip_events, slow.carried_ticks)
            assert list(fast.slipping) == slow.slipping.tolist()
            assert same_bits(fast._targets, slow._targets) and same_bits(fast.grip_targets, slow.grip_targets)
            assert same_bits(fast._prev_ft, slow._prev_ft) and same_bits(fast._prev_grip, slow._prev_grip)
            assert same_bits(fast._pac_usual, slow._pac_usual) and fast._pac_ticks == slow._pac_ticks.tolist()
            assert same_bits(fast.motion.q_goal, slow.motion.q_goal)
    assert fast.slip_events > 0


def test_the_mujoco_worlds_joint_views_read_what_its_indices_read(hand, objects):
    pytest.importorskip("mujoco")
    from grasp_ctrl.sim.mujoco.world import MuJoCoWorld, _selector

    assert _selector(np.array([3, 4, 5])) == slice(3, 6)
    gaps = np.array([3, 5, 6])
    assert _selector(gaps) is gaps
    world = MuJoCoWorld(hand, objects["chips_can"], 0)
    world.step()
    d = world.data
    assert same_bits(world.q_measured, d.qpos[world._qadr] - world.joint_offset_rad)
    assert same_bits(world.dq, d.qvel[world._vadr]) and same_bits(world.q, d.qpos[world._qadr])
    assert same_bits(world.joint_torque_nm, d.actuator_force[world._act])
    assert same_bits(world.palm_world, d.xpos[world._hand_body])
