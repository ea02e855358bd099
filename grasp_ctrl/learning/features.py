"""Spatial features of tared BioTac frames: contact point, surface normal, voxel grids.

All model inputs are computed here, behind ``model_inputs``, so the package can
switch to the tactile pipeline's own implementation (grasp_ctrl.tactile) in one
place. The rules follow the authors' network (official_icra19 README):

- contact point: centroid of the electrode positions weighted by the squared
  tared electrode values, projected onto the sensor surface of radius 5.5 mm
  (sphere about the origin for x > 0, cylinder about the x axis otherwise);
  the outward surface normal at that point;
- voxel grids (16, 16, 8): bin edges of ``histogramdd`` over the 19 electrode
  positions with (15, 15, 7) bins, index = digitize - 1; an index of -1 (below
  the lowest edge) wraps to the last cell as in the authors' code.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.tactile.geometry import ELECTRODE_POSITIONS_SENSOR, SURFACE_RADIUS_M
from grasp_ctrl.tactile.layout import ELECTRODES, PDC

GRID_SHAPE = (16, 16, 8)
_EDGES = [np.asarray(e) for e in np.histogramdd(ELECTRODE_POSITIONS_SENSOR, bins=(15, 15, 7))[1]]


def _cell_index(points: np.ndarray) -> np.ndarray:
    """(n, 3) points -> (n, 3) voxel indices in [0, 16) x [0, 16) x [0, 8), authors' wrap."""
    idx = np.stack([np.digitize(points[:, k], _EDGES[k]) - 1 for k in range(3)], axis=1)
    return np.where(idx < 0, np.array(GRID_SHAPE) - 1, idx)


_ELECTRODE_CELLS = _cell_index(ELECTRODE_POSITIONS_SENSOR)


def surface_point_and_normal(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Project points onto the sensor surface model; outward unit normals there."""
    p = np.asarray(points, dtype=float)
    r = SURFACE_RADIUS_M
    cap = p[:, 0] > 0
    sphere_norm = np.linalg.norm(p, axis=1)
    cyl = p.copy()
    cyl[:, 0] = 0.0
    cyl_norm = np.linalg.norm(cyl, axis=1)
    # a point on the axis has no direction: take the pad (-z)
    n_sphere = np.where(sphere_norm[:, None] > 1e-12, p / np.maximum(sphere_norm, 1e-12)[:, None], [0.0, 0.0, -1.0])
    n_cyl = np.where(cyl_norm[:, None] > 1e-12, cyl / np.maximum(cyl_norm, 1e-12)[:, None], [0.0, 0.0, -1.0])
    normal = np.where(cap[:, None], n_sphere, n_cyl)
    point = np.where(cap[:, None], r * n_sphere, np.column_stack([p[:, 0], r * n_cyl[:, 1], r * n_cyl[:, 2]]))
    return point, normal


def contact_point_and_normal(tared: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, 44) tared frames -> contact point (n, 3) m and outward normal (n, 3), sensor frame."""
    e = np.asarray(tared, dtype=float)[:, ELECTRODES]
    w = e * e
    total = w.sum(axis=1, keepdims=True)
    w = np.where(total > 0, w / np.maximum(total, 1e-300), 1.0 / e.shape[1])
    return surface_point_and_normal(w @ ELECTRODE_POSITIONS_SENSOR)


def voxel_grids(tared: np.ndarray, contact_point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Electrode grid (tared counts in each electrode's cell) and contact grid (1 at s_c)."""
    n = len(tared)
    e_vox = np.zeros((n,) + GRID_SHAPE, dtype=np.float32)
    ci = _ELECTRODE_CELLS
    # electrodes have distinct cells (the paper chose the grid for that), so assignment is exact
    e_vox[:, ci[:, 0], ci[:, 1], ci[:, 2]] = np.asarray(tared, dtype=np.float32)[:, ELECTRODES]
    c_vox = np.zeros((n,) + GRID_SHAPE, dtype=np.float32)
    cc = _cell_index(contact_point)
    c_vox[np.arange(n), cc[:, 0], cc[:, 1], cc[:, 2]] = 1.0
    return e_vox, c_vox


def model_inputs(tared: np.ndarray) -> dict[str, np.ndarray]:
    """Every input any model of this package uses, by name (float32)."""
    tared = np.asarray(tared, dtype=float)
    s_c, s_n = contact_point_and_normal(tared)
    e_vox, c_vox = voxel_grids(tared, s_c)
    return {
        "electrode_voxels": e_vox,
        "contact_voxels": c_vox,
        "electrodes": tared[:, ELECTRODES].astype(np.float32),
        "pdc": tared[:, PDC:PDC + 1].astype(np.float32),
        "contact_point": s_c.astype(np.float32),
        "surface_normal": s_n.astype(np.float32),
    }
