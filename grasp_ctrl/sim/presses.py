"""Synthetic fingertip presses from the BioTac forward model (labelled data).

Used to fit the analytic policy shipped for the mock world and by the learning
side's synthetic data sets.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR
from grasp_ctrl.sim.biotac_model import BioTacParams, BioTacSensorModel


def random_pad_forces(n: int, rng: np.random.Generator, max_force_n: float = 6.0, cone_deg: float = 45.0) -> np.ndarray:
    """Forces on the skin (sensor frame) pressing into the pad, within a cone about +z."""
    mag = rng.uniform(0.1, max_force_n, n)
    tilt = np.deg2rad(cone_deg) * np.sqrt(rng.uniform(0, 1, n))
    az = rng.uniform(0, 2 * np.pi, n)
    d = np.stack([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)], axis=1)
    return mag[:, None] * d


def pad_presses(n: int, seed: int, params: BioTacParams | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(tared frames (n, 44), f_sensor labels (n, 3)) for presses at the pad point,
    each on a freshly drawn simulated sensor (so gain spread is in the data)."""
    rng = np.random.default_rng(seed)
    f = random_pad_forces(n, rng)
    tared = np.empty((n, 44))
    batch = 256
    for start in range(0, n, batch):
        stop = min(n, start + batch)
        m = stop - start
        model = BioTacSensorModel(m, rng, params or BioTacParams())
        p = np.broadcast_to(PAD_POINT_SENSOR, (m, 3))
        nrm = np.broadcast_to(PAD_NORMAL_SENSOR, (m, 3))
        raw = model.frames(p, f[start:stop], nrm, np.ones(m, dtype=bool), np.zeros(m), 0.01)
        tared[start:stop] = raw - model.baseline
    return tared, f
