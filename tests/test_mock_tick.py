"""The mock trial's fused tick (trials/episode/mock_tick.py) against the generic control_tick path:
whole trials give the same record and the same tick log, bit for bit, including ticks
where a shortcut does not apply (tare, a hardware fault, a paused sensor, a non-finite
angle, a non-finite command, no tick log)."""

from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq
import pytest

from grasp_ctrl.estimators.registry import DEFAULT_POLICY
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.loop.loop_kernels import track_peaks
from grasp_ctrl.numeric import jit
from grasp_ctrl.sim.backends import MockHand, MockSensors
from grasp_ctrl.trials.episode import mock_tick
from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial

pytestmark = pytest.mark.skipif(not jit.JIT, reason="the fused tick needs the compiled kernels (sim extra)")


def _trial(hand, obj, seed, path, fused: bool, monkeypatch, disturb=None):
    """One trial; ``disturb(tick, world, hand_backend, sensors, ctrl)`` runs after every tick."""
    used = {"fused": 0}
    real_usable = mock_tick.MockTick.usable
    real_tick = mock_tick.MockTick.tick

    def usable(*args):
        return fused and real_usable(*args)

    def counting_tick(self, ctrl):
        used["fused"] += 1
        return real_tick(self, ctrl)

    monkeypatch.setattr(mock_tick.MockTick, "usable", staticmethod(usable))
    monkeypatch.setattr(mock_tick.MockTick, "tick", counting_tick)
    parts = {}

    def backends(world, hand_cfg):
        parts["hand"], parts["sensors"] = MockHand(world, hand_cfg), MockSensors(world)
        return parts["hand"], parts["sensors"]

    ticks = [0]

    def on_tick(world, ctrl):
        ticks[0] += 1
        if disturb:
            disturb(ticks[0], world, parts["hand"], parts["sensors"], ctrl)

    rec = run_sim_trial(
        hand,
        obj,
        estimator_factory(DEFAULT_POLICY, hand),
        seed,
        DEFAULT_POLICY,
        log_path=path,
        kin=HandKinematics(hand),
        on_tick=on_tick,
        make_backends=backends,
        backend="mock",
    ).to_json()
    rec.pop("wall_duration_s")
    monkeypatch.undo()
    return rec, used["fused"]


def _same_trial(hand, obj, seed, tmp_path, monkeypatch, disturb=None, log=True):
    paths = [tmp_path / f"{k}_ticks.parquet" if log else None for k in ("fused", "generic")]
    fused, n_fused = _trial(hand, obj, seed, paths[0], True, monkeypatch, disturb)
    generic, n_generic = _trial(hand, obj, seed, paths[1], False, monkeypatch, disturb)
    assert n_generic == 0 and n_fused > 100
    assert json.dumps(fused) == json.dumps(generic)  # (NaN included)
    if log:
        assert pq.read_table(paths[0]).equals(pq.read_table(paths[1]))
    return fused


@pytest.mark.parametrize("name", ["chips_can", "paper_cup", "mustard_bottle"])
def test_fused_trials_equal_the_generic_ones(hand, objects, tmp_path, monkeypatch, name):
    rec = _same_trial(hand, objects[name], 11, tmp_path, monkeypatch)
    assert rec["final_state"] in ("done", "fault")


def test_fused_trial_without_a_tick_log(hand, objects, tmp_path, monkeypatch):
    _same_trial(hand, objects["lego"], 4, tmp_path, monkeypatch, log=False)


@pytest.mark.parametrize("fault", ["overload", "paused", "nan_angle", "nan_goal"])
def test_fused_trials_take_the_generic_way_where_a_shortcut_does_not_apply(hand, objects, tmp_path, monkeypatch, fault):
    def disturb(tick, world, hand_backend, sensors, ctrl):
        if tick == 300:
            if fault == "overload":
                hand_backend.fault = "overload"
            elif fault == "paused":
                sensors.paused.add(world.sensor_ids[1])
            elif fault == "nan_angle":
                world._q_servo[3] = np.nan  # the angle read next tick
            else:
                ctrl.motion.q_goal[2] = np.nan

    rec = _same_trial(hand, objects["chips_can"], 2, tmp_path, monkeypatch, disturb)
    assert rec["final_state"] == "fault"


def test_outputs_kernel_refuses_a_non_finite_command_and_writes_nothing():
    J, F = 3, 2
    goal, target = np.full(J, 7.0), np.full(3, 7.0)
    peaks = np.zeros((3, F))
    limits = np.array([[-1.0] * J, [1.0] * J, [-2.0] * J, [2.0] * J])
    args = (
        np.zeros(J),
        0.1,
        limits,
        0.0,
        1.0,
        goal,
        target,
        np.ones((F, 3)),
        np.ones(F),
        np.ones(F),
        peaks,
        np.empty((0, 0)),
        -1,
        0.0,
        np.zeros(3),
        1.0,
        np.zeros((F, 44)),
        np.ones(F, dtype=bool),
        np.zeros((F, 44)),
        np.zeros((F, 3)),
        np.zeros(J),
        np.zeros((F, 3)),
        np.zeros(6),
    )
    assert mock_tick.mock_outputs(np.array([0.0, np.nan, 0.0]), np.zeros(3), *args) == mock_tick.NOT_FINITE
    assert mock_tick.mock_outputs(np.zeros(J), np.array([0.0, np.inf, 0.0]), *args) == mock_tick.NOT_FINITE
    assert np.all(goal == 7.0) and np.all(target == 7.0) and np.all(peaks == 0.0)
    assert mock_tick.mock_outputs(np.array([0.5, 3.0, -0.05]), np.array([0.1, 0.2, 5.0]), *args) == mock_tick.WRITTEN
    assert np.array_equal(goal, [0.1, 0.1, -0.05]) and np.array_equal(target, [0.1, 0.2, 1.0])
    expected = np.zeros((3, F))
    track_peaks(np.ones((F, 3)), np.ones(F), np.ones(F), expected[0], expected[1], expected[2])
    assert np.array_equal(peaks, expected)
