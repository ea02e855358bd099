"""Vectorised voxel grids against a slow loop-based reference of the authors' contract."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from grasp_ctrl.tactile.features import contact_points
from grasp_ctrl.tactile.geometry import ELECTRODE_POSITIONS_SENSOR, SURFACE_RADIUS_M
from grasp_ctrl.tactile.voxel import GRID_SHAPE, VoxelGrid


def _slow_edges() -> list[np.ndarray]:
    _, edges = np.histogramdd(ELECTRODE_POSITIONS_SENSOR, bins=(15, 15, 7))
    return edges


def _slow_index(value: float, edges: np.ndarray, size: int, variant: str) -> int:
    i = int(np.digitize(value, edges)) - 1
    if variant == "icra19":
        return i if i >= 0 else size + i  # what numpy's negative indexing did
    return min(max(i, 0), size - 1)


def slow_electrode_grid(e: np.ndarray, variant: str) -> np.ndarray:
    edges = _slow_edges()
    grid = np.zeros(GRID_SHAPE)
    for i in range(19):
        cell = tuple(_slow_index(ELECTRODE_POSITIONS_SENSOR[i, k], edges[k], GRID_SHAPE[k], variant) for k in range(3))
        grid[cell] = e[i]
    return grid


def slow_contact_grid(p: np.ndarray, variant: str) -> np.ndarray:
    edges = _slow_edges()
    grid = np.zeros(GRID_SHAPE)
    cell = tuple(_slow_index(p[k], edges[k], GRID_SHAPE[k], variant) for k in range(3))
    grid[cell] = 1.0
    return grid


electrode_batches = arrays(
    np.float64, st.tuples(st.integers(1, 6), st.just(19)), elements=st.floats(-2000, 2000, allow_nan=False)
)
points = arrays(np.float64, st.tuples(st.integers(1, 6), st.just(3)), elements=st.floats(-0.03, 0.03, allow_nan=False))


@pytest.mark.parametrize("variant", ["icra19", "clamped"])
@settings(max_examples=50)
@given(e=electrode_batches)
def test_electrode_grids_match_slow_reference(variant: str, e: np.ndarray) -> None:
    got = VoxelGrid(variant).electrode_grids(e, dtype=np.float64)
    assert got.shape == (e.shape[0], *GRID_SHAPE)
    for row, g in zip(e, got):
        assert np.array_equal(g, slow_electrode_grid(row, variant))


@pytest.mark.parametrize("variant", ["icra19", "clamped"])
@settings(max_examples=80)
@given(p=points)
def test_contact_grids_match_slow_reference(variant: str, p: np.ndarray) -> None:
    got = VoxelGrid(variant).contact_grids(p, dtype=np.float64)
    for row, g in zip(p, got):
        assert np.array_equal(g, slow_contact_grid(row, variant))
        assert g.sum() == 1.0


@settings(max_examples=50)
@given(e=electrode_batches)
def test_contact_grids_from_real_contact_points_match(e: np.ndarray) -> None:
    p = contact_points(e)
    got = VoxelGrid("icra19").contact_grids(p)
    for row, g in zip(p, got):
        assert np.array_equal(g, slow_contact_grid(row, "icra19").astype(np.float32))


def test_every_electrode_has_its_own_cell_with_max_edge_at_index_15() -> None:
    vg = VoxelGrid()
    cells = {tuple(c) for c in vg.electrode_cells}
    assert len(cells) == 19
    assert vg.electrode_cells[:, 0].max() == 15  # e7 at the largest x sits on the max edge
    assert vg.electrode_cells[:, 2].max() == 7


def test_pad_press_wraps_to_the_last_z_cell_in_icra19_and_clamps_in_clean_variant() -> None:
    pad = np.array([[-0.004, 0.0, -SURFACE_RADIUS_M]])  # below the lowest electrode (z = -5.08 mm)
    wrap = VoxelGrid("icra19").cell_indices(pad)[0]
    clamp = VoxelGrid("clamped").cell_indices(pad)[0]
    assert wrap[2] == GRID_SHAPE[2] - 1
    assert clamp[2] == 0
    assert wrap[0] == clamp[0] and wrap[1] == clamp[1]


def test_unknown_variant_and_bad_shapes_are_rejected() -> None:
    with pytest.raises(ValueError, match="variant"):
        VoxelGrid("fancy")
    with pytest.raises(ValueError, match=r"\(n, 19\)"):
        VoxelGrid().electrode_grids(np.zeros((2, 18)))
