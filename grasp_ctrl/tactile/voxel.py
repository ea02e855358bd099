"""Voxel grids of electrode values and contact points (16 x 16 x 8 cells).

The grid is the authors' (official_icra19 README): bin edges from
``numpy.histogramdd(electrode_positions_m, bins=(15, 15, 7))`` and cell index
``digitize(value, edges) - 1``, which yields 16 x 16 x 8 cells because a value
at the maximum edge lands one past the last bin. Two variants:

- ``icra19``: faithful to the authors' weights. A contact point below the lower
  edge of an axis gets index -1, which numpy indexing wraps to the LAST cell of
  that axis; pad presses (z about -5.5 mm, below the lowest electrode) therefore
  land in the top z cell. The weights were trained with that, so keep it.
- ``clamped``: the clean variant for newly trained models: out-of-range
  indices are clamped to the nearest cell.

Electrode grid: each electrode's tared value in its cell (no scaling); where
two electrodes share a cell the later one wins, as in the authors' loop.
Contact grid: 1.0 in the contact point's cell. Both vectorised over a batch.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from grasp_ctrl.config.sensor_layout import N_ELECTRODES
from grasp_ctrl.tactile.geometry import ELECTRODE_POSITIONS_SENSOR

VARIANTS = ("icra19", "clamped")
BINS = (15, 15, 7)
GRID_SHAPE = (16, 16, 8)


def _edges() -> list[np.ndarray]:
    _, edges = np.histogramdd(ELECTRODE_POSITIONS_SENSOR, bins=BINS)
    return [np.asarray(e, dtype=float) for e in edges]


class VoxelGrid:
    """Maps electrode values and contact points of a batch into voxel grids."""

    def __init__(self, variant: str = "icra19") -> None:
        if variant not in VARIANTS:
            raise ValueError(f"voxel grid variant must be one of {VARIANTS}, got {variant!r}")
        self.variant = variant
        self.shape = GRID_SHAPE
        self.edges = _edges()
        self._size = np.array(GRID_SHAPE)
        idx = self.cell_indices(ELECTRODE_POSITIONS_SENSOR)
        flat = np.ravel_multi_index(idx.T, GRID_SHAPE)
        # Last electrode wins a shared cell: keep each cell's last writer only.
        last = {int(c): i for i, c in enumerate(flat)}
        self.electrode_cells = idx
        self._el_flat = np.array(list(last.keys()), dtype=np.intp)
        self._el_src = np.array(list(last.values()), dtype=np.intp)
        self._n_cells = int(np.prod(GRID_SHAPE))
        self._strides = np.array([GRID_SHAPE[1] * GRID_SHAPE[2], GRID_SHAPE[2], 1], dtype=np.intp)

    def cell_indices(self, points: np.ndarray) -> np.ndarray:
        """(n, 3) points (m) -> (n, 3) cell indices in range, per the variant."""
        p = np.asarray(points, dtype=float)
        idx = np.empty(p.shape, dtype=np.intp)
        for k in range(3):  # three axes, not a loop over electrodes or samples
            idx[:, k] = np.digitize(p[:, k], self.edges[k]) - 1
        if self.variant == "icra19":
            return np.mod(idx, self._size)  # -1 -> last cell, as numpy indexing did
        return np.clip(idx, 0, self._size - 1)

    def electrode_grids(self, electrodes: np.ndarray, dtype: npt.DTypeLike = np.float32) -> np.ndarray:
        """(n, 19) tared electrode values -> (n, 16, 16, 8) grids."""
        e = np.asarray(electrodes)
        if e.ndim != 2 or e.shape[1] != N_ELECTRODES:
            raise ValueError(f"expected (n, {N_ELECTRODES}) electrode values, got {e.shape}")
        out = np.zeros((e.shape[0], self._n_cells), dtype=dtype)
        out[:, self._el_flat] = e[:, self._el_src]
        return out.reshape((e.shape[0],) + GRID_SHAPE)

    def contact_grids(self, points: np.ndarray, dtype: npt.DTypeLike = np.float32) -> np.ndarray:
        """(n, 3) contact points (m) -> (n, 16, 16, 8) one-hot grids."""
        idx = self.cell_indices(points)
        n = idx.shape[0]
        out = np.zeros((n, self._n_cells), dtype=dtype)
        out[np.arange(n), idx @ self._strides] = 1.0
        return out.reshape((n,) + GRID_SHAPE)
