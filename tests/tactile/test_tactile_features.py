"""Contact point on the sensor surface and outward unit normals (Lin et al. rule)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from grasp_ctrl.tactile.features import DEGENERATE_RADIUS_M, contact_points, surface_normals
from grasp_ctrl.tactile.geometry import ELECTRODE_NORMALS_SENSOR, ELECTRODE_POSITIONS_SENSOR, SURFACE_RADIUS_M

R = SURFACE_RADIUS_M
electrodes = arrays(
    np.float64, st.tuples(st.integers(1, 8), st.just(19)), elements=st.floats(-1500, 1500, allow_nan=False)
)


def _reference_point(e: np.ndarray) -> np.ndarray:
    """One row, written out step by step as the paper describes it."""
    w = e**2
    c = sum(w[i] * ELECTRODE_POSITIONS_SENSOR[i] for i in range(19)) / (w.sum() + 1e-8)
    if c[0] > 0:
        if np.linalg.norm(c) < DEGENERATE_RADIUS_M:
            return np.array([0.0, 0.0, -R])
        return c * R / np.linalg.norm(c)
    if np.hypot(c[1], c[2]) < DEGENERATE_RADIUS_M:
        return np.array([0.0, 0.0, -R])
    out = c.copy()
    out[1:] = c[1:] * R / np.hypot(c[1], c[2])
    return out


def _on_surface(p: np.ndarray) -> np.ndarray:
    r = np.where(p[:, 0] > 0, np.linalg.norm(p, axis=1), np.hypot(p[:, 1], p[:, 2]))
    return np.isclose(r, R, rtol=0, atol=1e-12)


@settings(max_examples=200)
@given(electrodes)
def test_contact_points_lie_on_the_sensor_surface(e: np.ndarray) -> None:
    p = contact_points(e)
    assert p.shape == (e.shape[0], 3)
    assert _on_surface(p).all()
    # x stays within the electrodes' x range, extended by the cap's radius.
    assert (p[:, 0] <= R + 1e-12).all()
    assert (p[:, 0] >= ELECTRODE_POSITIONS_SENSOR[:, 0].min() - 1e-12).all()


@settings(max_examples=200)
@given(electrodes)
def test_normals_are_unit_length_and_outward(e: np.ndarray) -> None:
    p = contact_points(e)
    n = surface_normals(p)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
    # Outward: moving along the normal leaves the surface model (radius grows).
    q = p + 1e-4 * n
    rq = np.where(q[:, 0] > 0, np.linalg.norm(q, axis=1), np.hypot(q[:, 1], q[:, 2]))
    assert (rq > R).all()


@settings(max_examples=100)
@given(electrodes)
def test_vectorised_points_match_row_by_row_reference(e: np.ndarray) -> None:
    got = contact_points(e)
    ref = np.array([_reference_point(row) for row in e])
    assert np.allclose(got, ref, rtol=0, atol=1e-12)


def test_accepts_full_44_channel_frames() -> None:
    frames = np.zeros((2, 44))
    frames[:, 16:19] = -200.0  # e17..e19: the pad electrodes
    p = contact_points(frames)
    assert np.allclose(p, contact_points(frames[:, :19]))
    # Pressing the pad electrodes puts the contact on the pad (-z) on the cylinder.
    assert (p[:, 2] < -0.9 * R).all() and (p[:, 0] < 0).all()
    assert np.allclose(surface_normals(p), [0, 0, -1], atol=1e-6)


def test_single_electrode_contact_points_towards_its_electrode() -> None:
    for i in range(19):
        e = np.zeros((1, 19))
        e[0, i] = -300.0
        p = contact_points(e)[0]
        pos = ELECTRODE_POSITIONS_SENSOR[i]
        if pos[0] > 0:
            assert np.allclose(p, pos * R / np.linalg.norm(pos))
        else:
            assert p[0] == pytest.approx(pos[0])
        # Its surface normal agrees roughly with the electrode's own normal.
        assert float(surface_normals(p[None])[0] @ ELECTRODE_NORMALS_SENSOR[i]) > 0.6


def test_no_signal_gives_the_pad_point() -> None:
    p = contact_points(np.zeros((3, 19)))
    assert np.allclose(p, [0.0, 0.0, -R])
    assert np.allclose(surface_normals(p), [0.0, 0.0, -1.0])
