"""The reference reading of MuJoCo's contacts at the fingertips: what the MuJoCo world's compiled
tick (grasp_ctrl/sim/mujoco/tick_kernel.py, ``mj_tick_frames``) computes, written plainly.

With elliptic friction cones MuJoCo's contact force of contact ``i`` is
``efc_force[efc_address[i] : +3]`` in the contact frame (normal, two tangents;
what ``mj_contactForce`` returns); the frame's first row is the normal from
geom1 to geom2 and the force acts on geom2 along it (on geom1 opposite).

These functions define the reading; the world's tick computes the same in one compiled
call, checked bit for bit against them by tests/sim/test_mujoco_lean.py.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasp_ctrl.kinematics.fingertip import PAD_X_MIN_M, SKIN_RADIUS_M


@dataclass
class TipContacts:
    """Per fingertip, this step: force ON the skin (world), normal force from the object,
    the force-weighted contact point (world) and whether anything touches it."""

    f_world: np.ndarray  # (F, 3)
    normal_from_object_n: np.ndarray  # (F,)
    point_world: np.ndarray  # (F, 3)
    touching: np.ndarray  # (F,) bool
    touching_object: np.ndarray  # (F,) bool
    table_normal_on_object_n: float
    object_on_table: bool
    other_hand_on_object_n: float  # normal force of hand links (not the fingertips) on the object


def read_contacts(
    model, data, tip_geom_of: list[int], object_geom: list[bool], table_geom: int, n_tips: int
) -> TipContacts:
    """``tip_geom_of[g]``: fingertip index of geom g or -1; ``object_geom[g]``: whether geom g
    is the object's; ``table_geom``: the table's geom id. A few contacts per step: plain
    Python floats are faster here than numpy on tiny arrays."""
    f = [[0.0, 0.0, 0.0] for _ in range(n_tips)]
    psum = [[0.0, 0.0, 0.0] for _ in range(n_tips)]
    weight = [0.0] * n_tips
    normal = [0.0] * n_tips
    touching = [False] * n_tips
    touching_obj = [False] * n_tips
    table_n = 0.0
    on_table = False
    other = 0.0
    n = data.ncon
    if n:
        con = data.contact
        g1s, g2s, adrs = con.geom1[:n].tolist(), con.geom2[:n].tolist(), con.efc_address[:n].tolist()
        frames, poss = con.frame[:n].tolist(), con.pos[:n].tolist()
        efc = data.efc_force
        for i in range(n):
            a = adrs[i]
            if a < 0:
                continue
            fn, t1, t2 = efc[a : a + 3].tolist()
            fr = frames[i]
            # Force on geom2 in the world: frame^T (fn, t1, t2); on geom1 the opposite.
            fx = fr[0] * fn + fr[3] * t1 + fr[6] * t2
            fy = fr[1] * fn + fr[4] * t1 + fr[7] * t2
            fz = fr[2] * fn + fr[5] * t1 + fr[8] * t2
            ga, gb = g1s[i], g2s[i]
            for g, partner, sign in ((ga, gb, -1.0), (gb, ga, 1.0)):
                k = tip_geom_of[g]
                if k < 0:
                    continue
                fk = f[k]
                fk[0] += sign * fx
                fk[1] += sign * fy
                fk[2] += sign * fz
                w = fn if fn > 1e-9 else 1e-9
                p, ps = poss[i], psum[k]
                ps[0] += w * p[0]
                ps[1] += w * p[1]
                ps[2] += w * p[2]
                weight[k] += w
                if fn > 1e-6:
                    touching[k] = True
                if object_geom[partner]:
                    normal[k] += fn
                    if fn > 1e-6:
                        touching_obj[k] = True
            if object_geom[ga] or object_geom[gb]:
                partner = gb if object_geom[ga] else ga
                if partner == table_geom:
                    table_n += fn
                    on_table = on_table or fn > 1e-9
                elif tip_geom_of[partner] < 0 and not object_geom[partner]:
                    other += fn
    point = np.array([[c / weight[k] for c in psum[k]] if weight[k] > 0 else [0.0, 0.0, 0.0] for k in range(n_tips)])
    return TipContacts(
        np.array(f), np.array(normal), point, np.array(touching), np.array(touching_obj), table_n, on_table, other
    )


def skin_point_and_normal(p_sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The sensor model's skin point nearest ``p_sensor`` and its outward normal (sensor frame):
    a cylinder of SKIN_RADIUS_M about x for PAD_X_MIN_M <= x <= 0, a hemispherical cap for x > 0."""
    x, y, z = (float(v) for v in p_sensor)
    if x > 0.0:
        r = float(np.sqrt(x * x + y * y + z * z))
        u = np.array([x, y, z]) / r if r > 1e-9 else np.array([1.0, 0.0, 0.0])
        return SKIN_RADIUS_M * u, u
    yz = float(np.hypot(y, z))
    ny, nz = (y / yz, z / yz) if yz > 1e-9 else (0.0, -1.0)
    xs = min(max(x, PAD_X_MIN_M), 0.0)
    return np.array([xs, SKIN_RADIUS_M * ny, SKIN_RADIUS_M * nz]), np.array([0.0, ny, nz])
