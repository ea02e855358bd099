"""Physical properties of the simulated BioTac (grasp_ctrl/sim/biotac/model.py)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from grasp_ctrl.config.sensor_layout import ELECTRODES, PDC, TDC
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR
from grasp_ctrl.learning.features import surface_point_and_normal
from grasp_ctrl.sim.biotac.model import (
    DEFAULT_PARAMS,
    GAIN_PDC,
    BioTacSensorModel,
    pack_params,
    pdc_rise_of,
    static_frames,
)

C = pack_params(DEFAULT_PARAMS)
UNIT_GAIN = np.ones((1, 20))


def _pattern(p: np.ndarray, f: np.ndarray) -> np.ndarray:
    point, normal = surface_point_and_normal(np.asarray(p, float)[None])
    return static_frames(point, normal, np.asarray(f, float)[None], UNIT_GAIN, C)[0]


def _on_surface(x: float, angle: float) -> np.ndarray:
    r = 5.5e-3
    return np.array([x, r * np.sin(angle), -r * np.cos(angle)])


def test_shear_is_not_a_moved_contact():
    """With the contact held at the pad point, 1 N of tangential force on top of a 2 N
    press changes the electrodes in a way that no contact shift (anywhere on the skin,
    any normal force) reproduces: the least-squares residual stays above 40 % of the
    change."""
    press = np.array([0.0, 0.0, 2.0])
    base = _pattern(PAD_POINT_SENSOR, press)[:19]
    for tangential in ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]):
        sheared = _pattern(PAD_POINT_SENSOR, press + np.array(tangential))[:19]
        change = np.linalg.norm(sheared - base)
        assert change > 20.0  # counts: the sensor sees shear at all

        def misfit(u: np.ndarray) -> np.ndarray:
            p = _on_surface(u[0], u[1])
            _, n = surface_point_and_normal(p[None])
            return _pattern(p, -u[2] * n[0])[:19] - sheared

        best = min(
            (
                least_squares(misfit, [x0, a0, 2.0], bounds=([-0.014, -1.6, 0.0], [0.0055, 1.6, 20.0]))
                for x0 in (-0.006, -0.003, 0.0)
                for a0 in (-0.4, 0.0, 0.4)
            ),
            key=lambda r: r.cost,
        )
        residual = np.linalg.norm(best.fun) / change
        assert residual > 0.4, f"shear {tangential}: a moved contact explains it (residual {residual:.2f})"


def test_shear_moves_fluid_toward_the_side_the_force_points_to():
    """The dragged skin carries fluid along: electrodes on the side the tangential force
    points to rise, those behind drop (the sign the authors' real-data network reads as
    that force, docs/mock_world.md), across the whole finger."""
    press = np.array([0.0, 0.0, 2.0])
    base = _pattern(PAD_POINT_SENSOR, press)[:19]
    toward_plus_y = _pattern(PAD_POINT_SENSOR, press + [0.0, 1.5, 0.0])[:19] - base
    plus_side = [10, 11, 12, 13, 14, 15]  # e11..e16: normals along +y
    minus_side = [0, 1, 2, 3, 4, 5]  # e1..e6
    assert toward_plus_y[minus_side].mean() < 0 < toward_plus_y[plus_side].mean()
    toward_tip = _pattern(PAD_POINT_SENSOR, press + [1.5, 0.0, 0.0])[:19] - base
    assert toward_tip[[6, 7, 8, 9]].mean() > 0 > toward_tip[[5, 15, 18]].mean()  # tip e7..e10 vs back
    # the change reaches electrodes far from the footprint (a global term)
    assert abs(toward_plus_y[15]) > 3.0 and abs(toward_plus_y[5]) > 3.0


def test_pdc_is_nonlinear_and_saturates():
    rises = np.array([pdc_rise_of(f, C) for f in (0.5, 1.0, 2.0, 4.0, 8.0, 20.0, 200.0)])
    assert np.all(np.diff(rises) > 0)
    assert rises[5] < 0.7 * 20 * rises[1]  # 20 N gives far less than 20x the 1 N rise
    assert rises[-1] <= DEFAULT_PARAMS.pdc_max_rise + 1e-9


def test_footprint_widens_and_drops_saturate():
    light = _pattern(PAD_POINT_SENSOR, [0, 0, 0.5])[:19]
    heavy = _pattern(PAD_POINT_SENSOR, [0, 0, 8.0])[:19]
    crushing = _pattern(PAD_POINT_SENSOR, [0, 0, 500.0])[:19]
    assert (heavy < -20).sum() >= (light < -20).sum()
    assert -crushing.min() <= DEFAULT_PARAMS.e_drop_max + 1e-9


def test_electrodes_away_from_the_contact_rise():
    e = _pattern(PAD_POINT_SENSOR, [0, 0, 3.0])[:19]
    assert (e > 20).sum() >= 3
    assert e[16] < 0  # e17 sits under the pad point


def test_sensitivity_depends_on_where_the_skin_is_touched():
    p_tip = np.array([4.0e-3, 0.0, -3.78e-3])
    tip = _pattern(p_tip, -3.0 * surface_point_and_normal(p_tip[None])[1][0])[:19]
    pad = _pattern(PAD_POINT_SENSOR, [0, 0, 3.0])[:19]
    assert not np.isclose(tip.min(), pad.min(), rtol=0.05)


def _press_and_release(model: BioTacSensorModel, force_n: float, hold_frames: int, rest_frames: int) -> np.ndarray:
    p = PAD_POINT_SENSOR[None]
    n = PAD_NORMAL_SENSOR[None]
    f = np.array([[0.0, 0.0, force_n]])
    out = []
    for k in range(hold_frames + rest_frames):
        touching = np.array([k < hold_frames])
        out.append(model.frames(p, f if touching[0] else np.zeros((1, 3)), n, touching, np.zeros(1), 0.01)[0])
    return np.array(out, dtype=float)


def test_hysteresis_leaves_a_pdc_offset_after_release_that_decays():
    params = DEFAULT_PARAMS
    model = BioTacSensorModel(1, np.random.default_rng(0), params)
    frames = _press_and_release(model, 6.0, 300, 3000)
    pdc = (
        frames[:, PDC]
        - model.baseline[0, PDC]
        - params.pdc_per_tdc * params.tdc_drift_per_s * 0.01 * np.arange(1, len(frames) + 1)
    )
    just_after = pdc[310:330].mean()
    much_later = pdc[-50:].mean()
    assert just_after > 5.0  # counts above the baseline after release
    assert much_later < 0.6 * just_after  # and it decays


def test_tdc_drift_drags_the_baselines():
    model = BioTacSensorModel(1, np.random.default_rng(1))
    zeros = np.zeros((1, 3))
    frames = np.array(
        [model.frames(zeros, zeros, zeros, np.zeros(1, bool), np.zeros(1), 0.01)[0] for _ in range(6000)], dtype=float
    )
    start, end = frames[:200].mean(axis=0), frames[-200:].mean(axis=0)
    assert end[TDC] - start[TDC] > 5.0
    assert abs(end[PDC] - start[PDC]) > 0.1


def test_sensors_differ_in_gain_and_offsets():
    model = BioTacSensorModel(8, np.random.default_rng(2))
    assert model.gain.shape == (8, 20)
    assert np.std(model.gain[:, GAIN_PDC]) > 0.01
    assert np.std(model.baseline[:, ELECTRODES].mean(axis=1)) > 10


def test_rest_noise_is_that_of_a_real_sensor():
    from grasp_ctrl.evaluation.biotac_anchors import rest_noise_sd

    assert rest_noise_sd() == pytest.approx(0.45, abs=0.12)
