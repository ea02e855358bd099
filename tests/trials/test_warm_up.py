"""Kernels loaded before a wall-clock trial: a kernel's first load (tens of milliseconds) inside the
first trial's loop stalled the Allegro's realtime dry run by up to 60 ms (a stale-sensor fault
once). The run's own hand, controller and policy warm them (trials/episode/warm_up.py), and a
hand's read-only joint state reaches the kernels as the same array type as every backend's."""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config import load_hand
from grasp_ctrl.controller.registry import default_settings
from grasp_ctrl.estimators.registry import DEFAULT_POLICY
from grasp_ctrl.files.paths import REPO_ROOT
from grasp_ctrl.hardware.base import JointState
from grasp_ctrl.trials.episode import runner, warm_up
from grasp_ctrl.trials.episode.runner import estimator_factory


def test_a_wall_clock_run_warms_the_kernels_with_its_own_hand_controller_and_policy(hand, monkeypatch):
    calls = []
    monkeypatch.setattr(runner, "warm_kernels_once", lambda *args: calls.append(args) or True)
    runner.sim_trial_fn(hand, [DEFAULT_POLICY], None, backend="mock")
    assert calls == []  # simulated time: nothing stalls
    runner.sim_trial_fn(hand, [DEFAULT_POLICY], None, backend="mock", realtime=True)
    (args,) = calls
    assert args == (hand, default_settings(), DEFAULT_POLICY)


def test_the_warm_up_trial_reaches_the_lift_with_the_runs_policy():
    """With a policy that sees the contacts the warm-up's mock trial goes through the close and the
    ramp into the lift, where the policy's and the squeeze's kernels run."""
    allegro = load_hand(REPO_ROOT / "hand_configs" / "allegro_hand.toml")
    reached = []
    real_build = warm_up.__dict__.get("build_trial")
    assert real_build is None  # imported inside warm_kernels: patch where it is looked up
    from grasp_ctrl.rigs import trial_builder

    original = trial_builder.build_trial

    def spy(*args, **kwargs):
        trial = original(*args, **kwargs)
        reached.append(trial)
        return trial

    trial_builder.build_trial = spy
    try:
        warm_up.warm_kernels(allegro, default_settings(), estimator_factory(DEFAULT_POLICY, allegro, 1))
    finally:
        trial_builder.build_trial = original
    assert reached[0].ctrl.state in ("lift", "hold"), reached[0].ctrl.state


def test_a_read_only_joint_state_reaches_the_kernels_writable(hand, objects):
    from grasp_ctrl.rigs.registry import TEST_WORLD
    from grasp_ctrl.rigs.trial_builder import build_trial

    trial = build_trial(hand, objects["lego"], 0, estimator_factory(DEFAULT_POLICY, hand, 1), backend=TEST_WORLD)
    for _ in range(hand.tactile.tare_frames + 2):  # past the tare: the compiled snapshot
        trial.step()
    joints = trial.hand_backend.read()
    q = np.array(joints.q)
    q.flags.writeable = False
    read_only = JointState(q=q, dq=joints.dq, current_a=joints.current_a, t=joints.t)
    snap = trial.pipeline.snapshot(trial.pipeline.raw, read_only, trial.world.palm_world, False, None, None)
    assert snap.q.flags.writeable and np.array_equal(snap.q, q)
