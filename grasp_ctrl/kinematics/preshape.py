"""The reach posture that makes contact "in the desired configuration" (paper, Sec. V).

The hand file's pregrasp posture is one posture for every object. Closed from it
along the task vectors by position-only IK, a pad arrives at the object tilted by
whatever the finger's curl adds on the way (on the LEAP Hand up to 36 degrees on
the lego, 37 degrees sideways on a 75 mm cylinder), so the grip is mostly shear.
A grasp planner instead shapes the hand for the object. Here, per grasping finger:

1. the expected contact: the pregrasp pad point cast along the finger's closing
   vector onto the object's side (cylinder or box, object centred under the
   palm at the reach pose), at the height of the pregrasp pad;
2. the preshape: joint angles that put the pad ``standoff_m`` back from that
   point along the closing vector, its normal facing the surface there (a
   bounded least-squares fit; 1 rad of facing weighs like ``FACING_WEIGHT_M``).

Fingers whose closing line misses the object, the finger placed on a cap and
fingers that cannot reach their preshape (within 2 mm, facing within 10 degrees)
keep the hand file's pregrasp angles. On the LEAP Hand that leaves the 65-75 mm
cylinders (a pad facing their side would have to yaw ~37 degrees, and the LEAP
abduction joint yaws the pad the other way as it moves it sideways) and the
thumb on the large boxes (it reaches them only tilted ~18 degrees down).
The controller then keeps each pad facing that way while it closes
(``PadIK.step`` with a ``Facing``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR
from grasp_ctrl.numeric.solve_cache import stored

#: 1 rad of pad facing error weighs like this much pad position error (m).
FACING_WEIGHT_M = 0.01
#: Sliding along the surface from the expected contact weighs this much of the
#: same distance off the surface or off the contact height.
SLIDE_WEIGHT = 1.0
#: A preshape whose pad misses its height or standoff by more than this, or faces
#: the surface worse than this, is not used (m, degrees).
MAX_MISS_M = 0.002
MAX_FACING_ERROR_DEG = 10.0


@dataclass(frozen=True)
class Preshape:
    """Reach posture (all joints, hand-file order) and per finger the outward pad
    normal it should keep (hand frame; None: no facing for that finger)."""

    q: np.ndarray
    pad_normals_hand: tuple[np.ndarray | None, ...]
    contacts_hand: tuple[np.ndarray | None, ...]  # expected contact points (hand frame)


def surface_hit(
    obj: ObjectProfile, start_hand: np.ndarray, direction_hand: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """Where the horizontal ray from ``start_hand`` along ``direction_hand`` first meets
    the side of ``obj`` (centred at the hand frame's x = y = 0), and the outward
    surface normal there; None when it misses or starts inside."""
    d = np.array([direction_hand[0], direction_hand[1], 0.0])
    norm = float(np.hypot(d[0], d[1]))
    if norm < 1e-9:
        return None
    d /= norm
    x0, y0 = float(start_hand[0]), float(start_hand[1])
    if obj.shape == "cylinder":
        r = 0.5 * obj.size_m[0]
        # |p0 + s d|^2 = r^2, smallest s > 0.
        b = x0 * d[0] + y0 * d[1]
        c = x0 * x0 + y0 * y0 - r * r
        disc = b * b - c
        if c <= 0.0 or disc <= 0.0:
            return None
        s = -b - math.sqrt(disc)
        if s <= 0.0:
            return None
        hit = np.array([x0 + s * d[0], y0 + s * d[1], start_hand[2]])
        return hit, np.array([hit[0] / r, hit[1] / r, 0.0])
    hx, hy = 0.5 * obj.size_m[0], 0.5 * obj.size_m[1]
    if abs(x0) <= hx and abs(y0) <= hy:
        return None
    best: tuple[float, np.ndarray, np.ndarray] | None = None
    for axis, half, other_half in ((0, hx, hy), (1, hy, hx)):
        if abs(d[axis]) < 1e-12:
            continue
        for side in (-1.0, 1.0):
            s = (side * half - (x0, y0)[axis]) / d[axis]
            if s <= 0.0:
                continue
            p = np.array([x0 + s * d[0], y0 + s * d[1], start_hand[2]])
            if abs(p[1 - axis]) <= other_half + 1e-12 and (best is None or s < best[0]):
                n = np.zeros(3)
                n[axis] = side
                best = (s, p, n)
    return None if best is None else (best[1], best[2])


def side_gap(obj: ObjectProfile, p_hand: np.ndarray) -> tuple[float, np.ndarray]:
    """Horizontal distance of ``p_hand`` outside the side of ``obj`` (centred at the
    hand frame's x = y = 0; negative inside) and the outward normal of the nearest side."""
    x, y = float(p_hand[0]), float(p_hand[1])
    if obj.shape == "cylinder":
        r = math.hypot(x, y)
        return r - 0.5 * obj.size_m[0], (np.array([x / r, y / r, 0.0]) if r > 1e-9 else np.array([1.0, 0.0, 0.0]))
    gx, gy = abs(x) - 0.5 * obj.size_m[0], abs(y) - 0.5 * obj.size_m[1]
    if gx >= gy:
        return gx, np.array([math.copysign(1.0, x), 0.0, 0.0])
    return gy, np.array([0.0, math.copysign(1.0, y), 0.0])


@stored(ignore=("kin",))
def solve_preshape(
    hand: HandConfig, obj: ObjectProfile, standoff_m: float, kin: HandKinematics | None = None
) -> Preshape:
    """The preshape of ``obj`` for ``hand`` (see the module docstring)."""
    from scipy.optimize import least_squares

    kin = kin or HandKinematics(hand)
    q = np.array([j.pregrasp_rad for j in hand.joints])
    cap_finger = obj.cap.finger if obj.cap is not None else None
    normals: list[np.ndarray | None] = []
    contacts: list[np.ndarray | None] = []
    for finger in hand.fingers:
        normals.append(None)
        contacts.append(None)
        if not finger.grasp or finger.name == cap_finger:
            continue
        chain, sl = kin.chains[finger.name], kin.slices[finger.name]
        R0, p0 = chain.fk_rp(q[sl])
        pad0 = R0 @ PAD_POINT_SENSOR + p0
        v = np.asarray(finger.task_vector_hand, dtype=float)
        v_flat = np.array([v[0], v[1], 0.0]) / float(np.hypot(v[0], v[1]))
        hit = surface_hit(obj, pad0, v_flat)
        if hit is None:
            continue
        contact, n_surface = hit
        height, across = contact[2], np.cross([0.0, 0.0, 1.0], v_flat)

        def residual(qf: np.ndarray, chain=chain, contact=contact, n_surface=n_surface) -> np.ndarray:
            R, p = chain.fk_rp(qf)
            pad = R @ PAD_POINT_SENSOR + p
            # Where this pad would touch when closing along v, and the surface's normal there.
            hit_here = surface_hit(obj, pad, v_flat)
            touch, n_touch = hit_here if hit_here is not None else (contact, n_surface)
            ahead = float((touch - pad) @ v_flat)
            return np.concatenate(
                [
                    [pad[2] - height, ahead - standoff_m, SLIDE_WEIGHT * float((pad - contact) @ across)],
                    FACING_WEIGHT_M * (R @ PAD_NORMAL_SENSOR + n_touch),  # the pad's outward normal faces inward
                ]
            )

        fit = least_squares(residual, q[sl], bounds=(chain.lower, chain.upper))
        if float(np.linalg.norm(fit.fun[:2])) > MAX_MISS_M:
            continue
        if float(np.linalg.norm(fit.fun[3:])) / FACING_WEIGHT_M > math.radians(MAX_FACING_ERROR_DEG):
            continue  # the finger cannot face the object there: the pregrasp posture is as good
        q[sl] = fit.x
        R, p = chain.fk_rp(fit.x)
        pad = R @ PAD_POINT_SENSOR + p
        hit = surface_hit(obj, pad, v_flat)
        if hit is None:
            continue
        normals[-1] = R @ PAD_NORMAL_SENSOR
        contacts[-1] = hit[0]
    return Preshape(q, tuple(normals), tuple(contacts))


@functools.lru_cache(maxsize=64)
def _cached(hand: HandConfig, obj: ObjectProfile, standoff_m: float) -> Preshape:
    return solve_preshape(hand, obj, standoff_m)


def preshape(hand: HandConfig, obj: ObjectProfile, standoff_m: float) -> Preshape:
    """``solve_preshape``, fitted once per hand, object and standoff (a fit takes
    tens of milliseconds, a sizeable part of a simulated trial)."""
    shape = _cached(hand, obj, standoff_m)
    return Preshape(shape.q.copy(), shape.pad_normals_hand, shape.contacts_hand)
