"""Synthetic sources: the character of each source, with a placeholder forward model."""

from __future__ import annotations

import numpy as np

from grasp_ctrl.learning.features import surface_point_and_normal
from grasp_ctrl.learning.synthetic import generate, generate_source, mock_biotac_forward
from grasp_ctrl.tactile.geometry import ELECTRODE_POSITIONS_SENSOR


def linear_forward(p: np.ndarray, f: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Placeholder BioTac: electrodes near the contact drop with the normal load, pdc rises."""
    _, n_out = surface_point_and_normal(p)
    d = ELECTRODE_POSITIONS_SENSOR[None] - p[:, None]
    w = np.exp(-np.sum(d * d, axis=2) / (2 * 0.0045**2))
    raw = np.full((len(p), 44), 2000.0)
    raw[:, :19] -= 300.0 * w * np.maximum(-np.sum(f * n_out, axis=1), 0)[:, None]
    raw[:, 19] += 70.0 * np.linalg.norm(f, axis=1)
    return raw + rng.normal(0, 1.0, raw.shape)


def test_rigid_ft_is_large_and_mostly_normal() -> None:
    ds = generate_source("rigid-ft", 400, linear_forward, np.random.default_rng(0))
    mag = np.linalg.norm(ds.f_sensor, axis=1)
    assert len(ds) >= 400 and not ds.projected.any()
    assert np.percentile(mag, 90) > 4.0
    # the force points into the pad (+z) for most samples
    assert np.median(ds.f_sensor[:, 2] / mag) > 0.8
    assert len(np.unique(ds.trial_id)) >= 3


def test_ball_ft_covers_other_directions() -> None:
    ds = generate_source("ball-ft", 400, linear_forward, np.random.default_rng(1))
    mag = np.linalg.norm(ds.f_sensor, axis=1)
    assert np.percentile(np.abs(ds.f_sensor[:, 1]) / mag, 90) > 0.5  # sideways contacts


def test_planar_pushing_labels_are_small_planar_and_projected() -> None:
    ds = generate_source("planar-pushing", 300, linear_forward, np.random.default_rng(2))
    mag = np.linalg.norm(ds.f_sensor, axis=1)
    assert ds.projected.all()
    assert 0.05 < np.median(mag) < 2.0 and mag.max() < 3.0
    # the label is the pusher force rotated into the sensor frame: no world-vertical part
    f_world = np.einsum("nij,nj->ni", ds.r_world_sensor, ds.f_sensor)
    np.testing.assert_allclose(f_world[:, 2], 0.0, atol=1e-9)


def test_mock_world_forward_model_and_gate() -> None:
    ds = generate(150, seed=3, forward=mock_biotac_forward())
    assert set(ds.sources()) == {"rigid-ft", "ball-ft", "planar-pushing"}
    assert np.all(ds.tared[:, 19] > 10)  # only gated (in-contact) samples
    assert np.median(ds.tared[:, :19].min(axis=1)) < -50  # pressed electrodes drop
