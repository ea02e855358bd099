"""Binning of direction errors by the force's tilt from the pad normal (evaluation/tilt_profile.py)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.evaluation.tilt_profile import (
    MIN_BIN_SAMPLES,
    TILT_BINS_DEG,
    format_tilt_profiles,
    profile,
    simulated_tilt_profile,
    tilt_deg,
)


def test_tilt_of_axis_directions():
    d = np.array([[0, 0, 1], [1, 0, 0], [0, -1, 0], [0, 0, -1], [0, 1, 1]], dtype=float)
    assert np.allclose(tilt_deg(d), [0, 90, 90, 180, 45])
    assert profile(np.zeros(1), np.array([180.0])).samples[-1] == 1


def test_profile_takes_the_median_per_bin_and_leaves_thin_bins_empty():
    tilts = np.concatenate([np.full(30, 5.0), np.full(25, 50.0), np.full(MIN_BIN_SAMPLES - 1, 100.0)])
    errors = np.concatenate([np.arange(30.0), np.full(25, 40.0), np.full(MIN_BIN_SAMPLES - 1, 1.0)])
    prof = profile(errors, tilts)
    assert prof.samples == (30, 0, 0, 25, 0, MIN_BIN_SAMPLES - 1)
    assert prof.median_error_deg[0] == 14.5
    assert prof.median_error_deg[3] == 40.0
    assert all(math.isnan(prof.median_error_deg[k]) for k in (1, 2, 4, 5))


def test_simulated_profile_is_zero_for_exact_estimates():
    rng = np.random.default_rng(0)
    f = rng.standard_normal((500, 3))
    prof = simulated_tilt_profile(2.0 * f, f)  # same direction, other magnitude
    for n, err in zip(prof.samples, prof.median_error_deg):
        assert n < MIN_BIN_SAMPLES or err < 1e-4


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)), min_size=1, max_size=50))
def test_every_nonzero_direction_falls_in_one_bin(vectors):
    f = np.array(vectors, dtype=float)
    f = f[np.linalg.norm(f, axis=1) > 1e-6]
    prof = profile(np.zeros(len(f)), tilt_deg(f))
    assert sum(prof.samples) == len(f)


def test_format_lists_every_bin():
    prof = profile(np.zeros(0), np.zeros(0))
    text = format_tilt_profiles(prof, prof)
    for lo, hi in TILT_BINS_DEG:
        assert f"{lo:.0f}-{hi:.0f}" in text
