"""Object geometry of the mock world: a body standing on the table, optionally
topped by a domed cap (the mustard bottle's).

``shape_params`` packs a profile into a float array so that ``penetration``
can run inside the compiled world step (grasp_ctrl/numeric/jit.py).
"""

from __future__ import annotations

import math

import numpy as np

from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.numeric.jit import njit

# Layout of the parameter array.
CYLINDER, RADIUS, HALF_X, HALF_Y, BODY_H, HAS_CAP, CAP_R, CAP_CZ, CAP_DX, CAP_DY, TOP = range(11)


def shape_params(obj: ObjectProfile) -> np.ndarray:
    """Body (vertical cylinder or box of ``height_m``) plus the profile's cap: a
    spherical dome of base ``cap.diameter_m`` and height ``cap.height_m`` on the
    body's top, centred ``cap.offset_m`` from the footprint centre."""
    s = np.zeros(11)
    s[CYLINDER] = 1.0 if obj.shape == "cylinder" else 0.0
    s[RADIUS] = obj.half_width_m
    s[HALF_X], s[HALF_Y] = 0.5 * obj.size_m[0], 0.5 * obj.size_m[1]
    s[BODY_H] = s[TOP] = obj.height_m
    if obj.cap is not None:
        r, h = 0.5 * obj.cap.diameter_m, obj.cap.height_m
        s[HAS_CAP] = 1.0
        s[CAP_R] = (r * r + h * h) / (2.0 * h)  # radius of the dome's sphere
        s[CAP_CZ] = obj.height_m + h - s[CAP_R]
        s[CAP_DX], s[CAP_DY] = obj.cap.offset_m
        s[TOP] = obj.height_m + h
    return s


@njit
def penetration(s: np.ndarray, dx: float, dy: float, z: float) -> tuple[float, float, float, float]:
    """Depth of a point at (dx, dy) from the footprint centre and z above the
    object's base (<= 0 outside), and the outward unit normal of the nearest surface."""
    if z < 0.0 or z > s[TOP]:
        return -1.0, 0.0, 0.0, 0.0
    if z > s[BODY_H]:
        # The dome: a sphere cut at the body's top, so its normal tilts upward.
        x, y, zc = dx - s[CAP_DX], dy - s[CAP_DY], z - s[CAP_CZ]
        d = math.sqrt(x * x + y * y + zc * zc)
        if d < 1e-9:
            return s[CAP_R], 0.0, 0.0, 1.0
        return s[CAP_R] - d, x / d, y / d, zc / d
    if s[CYLINDER] > 0.0:
        r = math.sqrt(dx * dx + dy * dy)
        if r < 1e-9:
            return s[RADIUS], 1.0, 0.0, 0.0
        return s[RADIUS] - r, dx / r, dy / r, 0.0
    px, py = s[HALF_X] - abs(dx), s[HALF_Y] - abs(dy)
    if px <= py:
        return px, (1.0 if dx >= 0.0 else -1.0), 0.0, 0.0
    return py, 0.0, (1.0 if dy >= 0.0 else -1.0), 0.0
