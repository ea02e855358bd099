"""Contact point, voxel grids (authors' contract) and the paper's metrics."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from grasp_ctrl.learning.features import GRID_SHAPE, _cell_index, contact_point_and_normal, model_inputs, voxel_grids
from grasp_ctrl.learning.metrics import by_source, per_sample
from grasp_ctrl.tactile.geometry import ELECTRODE_POSITIONS_SENSOR, SURFACE_RADIUS_M


@settings(max_examples=50, deadline=None)
@given(arrays(np.float64, (7, 44), elements=st.floats(-2000, 2000)))
def test_contact_point_on_surface_with_unit_normal(tared: np.ndarray) -> None:
    p, n = contact_point_and_normal(tared)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-9)
    cap = p[:, 0] > 0
    r = np.where(cap, np.linalg.norm(p, axis=1), np.linalg.norm(p[:, 1:], axis=1))
    np.testing.assert_allclose(r, SURFACE_RADIUS_M, atol=1e-9)


def test_single_pressed_electrode_gives_its_region() -> None:
    tared = np.zeros((1, 44))
    tared[0, 17] = -800.0  # e18, on the pad (-z)
    p, n = contact_point_and_normal(tared)
    assert n[0, 2] < -0.99 and abs(p[0, 0] - ELECTRODE_POSITIONS_SENSOR[17, 0]) < 1e-9


def test_voxel_grids_match_a_slow_reference() -> None:
    rng = np.random.default_rng(0)
    tared = rng.normal(0, 300, (5, 44))
    s_c, _ = contact_point_and_normal(tared)
    e_vox, c_vox = voxel_grids(tared, s_c)
    edges = np.histogramdd(ELECTRODE_POSITIONS_SENSOR, bins=(15, 15, 7))[1]
    for i in range(5):
        ref = np.zeros(GRID_SHAPE)
        for k in range(19):
            idx = [np.digitize(ELECTRODE_POSITIONS_SENSOR[k, a], edges[a]) - 1 for a in range(3)]
            ref[tuple(idx)] = tared[i, k]
        np.testing.assert_allclose(e_vox[i], ref, rtol=1e-6)
        cref = np.zeros(GRID_SHAPE)
        cref[tuple(np.digitize(s_c[i, a], edges[a]) - 1 for a in range(3))] = 1.0  # -1 wraps like numpy
        np.testing.assert_array_equal(c_vox[i], cref)
    assert e_vox.shape == (5, 16, 16, 8)
    # below the lowest edge: index -1 wraps to the last cell
    low = ELECTRODE_POSITIONS_SENSOR.min(axis=0) - 1e-3
    np.testing.assert_array_equal(_cell_index(low[None])[0], [15, 15, 7])
    assert set(model_inputs(tared)) >= {"electrode_voxels", "contact_voxels", "electrodes", "pdc", "contact_point"}


def test_metrics_on_known_vectors() -> None:
    f_true = np.array([[0.0, 0.0, 2.0], [1.0, 0.0, 0.0], [0.0, 3.0, 0.0]])
    f_pred = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.0, 3.0, 0.0]])
    m = per_sample(f_true, f_pred)
    np.testing.assert_allclose(m["angle_deg"], [0.0, 90.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(m["direction_error_pct"], [0.0, 50.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(m["magnitude_error_pct"], [100 / 3, 0.0, 0.0])
    np.testing.assert_allclose(m["magnitude_error_n"], [1.0, 0.0, 0.0])
    s = by_source(f_true, f_pred, np.array(["a", "a", "b"]))
    assert s["mixed"]["magnitude_error_n"]["n"] == 3 and s["b"]["angle_deg"]["median"] < 1e-6
