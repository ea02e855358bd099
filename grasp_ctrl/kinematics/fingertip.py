"""The fingertip reference point used for contact and task-space motion.

The pad point lies on the BioTac surface model (cylinder of radius 5.5 mm about
the sensor x axis) under the central pad electrodes; its outward normal is -z
of the sensor frame (the pad faces -z, docs/design.md 4).
"""

from __future__ import annotations

import math

import numpy as np

from grasp_ctrl.numeric.jit import njit

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
PAD_POINT_X_M = float(PAD_POINT_SENSOR[0])


@njit
def skin_contact_point(ux: float, uy: float, uz: float) -> tuple[float, float, float, float, float, float]:
    """``contact_on_skin`` on plain floats (also compiled into the mock world's step):
    the contact point (x, y, z) and outward skin normal (x, y, z), sensor frame."""
    norm = math.sqrt(ux * ux + uy * uy + uz * uz)
    ux, uy, uz = ux / norm, uy / norm, uz / norm
    if ux > CAP_TILT_SIN:
        return SKIN_RADIUS_M * ux, SKIN_RADIUS_M * uy, SKIN_RADIUS_M * uz, ux, uy, uz
    yz = math.sqrt(uy * uy + uz * uz)
    if yz > 1e-9:
        ry, rz = uy / yz, uz / yz
    else:
        ry, rz = 0.0, 1.0  # the pad's opposite side (-PAD_NORMAL_SENSOR)
    x = min(max(PAD_POINT_X_M + PAD_SLIDE_M * ux / CAP_TILT_SIN, PAD_X_MIN_M), 0.0)
    return x, SKIN_RADIUS_M * ry, SKIN_RADIUS_M * rz, 0.0, ry, rz


def contact_on_skin(u_sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where a flat surface pressing along ``u_sensor`` (unit, from the fingertip into
    the surface, sensor frame) touches the skin: the contact point and the skin's
    outward normal there, both sensor frame.

    A rigid fingertip touches a plane at its support point in that direction: on
    the cap when the surface faces the tip, else on the pad, sliding along it with
    the tilt (a flat press lands on the pad centre, PAD_POINT_SENSOR).
    """
    u = np.asarray(u_sensor, dtype=float)
    cx, cy, cz, nx, ny, nz = skin_contact_point(float(u[0]), float(u[1]), float(u[2]))
    return np.array([cx, cy, cz]), np.array([nx, ny, nz])
