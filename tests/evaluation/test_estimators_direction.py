"""Direction-evaluation maths and the analytic estimator on synthetic data."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from grasp_ctrl.estimators.analytic import AnalyticEstimator, electrode_normal_sums, fit_gains
from grasp_ctrl.evaluation.direction import angles_deg, fit_analytic_gains, fit_rotation, held_out_angles, unit


def test_fit_rotation_recovers_rotation_and_label_sign() -> None:
    rng = np.random.default_rng(0)
    dirs = unit(rng.normal(size=(500, 3)))
    true = Rotation.from_rotvec([0.3, -1.1, 0.5])
    for sign in (1.0, -1.0):
        labels = sign * true.apply(dirs)
        fit = fit_rotation(dirs, labels)
        assert fit.label_sign == sign
        assert np.allclose(fit.rotation.as_matrix(), true.as_matrix(), atol=1e-9)
        assert held_out_angles(fit, dirs, labels).max() < 1e-5


def test_angles_deg_basic() -> None:
    a = np.array([[1.0, 0, 0], [1.0, 0, 0], [0, 2.0, 0]])
    b = np.array([[2.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0]])
    assert np.allclose(angles_deg(a, b), [0.0, 90.0, 180.0])


def _tared_with_signal(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.zeros((n, 44))
    t[:, :19] = -rng.uniform(0, 300, (n, 19)) * (rng.random((n, 19)) < 0.4)
    return t


def test_analytic_gains_fit_recovers_known_gains() -> None:
    tared = _tared_with_signal(400, 1)
    gains = np.array([0.004, 0.006, 0.01])
    f = electrode_normal_sums(tared) * gains
    assert np.allclose(fit_gains(tared, f), gains)
    est = AnalyticEstimator(gains)
    assert np.allclose(est.estimate(tared, ["x"] * 400).f_sensor, f)


def test_analytic_relative_gains_and_rotation_fit_jointly() -> None:
    tared = _tared_with_signal(600, 2)
    gains = np.array([2.0, 0.5, 1.0])
    rot = Rotation.from_rotvec([0.2, 0.4, -0.3])
    labels = -rot.apply(unit(electrode_normal_sums(tared) * gains))
    fit = fit_analytic_gains(tared, labels)
    assert fit.label_sign == -1.0
    assert np.allclose(fit.gains, gains, rtol=0.02)
    assert np.median(held_out_angles(fit, electrode_normal_sums(tared) * fit.gains, labels)) < 0.5
