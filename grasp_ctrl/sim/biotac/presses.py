"""Synthetic fingertip presses from the BioTac forward model (labelled data).

Used to fit the analytic policy shipped for the mock world and by the learning
side's synthetic data sets.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR
from grasp_ctrl.sim.biotac.grasp_contacts import GraspContacts
from grasp_ctrl.sim.biotac.model import BioTacParams, BioTacSensorModel


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
    points = np.broadcast_to(PAD_POINT_SENSOR, (n, 3))
    normals = np.broadcast_to(PAD_NORMAL_SENSOR, (n, 3))
    return _tared_presses(points, f, normals, rng, params), f


def _tared_presses(
    points: np.ndarray, f: np.ndarray, normals: np.ndarray, rng: np.random.Generator, params: BioTacParams | None
) -> np.ndarray:
    """Tared frames (n, 44) of steady presses, in batches of 256 on freshly drawn sensors."""
    n = len(f)
    tared = np.empty((n, 44))
    batch = 256
    for start in range(0, n, batch):
        stop = min(n, start + batch)
        m = stop - start
        model = BioTacSensorModel(m, rng, params or BioTacParams())
        raw = model.frames(
            points[start:stop], f[start:stop], normals[start:stop], np.ones(m, dtype=bool), np.zeros(m), 0.01
        )
        tared[start:stop] = raw - model.baseline
    return tared


def random_skin_points(
    n: int, rng: np.random.Generator, max_angle_deg: float = 60.0, cap_share: float = 0.2
) -> tuple[np.ndarray, np.ndarray]:
    """Contact points where a grasp's contacts land (sensor frame) and the outward skin
    normals there: along the whole pad (PAD_X_MIN_M <= x <= 0) up to ``max_angle_deg``
    from its centre line toward either side, and on the lower part of the tip cap."""
    from grasp_ctrl.kinematics.fingertip import PAD_X_MIN_M, SKIN_RADIUS_M

    a = np.deg2rad(max_angle_deg) * rng.uniform(-1.0, 1.0, n)
    normals = np.stack([np.zeros(n), np.sin(a), -np.cos(a)], axis=1)
    x = rng.uniform(PAD_X_MIN_M, 0.0, n)
    on_cap = rng.uniform(0.0, 1.0, n) < cap_share
    # On the cap: a direction tilted from the pad's normal toward the tip by up to 60 degrees.
    tilt = np.deg2rad(60.0) * np.sqrt(rng.uniform(0.0, 1.0, n))
    cap_normals = np.stack([np.sin(tilt), np.cos(tilt) * np.sin(a), -np.cos(tilt) * np.cos(a)], axis=1)
    normals[on_cap] = cap_normals[on_cap]
    points = SKIN_RADIUS_M * normals
    points[~on_cap, 0] = x[~on_cap]
    return points, normals


def skin_presses(
    n: int, seed: int, max_shear_ratio: float = 1.0, params: BioTacParams | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(tared frames (n, 44), f_sensor labels (n, 3)) for presses anywhere a grasp's
    contact lands (``random_skin_points``), each pressing into the skin along its normal
    with a shear of up to ``max_shear_ratio`` times the normal force in a random
    direction (within a friction cone of the objects' mu <= 1); each on a freshly drawn
    simulated sensor."""
    rng = np.random.default_rng(seed)
    points, normals = random_skin_points(n, rng)
    normal_n = rng.uniform(0.1, 6.0, n)
    ratio = max_shear_ratio * rng.uniform(0.0, 1.0, n)
    f = sheared_forces(normals, normal_n, ratio, rng)
    return _tared_presses(points, f, normals, rng, params), f


def sheared_forces(
    normals: np.ndarray, normal_n: np.ndarray, shear_ratio: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Forces on the skin (n, 3): ``normal_n`` pressing in along each outward normal plus
    ``shear_ratio`` times that in a random tangent direction."""
    # A tangent direction: a random vector with its normal part removed.
    t = rng.standard_normal(normals.shape)
    t -= np.sum(t * normals, axis=1, keepdims=True) * normals
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    return normal_n[:, None] * (-normals + shear_ratio[:, None] * t)


def contact_presses(
    contacts: GraspContacts,
    n: int,
    seed: int,
    scale_range: tuple[float, float] = (0.25, 1.75),
    params: BioTacParams | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(tared frames (n, 44), f_sensor labels (n, 3)) for presses at recorded contacts
    (``sim/biotac/grasp_contacts.py``): each a contact drawn at random, its force scaled by a
    factor from ``scale_range`` (the recording's forces are those of one grip law; a
    policy's grip may be lighter or harder) and, for half of them, its shear reversed
    (``reverse_shear``), on a freshly drawn simulated sensor."""
    rng = np.random.default_rng(seed)
    pick = contacts.sample(n, rng)
    normals = contacts.n_sensor[pick]
    f = reverse_shear(contacts.f_sensor[pick], normals, rng.uniform(0.0, 1.0, n) < 0.5)
    f *= rng.uniform(*scale_range, n)[:, None]
    return _tared_presses(contacts.p_sensor[pick], f, normals, rng, params), f


def reverse_shear(f_sensor: np.ndarray, n_sensor: np.ndarray, which: np.ndarray) -> np.ndarray:
    """The forces (n, 3) with the part along the skin reversed where ``which``. A grasp's
    shear points one way while the pads carry the object up and the other way once the
    table pushes it back into them: the release rule reads that sign, and a recording of
    grasps that release at once holds little of the second kind."""
    normal_part = np.sum(f_sensor * n_sensor, axis=1, keepdims=True) * n_sensor
    shear = f_sensor - normal_part
    return normal_part + np.where(which[:, None], -shear, shear)
