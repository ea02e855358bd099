"""fit-mock-policies: the shipped linear fit reads pad-centre presses; the mixed fit
(``--linear-presses mixed``) also reads presses where grasp contacts land elsewhere on the skin."""

from __future__ import annotations

import json

import numpy as np
import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.estimators.linear import LinearEstimator
from grasp_ctrl.kinematics.fingertip import PAD_X_MIN_M, SKIN_RADIUS_M
from grasp_ctrl.sim.biotac.presses import random_skin_points, skin_presses


def test_skin_press_points_lie_on_the_skin_and_press_within_the_friction_cone():
    points, normals = random_skin_points(500, np.random.default_rng(0))
    cap = points[:, 0] > 0
    assert np.allclose(np.linalg.norm(points[cap], axis=1), SKIN_RADIUS_M)
    assert np.allclose(np.hypot(points[~cap, 1], points[~cap, 2]), SKIN_RADIUS_M)
    assert points[:, 0].min() >= PAD_X_MIN_M and np.all(normals[:, 2] < 0)  # the lower (pad) half
    _, f = skin_presses(200, 1)
    assert f.shape == (200, 3) and np.all(np.isfinite(f))


def _magnitude_ratio(policy: dict, tared: np.ndarray, f: np.ndarray) -> float:
    est = LinearEstimator(np.array(policy["weights_n_per_count"]), np.array(policy["bias_n"]))
    return float(np.median(np.linalg.norm(est.estimate(tared, []).f_sensor, axis=1) / np.linalg.norm(f, axis=1)))


@pytest.mark.parametrize("presses", ["pad", "mixed"])
def test_the_linear_fit_reads_skin_presses_only_when_trained_on_them(tmp_path, presses):
    assert (
        main(["fit-mock-policies", "--samples", "2000", "--linear-presses", presses, "--out-dir", str(tmp_path)]) == 0
    )
    policy = json.loads((tmp_path / "linear_mock.json").read_text())
    tared, f = skin_presses(800, 7)
    ratio = _magnitude_ratio(policy, tared, f)
    if presses == "pad":
        assert ratio > 1.5  # off the pad centre, a pad-centre fit reads 2-3 times the force
    else:
        assert 0.8 < ratio < 1.25
        assert "metrics_skin_presses" in policy


def test_the_mlp_fit_reads_skin_presses_and_is_repeatable(tmp_path):
    pytest.importorskip("torch")
    runs = []
    for k in range(2):
        out = tmp_path / str(k)
        out.mkdir()
        assert main(["fit-mock-policies", "--samples", "1000", "--out-dir", str(out)]) == 0
        runs.append((out / "mlp_mock.json").read_text())
    assert runs[0] == runs[1]  # same seed, same weights
    policy = json.loads(runs[0])
    assert policy["kind"] == "mlp" and policy["metrics"]["median_angle_deg"] < 12.0  # 1000 presses: a small fit
