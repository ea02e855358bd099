"""Contact point and surface normal from tared electrode values (Lin et al. 2013).

Contact point: the centroid of the electrode positions weighted by the squared
tared electrode values, projected onto the sensor surface model: a sphere of
radius 5.5 mm about the origin where x > 0 (the tip cap), otherwise a cylinder
of the same radius about the x axis. The surface normal there points outward.
This is the rule the ICRA 2019 network was trained with. Vectorised over a
batch of fingertips.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config.sensor_layout import ELECTRODES, N_ELECTRODES
from grasp_ctrl.tactile.geometry import ELECTRODE_POSITIONS_SENSOR, SURFACE_RADIUS_M

# The authors add this to the weight sum; kept so centroids match theirs.
_WEIGHT_EPS = 1e-8
# A centroid this close to the origin/axis has no defined direction (no signal).
DEGENERATE_RADIUS_M = 1e-9


def electrodes_of(tared: np.ndarray) -> np.ndarray:
    """(n, 44) tared frames or (n, 19) electrode values -> (n, 19)."""
    a = np.asarray(tared, dtype=float)
    if a.ndim != 2 or a.shape[1] not in (N_ELECTRODES, 44):
        raise ValueError(f"expected (n, 19) electrodes or (n, 44) frames, got {a.shape}")
    return a[:, ELECTRODES] if a.shape[1] == 44 else a


def contact_points(tared: np.ndarray, radius_m: float = SURFACE_RADIUS_M) -> np.ndarray:
    """(n, 44) or (n, 19) tared values -> (n, 3) contact points on the surface (m).

    With no electrode signal the centroid is undefined (it sits within
    ``DEGENERATE_RADIUS_M`` of the origin or the x axis); such rows get the pad
    point (0, 0, -radius).
    """
    e = electrodes_of(tared)
    w = e * e
    w = w / (w.sum(axis=1, keepdims=True) + _WEIGHT_EPS)
    c = w @ ELECTRODE_POSITIONS_SENSOR
    on_cap = c[:, 0] > 0.0
    # Sphere: scale all three coordinates; cylinder: scale y and z only.
    r_sphere = np.linalg.norm(c, axis=1)
    r_cyl = np.hypot(c[:, 1], c[:, 2])
    r = np.where(on_cap, r_sphere, r_cyl)
    degenerate = r < DEGENERATE_RADIUS_M
    scale = radius_m / np.where(degenerate, 1.0, r)
    p = c.copy()
    p[:, 1:] *= scale[:, None]
    p[:, 0] = np.where(on_cap, c[:, 0] * scale, c[:, 0])
    if degenerate.any():
        p[degenerate] = (0.0, 0.0, -radius_m)
    return p


def surface_normals(points: np.ndarray) -> np.ndarray:
    """(n, 3) points on the surface -> (n, 3) outward unit normals."""
    p = np.asarray(points, dtype=float)
    n = p.copy()
    n[:, 0] = np.where(p[:, 0] > 0.0, p[:, 0], 0.0)
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    bad = norm[:, 0] <= 0.0
    n = n / np.where(bad[:, None], 1.0, norm)
    if bad.any():
        n[bad] = (0.0, 0.0, -1.0)
    return n
