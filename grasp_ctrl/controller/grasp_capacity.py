"""How heavy an object a grasp can lift with its servos' torque and the contacts' friction.

Statics of a fingertip grasp on a free object: each grasping pad pushes on the object with a
force in its (pyramidal) friction cone plus a torsional moment within mu x the contact patch's
radius; the forces and moments balance the object's weight; every joint holds its share
``J^T f`` within its torque limit (current limit x the servo's torque constant). A linear
programme gives the largest weight that can be carried that way: an upper bound on what any
grip law achieves with this hand posture (docs/hand_geometry.md, "What the servos can lift").

``object_capacity`` places the hand as the controller does (the per-object preshape and the
cap finger's raised posture), closes each grasping pad along its task vector onto the object's
side, and evaluates the grasp there. A grasp that cannot close (an object as wide as the pregrasp
gap between opposing pads, a pad that starts inside it or never reaches it) raises
:class:`NoGrasp` saying why: no figure is computed for it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grasp_ctrl.config.actuation import torque_limits_nm
from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import CapProfile, ObjectProfile
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR
from grasp_ctrl.numeric.gravity import GRAVITY_M_S2
from grasp_ctrl.numeric.solve_cache import stored

#: Radius of the pad's contact patch for torsional friction (the MuJoCo scene's).
TORSION_RADIUS_M = 0.003
_FACETS = 8  # sides of the friction pyramid (inscribed in the cone)


class NoGrasp(ValueError):
    """The hand cannot close on the object as the controller places it; the message says why."""


@dataclass(frozen=True)
class PregraspGap:
    """Two grasping pads that close toward each other, and their distance at the pregrasp posture
    along the line they close on (``direction_hand``: unit, horizontal, first pad -> second)."""

    fingers: tuple[str, str]
    direction_hand: np.ndarray
    gap_m: float


def pregrasp_pads(hand: HandConfig, kin: HandKinematics | None = None) -> dict[str, np.ndarray]:
    """Each grasping finger's pad point (hand frame) at the hand file's pregrasp posture."""
    kin = kin or HandKinematics(hand)
    q = np.array([j.pregrasp_rad for j in hand.joints])
    pads = {}
    for finger in hand.grasp_fingers:
        rot, origin = kin.chains[finger.name].fk_rp(q[kin.slices[finger.name]])
        pads[finger.name] = rot @ PAD_POINT_SENSOR + origin
    return pads


def _flat(v: tuple[float, float, float]) -> np.ndarray:
    """The closing direction's horizontal part, unit (the hand file keeps it non-zero)."""
    flat = np.array([v[0], v[1], 0.0])
    return flat / float(np.linalg.norm(flat))


def pregrasp_gaps(
    hand: HandConfig, kin: HandKinematics | None = None, leave_out: str | None = None
) -> list[PregraspGap]:
    """Every pair of grasping fingers (but ``leave_out``) whose horizontal closing directions
    oppose, with their pads' distance along the line they close on at the pregrasp posture."""
    pads = pregrasp_pads(hand, kin)
    fingers = [f for f in hand.grasp_fingers if f.name != leave_out]
    out = []
    for i, a in enumerate(fingers):
        for b in fingers[i + 1 :]:
            va, vb = _flat(a.task_vector_hand), _flat(b.task_vector_hand)
            if float(va @ vb) >= 0.0:
                continue  # side by side (index and middle): no gap between them
            d = (va - vb) / float(np.linalg.norm(va - vb))  # the line they close on, from a's pad toward b's
            out.append(PregraspGap((a.name, b.name), d, float((pads[b.name] - pads[a.name]) @ d)))
    return out


def width_along(obj: ObjectProfile, direction_hand: np.ndarray) -> float:
    """The object's extent (m) along a horizontal direction, its footprint's axes on the hand's."""
    if obj.shape == "cylinder":
        return obj.size_m[0]
    return abs(float(direction_hand[0])) * obj.size_m[0] + abs(float(direction_hand[1])) * obj.size_m[1]


def closing_blocked(hand: HandConfig, obj: ObjectProfile, kin: HandKinematics | None = None) -> str | None:
    """Why the grasping pads cannot close around ``obj`` from the pregrasp posture (object centred
    under the palm), or None: it is at least as wide as the gap between two opposing pads, or a
    pad starts inside its side. The cap finger closes on the cap, above the body: left out."""
    from grasp_ctrl.kinematics.preshape import side_gap

    kin = kin or HandKinematics(hand)
    cap_finger = obj.cap.finger if obj.cap is not None else None
    for g in pregrasp_gaps(hand, kin, leave_out=cap_finger):
        width = width_along(obj, g.direction_hand)
        if width >= g.gap_m:
            a, b = g.fingers
            return (
                f"{1000 * width:.0f} mm across between the {a} and {b} pads, not narrower than the hand's "
                f"pregrasp gap of {1000 * g.gap_m:.0f} mm between them (the pads cannot close around it)"
            )
    for name, pad in pregrasp_pads(hand, kin).items():
        gap, _ = side_gap(obj, pad)
        if name != cap_finger and gap <= 0.0:
            return (
                f"the {name} pad starts {abs(1000 * gap):.0f} mm inside the object's side at the pregrasp posture "
                "(object centred under the palm: the pads cannot close around it)"
            )
    return None


@dataclass(frozen=True)
class PadContact:
    """One pad on the object: the contact point and the surface's outward normal (hand frame)."""

    finger: str
    point_hand: np.ndarray
    normal_hand: np.ndarray
    facing_deg: float = 0.0  # the pad's normal off the surface's (how squarely the pad meets it)


@dataclass(frozen=True)
class PadLoad:
    """What one pad does at the best grasp: its normal force, the part it carries up (N)
    and the most loaded of its joints as a share of that joint's torque limit."""

    finger: str
    normal_n: float
    lift_n: float
    joint: str
    torque_share: float


@dataclass(frozen=True)
class Capacity:
    weight_n: float  # the largest weight the grasp carries (0: none)
    loads: tuple[PadLoad, ...]

    def margin(self, mass_kg: float) -> float:
        """The liftable weight over the object's weight."""
        return self.weight_n / (mass_kg * GRAVITY_M_S2)


@stored(ignore=("kin",))
def liftable_weight(
    hand: HandConfig,
    q_all: np.ndarray,
    contacts: list[PadContact],
    mu: float,
    kin: HandKinematics | None = None,
    torque_per_amp_nm: float | None = None,
    normal_max_n: dict[str, float] | None = None,
) -> Capacity:
    """The largest weight (N) the pads in ``contacts`` carry at joint angles ``q_all`` (hand-file
    order), the object's weight acting on the vertical line through the hand frame's origin.
    ``normal_max_n`` (finger -> N): each listed pad's normal force at most that (its grip target).
    ``torque_per_amp_nm``: a Dynamixel hand's servos' (default: the hand file's; its joints'
    torque limits come from config/actuation.py)."""
    from scipy.optimize import linprog

    kin = kin or HandKinematics(hand)
    all_limits = torque_limits_nm(hand, torque_per_amp_nm)
    z = np.array([0.0, 0.0, 1.0])
    nv = 4 * len(contacts) + 1  # per pad: normal, tangent up, tangent across, torsion; weight
    a_ub: list[np.ndarray] = []
    b_ub: list[float] = []
    balance = np.zeros((6, nv))
    frames = []
    for i, c in enumerate(contacts):
        n = -np.asarray(c.normal_hand, dtype=float)
        n /= np.linalg.norm(n)
        up = z - (z @ n) * n
        up = up / np.linalg.norm(up) if np.linalg.norm(up) > 1e-9 else np.array([1.0, 0.0, 0.0])
        across = np.cross(n, up)
        cols = 4 * i + np.arange(4)
        p = np.asarray(c.point_hand, dtype=float)
        for col, vec in zip(cols[:3], (n, up, across)):
            balance[:3, col] = vec
            balance[3:, col] = np.cross(p, vec)
        balance[3:, cols[3]] = n
        for k in range(_FACETS):
            row = np.zeros(nv)
            a = 2.0 * math.pi * k / _FACETS
            row[cols[1]], row[cols[2]] = math.cos(a), math.sin(a)
            row[cols[0]] = -mu * math.cos(math.pi / _FACETS)
            a_ub.append(row)
            b_ub.append(0.0)
        for sign in (1.0, -1.0):
            row = np.zeros(nv)
            row[cols[3]], row[cols[0]] = sign, -mu * TORSION_RADIUS_M
            a_ub.append(row)
            b_ub.append(0.0)
        finger = hand.finger(c.finger)
        _, jac = kin.chains[c.finger].point_and_jacobian(q_all[kin.slices[c.finger]], PAD_POINT_SENSOR)
        limits = all_limits[kin.slices[c.finger]]
        per_n = np.stack([jac.T @ n, jac.T @ up, jac.T @ across], axis=1)  # joint torque per N
        for j, tau_max in enumerate(limits):
            row = np.zeros(nv)
            row[cols[:3]] = per_n[j]
            a_ub += [row, -row]
            b_ub += [float(tau_max), float(tau_max)]
        frames.append((cols, per_n, limits, finger))
    balance[2, -1] = -1.0
    bounds: list[tuple[float | None, float | None]] = [(None, None)] * nv
    for i, c in enumerate(contacts):
        bounds[4 * i] = (0.0, (normal_max_n or {}).get(c.finger))
    bounds[-1] = (0.0, None)
    cost = np.zeros(nv)
    cost[-1] = -1.0
    res = linprog(cost, A_ub=np.array(a_ub), b_ub=b_ub, A_eq=balance, b_eq=np.zeros(6), bounds=bounds, method="highs")
    if res.status != 0:
        return Capacity(0.0, ())
    loads = []
    for c, (cols, per_n, limits, finger) in zip(contacts, frames):
        share = np.abs(per_n @ res.x[cols[:3]]) / limits
        j = int(np.argmax(share))
        loads.append(
            PadLoad(c.finger, float(res.x[cols[0]]), float(res.x[cols[1]]), finger.joints[j].name, float(share[j]))
        )
    return Capacity(float(res.x[-1]), tuple(loads))


def _cap_contact(cap: CapProfile, pad: np.ndarray, top_z_hand: float) -> tuple[float, np.ndarray]:
    """Horizontal gap of ``pad`` outside the mustard-style dome and the dome's outward normal
    at the pad's height (the dome: a sphere cap of the cap's diameter and height)."""
    a, h = 0.5 * cap.diameter_m, cap.height_m
    radius = (a * a + h * h) / (2.0 * h)
    centre_z = h - radius  # sphere centre above the body's top
    z_rel = pad[2] - top_z_hand  # pad height above the body's top
    ring = math.sqrt(max(radius * radius - (z_rel - centre_z) ** 2, 1e-12))
    dx, dy = pad[0] - cap.offset_m[0], pad[1] - cap.offset_m[1]
    r = math.hypot(dx, dy)
    u = np.array([dx / r, dy / r]) if r > 1e-9 else np.array([1.0, 0.0])
    normal = np.array([u[0] * ring, u[1] * ring, z_rel - centre_z]) / radius
    return r - ring, normal


def object_capacity(
    hand: HandConfig,
    obj: ObjectProfile,
    standoff_m: float = 0.01,
    step_m: float = 0.0005,
    kin: HandKinematics | None = None,
    normal_max_n: dict[str, float] | None = None,
) -> tuple[Capacity, list[PadContact], np.ndarray]:
    """The grasp of ``obj`` as the controller makes it (preshape, cap finger raised, pads closed
    along their task vectors until they touch), its capacity, the contacts and the posture.
    The hand frame's origin is ``[grasp] palm_above_contact_m`` above the reach height.
    Raises :class:`NoGrasp` (why) where the pads cannot close on the object."""
    from grasp_ctrl.controller.machine import raised_reach_posture
    from grasp_ctrl.kinematics.preshape import preshape, side_gap

    kin = kin or HandKinematics(hand)
    blocked = closing_blocked(hand, obj, kin)
    if blocked is not None:
        raise NoGrasp(blocked)
    q = preshape(hand, obj, standoff_m).q
    cap = obj.cap
    # the body's top in the hand frame (the hand origin palm_above_contact_m over the grasp height)
    top_z_hand = obj.height_m - obj.grasp_height_m - hand.grasp.palm_above_contact_m
    if cap is not None:
        raised = raised_reach_posture(hand, cap.finger, cap.contact_height_m - obj.grasp_height_m)
        sl = kin.slices[cap.finger]
        q[sl] = raised[sl]
    contacts = []
    for finger in hand.grasp_fingers:
        chain, sl = kin.chains[finger.name], kin.slices[finger.name]
        v = np.asarray(finger.task_vector_hand, dtype=float)
        qf = q[sl].copy()
        normal = None
        for _ in range(400):
            pad, _ = chain.point_and_jacobian(qf, PAD_POINT_SENSOR)
            if cap is not None and finger.name == cap.finger:
                gap, normal = _cap_contact(cap, pad, top_z_hand)
            else:
                gap, normal = side_gap(obj, pad)
            if gap <= 0.0:
                break
            qf = chain.ik_step(qf, v * min(step_m, gap + 1e-5), PAD_POINT_SENSOR)
        else:  # the controller waits for every grasping pad's contact: without it, no grasp
            raise NoGrasp(f"the {finger.name} pad does not reach the object closing along its task vector")
        q[sl] = qf
        rot, origin = chain.fk_rp(qf)
        pad = rot @ PAD_POINT_SENSOR + origin
        facing = math.degrees(math.acos(float(np.clip(-(rot @ PAD_NORMAL_SENSOR) @ normal, -1.0, 1.0))))
        contacts.append(PadContact(finger.name, pad, normal, facing))
    return liftable_weight(hand, q, contacts, obj.mu, kin, normal_max_n=normal_max_n), contacts, q
