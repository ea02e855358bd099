"""The simulated BioTac against real data (docs/mock_world.md, "Anchors").

Measured with the same code as ``python launch.py biotac-anchors``: the authors'
real-data network reading simulated rigid-ft + ball-ft presses (20,000 force
samples per source, about 200 presses, seed 7: with 1,500 samples, a few dozen presses, the
pooled median angle moved from 18.9 to 30.8 deg over seeds 1-10) and simulated in-contact electrode patterns against
the real long recordings A and B of robotic_finger_tidy.csv. Skipped without
../shared/data.

Each figure is asserted twice where the model does not reach its target yet:
a regression bound at the level measured on 2026-11-23 (a change that makes the
model less real fails), and the target itself as a strict xfail (a change that
reaches it fails too, so that the bound is raised and the xfail removed).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

REAL_CSV = SHARED_DATA / "robotic_finger" / "robotic_finger_tidy.csv"
RISE_FIT = Path(__file__).resolve().parents[2] / "docs" / "biotac_params_rise_fit.json"
from grasp_ctrl.evaluation.biotac_anchors import (
    LOCATION_SCAN_X_M,
    PAD_SCAN_FORCES_N,
    PAD_SCAN_X_M,
    anchor_report,
    pad_press_ratios,
    real_anchors,
)
from grasp_ctrl.evaluation.tilt_profile import TILT_BINS_DEG


@pytest.fixture(scope="module")
def real():
    """The real-data side (trials A and B read by the network), the same for both reports below:
    computed once (about 8 s)."""
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is not present beside the checkout")
    return real_anchors(REAL_CSV)


@pytest.fixture(scope="module")
def report(real):
    return anchor_report(REAL_CSV, n_per_source=20000, seed=7, real=real)


def test_real_reference_figures(report):
    """The real-to-real figures the simulated ones are compared with (B against A)."""
    real = report.real_b
    assert real.variance_in_real_a_top5 == pytest.approx(0.81, abs=0.02)
    assert real.best_match_residual_median == pytest.approx(0.18, abs=0.03)
    assert 9 <= real.rising_electrodes_median <= 11
    assert 0.8 <= real.largest_drop_over_pdc_median <= 0.9
    assert 0.4 <= real.drop_vs_pdc_loglog_slope <= 0.6
    assert real.rest_noise_sd == pytest.approx(0.45, abs=0.05)


def test_official_net_reads_rigid_ft_presses_at_its_real_data_level(report):
    rigid = report.per_source["rigid-ft"]
    assert rigid.median_angle_deg <= 20.0
    assert 0.5 <= rigid.magnitude_ratio_median <= 2.0
    assert rigid.magnitude_corr >= 0.4


def test_official_net_magnitudes_track_the_true_force(report):
    assert report.pooled.magnitude_corr >= 0.4
    for source, fig in report.per_source.items():
        assert 0.5 <= fig.magnitude_ratio_median <= 2.0, source


def test_official_net_reads_the_pooled_presses_near_its_real_data_level(report):
    # regression bounds (measured 2026-11-23: pooled 21.0 deg, ball-ft 32.2 deg;
    # seeds 1-5: pooled 22.1-24.1 deg)
    assert report.pooled.median_angle_deg <= 23.0
    assert report.per_source["ball-ft"].median_angle_deg <= 35.0


@pytest.mark.xfail(
    strict=True, reason="target not reached: pooled 21.0 deg at 200 presses per source (decision record 0003)"
)
def test_official_net_reads_the_pooled_presses_at_its_real_data_level(report):
    """Anchor (a): <= 20 deg median over rigid-ft + ball-ft (the net reads a real
    BioTac of another lab at about 16 deg)."""
    assert report.pooled.median_angle_deg <= 20.0


def test_official_net_reads_real_plate_presses_alike_at_every_tilt(report):
    """The real level by tilt of the force from the pad normal (measured 2026-11-24:
    20.9 / 18.4 / 20.4 / 18.1 / 26.1 deg at 0-15 / 15-30 / 30-45 / 45-60 / 60-90 deg);
    a hand-held plate never pushes beyond 90 deg."""
    real = report.tilt_real
    for (lo, hi), n, err in zip(TILT_BINS_DEG, real.samples, real.median_error_deg):
        if hi <= 90.0:
            assert n >= 1000, (lo, hi)
            assert 15.0 <= err <= 30.0, (lo, hi)
        else:
            assert n == 0


def test_simulated_error_by_tilt(report):
    """Regression bounds (2026-11-24: 12.6 / 19.2 / 26.1 / 31.3 / 42.1 / 66.7 deg): pad-like
    forces are read as on the real sensor, the error grows with tilt."""
    sim = dict(zip(TILT_BINS_DEG, report.tilt_simulated.median_error_deg))
    real = dict(zip(TILT_BINS_DEG, report.tilt_real.median_error_deg))
    assert sim[(0.0, 15.0)] <= real[(0.0, 15.0)]
    assert sim[(15.0, 30.0)] <= real[(15.0, 30.0)] + 3.0
    assert sim[(45.0, 60.0)] <= 34.0
    assert sim[(60.0, 90.0)] <= 45.0


@pytest.mark.xfail(
    strict=True,
    reason="target not reached: the simulated error grows with tilt (31 / 42 deg at 45-60 / "
    "60-90 deg), the real stays 18-26 deg",
)
def test_simulated_error_by_tilt_target(report):
    """Where the real recordings cover the tilt (0-90 deg), within 5 deg of the real level in every bin."""
    for (lo, hi), sim, real in zip(
        TILT_BINS_DEG, report.tilt_simulated.median_error_deg, report.tilt_real.median_error_deg
    ):
        if hi <= 90.0:
            assert sim <= real + 5.0, (lo, hi)


def test_simulated_patterns_look_real(report):
    sim = report.simulated
    assert sim.rising_electrodes_median >= 3
    assert 0.5 <= sim.largest_drop_over_pdc_median <= 1.5
    assert sim.rest_noise_sd == pytest.approx(report.real_b.rest_noise_sd, abs=0.12)
    assert 0.3 <= sim.drop_vs_pdc_loglog_slope <= 0.7
    assert sim.max_rise_median == pytest.approx(report.real_b.max_rise_median, rel=0.3)
    # regression bounds (measured 2026-11-23: 0.491 and 0.377)
    assert sim.variance_in_real_a_top5 >= 0.46
    assert sim.best_match_residual_median <= 0.40


@pytest.mark.xfail(strict=True, reason="target not reached: PCA share 0.49, best match 0.38 (decision record 0003)")
def test_simulated_patterns_target(report):
    sim = report.simulated
    assert sim.variance_in_real_a_top5 >= 0.69
    assert sim.best_match_residual_median <= 0.35


def test_variance_share_is_a_matter_of_where_the_skin_is_pressed(report):
    """Real A presses at the front of the sensor (drop centroid quartiles 0.1 / 1.4 / 2.9 mm). Simulated
    presses there lie inside real A's top-5 components as much as real B does (0.81); presses on the
    back of the pad, which the training sources add and real A never makes, do not. So the pooled
    anchor share (0.455) measures the sources' press locations as much as the patterns."""
    scan = report.location_share
    share = dict(zip(LOCATION_SCAN_X_M, scan.share))
    assert 0.0 <= scan.real_centroid_x_m[1] <= 0.003
    # measured 2026-11-23: 0.81 at x = 0, 0.92 at +3 mm, 0.91 at +6 mm; 0.22 / 0.18 at -12 / -8 mm
    assert min(share[0.0], share[0.003], share[0.006]) >= 0.69
    assert max(share[-0.012], share[-0.008]) < 0.5


def test_official_net_barely_follows_pressure_on_a_real_sensor_it_was_not_trained_on(report):
    """Anchor (d), real side: on the robotic_finger BioTac the authors' network reads plate presses
    at 0.6-0.8 N median whether tared pdc is 50-100 or 400-500 (measured 2026-11-23: rise 1.09 on
    A, 1.16 on B), although pdc rises with the load on every BioTac. So a faithful simulated sensor
    need not be read at the right magnitude spot by spot (anchor (c) below)."""
    for name in ("real A", "real B"):
        resp = report.pressure[name]
        assert resp.frames > 3000, name
        assert all(0.55 <= m <= 0.85 for m in resp.median_n_by_bin), name
        assert 1.0 <= resp.rise <= 1.3, name
        assert 0.3 <= resp.rank_corr <= 0.8, name


def test_official_net_follows_pressure_on_simulated_pad_presses(report):
    """Anchor (d), simulated side: over the same pdc range the network reads simulated rigid-ft
    presses a little higher and rising more (measured 2026-11-23: 1.01 N at pdc 50-100, 1.74 N at
    400-500, true 0.30 and 1.65 N): the simulated sensor is no harder for it to read than a real
    one from another lab."""
    resp = report.pressure["simulated rigid-ft"]
    assert np.all(np.isfinite(resp.median_n_by_bin))
    assert resp.rise >= report.pressure["real A"].rise
    assert 0.5 <= resp.median_n_by_bin[0] <= 1.5


@pytest.fixture(scope="module")
def pad_scan():
    return pad_press_ratios()


def test_official_net_on_steady_pad_presses(pad_scan):
    # The closed loop's read: a grasp presses one spot of the pad at about 2 N. Measured on
    # 2026-11-23: median ratio 1.70, 50 % of (location, force) pairs within 0.5 to 2, the pad
    # point itself (x = -3 mm) read 3.3x at 0.5 N and 1.4x at 2 N.
    assert pad_scan.shape == (len(PAD_SCAN_X_M), len(PAD_SCAN_FORCES_N))
    assert np.all(np.isfinite(pad_scan)) and np.all(pad_scan > 0.0)
    assert np.median(pad_scan) <= 2.0
    assert np.mean((pad_scan >= 0.5) & (pad_scan <= 2.0)) >= 0.45
    # Not a target: on a real sensor it was not trained on the network's magnitude barely follows
    # the load (anchor (d) above), so a spot-by-spot 0.5-2 band is not what real data supports.


@pytest.fixture(scope="module")
def rise_fit_report(real):
    """The fitted per-electrode rise weights (docs/mock_world.md, anchor (b); decision record 0003);
    not the default model: adopting it means retraining every policy."""
    from grasp_ctrl.sim.biotac.params_file import load_biotac_params

    return anchor_report(REAL_CSV, n_per_source=20000, seed=7, params=load_biotac_params(RISE_FIT), real=real)


def test_fitted_rise_weights_reach_the_match_residual_target_and_keep_the_network_reading(rise_fit_report):
    # measured 2026-11-23: residual 0.310, share 0.478; network 14.9 / 36.0 / pooled 21.8 deg,
    # ratio 0.99 / 0.54, corr 0.57; largest rise at pdc 300-400 184 counts (real 130)
    sim = rise_fit_report.simulated
    assert sim.best_match_residual_median <= 0.35
    assert sim.variance_in_real_a_top5 >= 0.46
    assert 0.5 <= sim.largest_drop_over_pdc_median <= 1.5
    assert 0.3 <= sim.drop_vs_pdc_loglog_slope <= 0.7
    assert sim.rising_electrodes_median >= 3
    assert rise_fit_report.per_source["rigid-ft"].median_angle_deg <= 20.0
    assert rise_fit_report.pooled.median_angle_deg <= 23.0
    assert rise_fit_report.pooled.magnitude_corr >= 0.4
    for source, fig in rise_fit_report.per_source.items():
        assert 0.5 <= fig.magnitude_ratio_median <= 2.0, source
