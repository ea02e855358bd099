"""Taring, contact gating and the official network on real BioTac recordings.

Uses ../shared/data/robotic_finger/robotic_finger_tidy.csv (skipped when absent).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.config.sensor_layout import ELECTRODES, PDC
from grasp_ctrl.evaluation.robotic_finger import Trial, read_trials

CSV = Path(__file__).resolve().parents[3] / "shared" / "data" / "robotic_finger" / "robotic_finger_tidy.csv"


@pytest.fixture(scope="module")
def long_trials() -> list[Trial]:
    if not CSV.is_file():
        pytest.skip(f"{CSV} not available")
    trials = [t for t in read_trials(CSV) if t.in_paper]
    assert len(trials) == 2 and all(len(t) > 6000 for t in trials)
    return trials


def _first_onset(tared_pdc: np.ndarray, threshold: float, frames: int) -> int:
    run = 0
    for i, v in enumerate(tared_pdc):
        run = run + 1 if v > threshold else 0
        if run >= frames:
            return i
    return -1


def test_gate_fires_at_the_recorded_onset(long_trials: list[Trial]) -> None:
    from grasp_ctrl.evaluation.direction import gate_trial

    for trial in long_trials:
        s = gate_trial(trial, tare_frames=50, threshold=10.0, frames=10)
        tared = trial.raw - trial.raw[:50].mean(axis=0)
        onset = _first_onset(tared[:, PDC], 10.0, 10)
        assert s.onset == onset > 50
        # Before the onset: free space, the taring keeps pdc and electrodes near zero.
        assert np.abs(tared[: onset - 10, PDC]).max() <= 10.0
        assert np.abs(tared[: onset - 10, ELECTRODES]).max() < 30.0
        # Shortly after: pressed, pdc up and the pressed electrodes DOWN (negative when tared).
        after = tared[onset : onset + 100]
        assert after[:, PDC].max() > 30.0
        assert after[:, ELECTRODES].min() < -20.0


def test_official_network_expects_value_minus_baseline(long_trials: list[Trial]) -> None:
    """With the docs/design.md tare sign the magnitude tracks pdc and a pad press is +z;
    with the opposite sign the correlation turns negative."""
    from grasp_ctrl.estimators.registry import load_policy
    from grasp_ctrl.evaluation.direction import gate_trial

    est = load_policy("icra19_official", threads=1)
    for trial in long_trials:
        s = gate_trial(trial, min_pdc=50.0)
        sub = s.tared[::4]
        f = est.estimate(sub, ["index"] * len(sub)).f_sensor
        flipped = est.estimate(-sub, ["index"] * len(sub)).f_sensor
        pdc = sub[:, PDC]
        r_right = np.corrcoef(np.linalg.norm(f, axis=1), pdc)[0, 1]
        r_wrong = np.corrcoef(np.linalg.norm(flipped, axis=1), pdc)[0, 1]
        assert r_right > 0.3 > 0.0 > r_wrong
        assert f[:, 2].mean() > 0.3  # f_sensor: force ON the skin, pad faces -z


def test_pipeline_on_real_frames_zero_before_contact(long_trials: list[Trial]) -> None:
    from grasp_ctrl.estimators.pipeline import TactilePipeline
    from grasp_ctrl.estimators.registry import load_policy

    trial = long_trials[0]
    pipe = TactilePipeline(load_policy("icra19_official", threads=1), ["index"])
    pipe.set_baseline(trial.raw[:50, None, :])
    forces, contact = [], []
    for raw in trial.raw[:1400]:
        out = pipe.step(raw[None, :])
        forces.append(out.f_sensor[0])
        contact.append(out.in_contact[0])
    forces_a, contact_a = np.array(forces), np.array(contact)
    onset = int(np.argmax(contact_a))
    assert onset > 50
    assert np.all(forces_a[:onset] == 0.0)
    assert np.all(np.linalg.norm(forces_a[contact_a], axis=1) > 0.0)


def test_direction_agreement_after_one_rotation(long_trials: list[Trial]) -> None:
    from grasp_ctrl.estimators.registry import load_policy
    from grasp_ctrl.evaluation.direction import evaluate, gate_trial, policy_directions, surface_normal_directions

    samples = [gate_trial(t, min_pdc=30.0) for t in long_trials]
    net = evaluate("net", samples, policy_directions(load_policy("icra19_official", threads=1)))
    normal = evaluate("sn", samples, surface_normal_directions)
    assert len(net) == len(normal) == 2
    for r in net:
        assert r.percentiles[50] < 20.0 and r.percentiles[90] < 35.0
    for r in normal:
        assert r.percentiles[50] < 25.0
