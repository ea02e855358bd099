"""The fingertip reference point used for contact and task-space motion.

The pad point lies on the BioTac surface model (cylinder of radius 5.5 mm about
the sensor x axis) under the central pad electrodes; its outward normal is -z
of the sensor frame (the pad faces -z, DESIGN.md 4).
"""

from __future__ import annotations

import numpy as np

PAD_POINT_SENSOR = np.array([-0.003, 0.0, -5.5e-3])
PAD_NORMAL_SENSOR = np.array([0.0, 0.0, -1.0])
PAD_POINT_SENSOR.setflags(write=False)
PAD_NORMAL_SENSOR.setflags(write=False)


# The skin of the surface model: a cylinder of radius r about the sensor x axis
# for PAD_X_MIN <= x <= 0, closed by a hemispherical cap for x > 0.
SKIN_RADIUS_M = 5.5e-3
PAD_X_MIN_M = -0.014
#: Tilt (sine of the angle between the pressing direction and the pad's plane)
#: at which the contact leaves the pad for the fingertip's cap.
CAP_TILT_SIN = 0.17
PAD_SLIDE_M = 0.004


def contact_on_skin(u_sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where a flat surface pressing along ``u_sensor`` (unit, from the fingertip into
    the surface, sensor frame) touches the skin: the contact point and the skin's
    outward normal there, both sensor frame.

    A rigid fingertip touches a plane at its support point in that direction: on
    the cap when the surface faces the tip, else on the pad, sliding along it with
    the tilt (a flat press lands on the pad centre, PAD_POINT_SENSOR).
    """
    u = np.asarray(u_sensor, dtype=float)
    u = u / np.linalg.norm(u)
    if u[0] > CAP_TILT_SIN:
        return SKIN_RADIUS_M * u, u
    yz = np.hypot(u[1], u[2])
    ring = np.array([0.0, u[1], u[2]]) / yz if yz > 1e-9 else -PAD_NORMAL_SENSOR
    x = float(np.clip(PAD_POINT_SENSOR[0] + PAD_SLIDE_M * u[0] / CAP_TILT_SIN, PAD_X_MIN_M, 0.0))
    return np.array([x, 0.0, 0.0]) + SKIN_RADIUS_M * ring, ring
