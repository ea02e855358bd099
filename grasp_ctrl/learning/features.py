"""Model inputs of tared BioTac frames, from the tactile pipeline's own feature code.

All inputs any model of this package uses are computed here, behind ``model_inputs``,
with exactly the functions the controller's ONNX estimator uses at run time
(``grasp_ctrl.tactile.features`` and ``grasp_ctrl.tactile.voxel``, variant ``icra19``),
so training and deployment see the same features:

- contact point: centroid of the electrode positions weighted by the squared tared
  electrode values, projected onto the sensor surface of radius 5.5 mm; the outward
  surface normal there;
- voxel grids (16, 16, 8) with the authors' index wrap.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config.sensor_layout import ELECTRODES, PDC
from grasp_ctrl.tactile.features import contact_points, surface_normals
from grasp_ctrl.tactile.geometry import SURFACE_RADIUS_M
from grasp_ctrl.tactile.voxel import GRID_SHAPE, VoxelGrid

VOXEL_VARIANT = "icra19"
_GRID = VoxelGrid(VOXEL_VARIANT)
_ELECTRODE_CELLS = _GRID.electrode_cells  # (19, 3), all distinct


def _cell_index(points: np.ndarray) -> np.ndarray:
    """(n, 3) points -> (n, 3) voxel indices (authors' wrap)."""
    return _GRID.cell_indices(points)


def surface_point_and_normal(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Project arbitrary points onto the sensor surface model (sphere cap for x > 0,
    cylinder about x otherwise); outward unit normals there. Used to place synthetic contacts."""
    p = np.asarray(points, dtype=float)
    cap = p[:, 0] > 0
    r = np.where(cap, np.linalg.norm(p, axis=1), np.hypot(p[:, 1], p[:, 2]))
    r = np.where(r > 1e-12, r, 1.0)
    q = p.copy()
    q[:, 1:] *= (SURFACE_RADIUS_M / r)[:, None]
    q[:, 0] = np.where(cap, p[:, 0] * SURFACE_RADIUS_M / r, p[:, 0])
    return q, surface_normals(q)


def contact_point_and_normal(tared: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, 44) tared frames -> contact point (n, 3) m and outward normal (n, 3), sensor frame."""
    p = contact_points(np.asarray(tared, dtype=float))
    return p, surface_normals(p)


def voxel_grids(tared: np.ndarray, contact_point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Electrode grid (tared counts in each electrode's cell) and contact grid (1 at s_c)."""
    return _GRID.electrode_grids(np.asarray(tared, dtype=float)[:, ELECTRODES]), _GRID.contact_grids(contact_point)


def model_inputs(tared: np.ndarray) -> dict[str, np.ndarray]:
    """Every input any model of this package uses, by name (float32)."""
    tared = np.asarray(tared, dtype=float)
    s_c, s_n = contact_point_and_normal(tared)
    e_vox, c_vox = voxel_grids(tared, s_c)
    return {
        "electrode_voxels": e_vox,
        "contact_voxels": c_vox,
        "electrodes": tared[:, ELECTRODES].astype(np.float32),
        "pdc": tared[:, PDC : PDC + 1].astype(np.float32),
        "contact_point": s_c.astype(np.float32),
        "surface_normal": s_n.astype(np.float32),
    }


__all__ = ["GRID_SHAPE", "model_inputs", "contact_point_and_normal", "voxel_grids", "surface_point_and_normal"]
