"""Fingertip and table contacts read from MuJoCo's solver, for the BioTac model and the judge.

With elliptic friction cones MuJoCo's contact force of contact ``i`` is
``efc_force[efc_address[i] : +3]`` in the contact frame (normal, two tangents;
what ``mj_contactForce`` returns); the frame's first row is the normal from
geom1 to geom2 and the force acts on geom2 along it (on geom1 opposite).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasp_ctrl.kinematics.fingertip import PAD_X_MIN_M, SKIN_RADIUS_M


@dataclass
class TipContacts:
    """Per fingertip, this step: force ON the skin (world), normal force from the object,
    the force-weighted contact point (world) and whether anything touches it."""
    f_world: np.ndarray          # (F, 3)
    normal_from_object_n: np.ndarray   # (F,)
    point_world: np.ndarray      # (F, 3)
    touching: np.ndarray         # (F,) bool
    touching_object: np.ndarray  # (F,) bool
    table_normal_on_object_n: float
    object_on_table: bool
    other_hand_on_object_n: float      # normal force of hand links (not the fingertips) on the object


def read_contacts(model, data, tip_geom_of: np.ndarray, object_geom: np.ndarray, table_geom: int,
                  n_tips: int) -> TipContacts:
    """``tip_geom_of[g]``: fingertip index of geom g or -1; ``object_geom[g]``: whether geom g
    is the object's; ``table_geom``: the table's geom id. Hand geoms are contype 2."""
    f_world = np.zeros((n_tips, 3))
    normal = np.zeros(n_tips)
    point_sum = np.zeros((n_tips, 3))
    weight = np.zeros(n_tips)
    touching = np.zeros(n_tips, dtype=bool)
    touching_obj = np.zeros(n_tips, dtype=bool)
    table_n = 0.0
    on_table = False
    other = 0.0
    n = data.ncon
    if n == 0:
        return TipContacts(f_world, normal, point_sum, touching, touching_obj, 0.0, False, 0.0)
    con = data.contact
    g1, g2 = con.geom1[:n], con.geom2[:n]
    adr = con.efc_address[:n]
    efc = data.efc_force
    frames = con.frame[:n].reshape(n, 3, 3)
    pos = con.pos[:n]
    for i in range(n):
        a = int(adr[i])
        if a < 0:
            continue
        fc = efc[a:a + 3]
        f2 = frames[i].T @ fc          # force on geom2, world frame
        fn = float(fc[0])
        ga, gb = int(g1[i]), int(g2[i])
        for g, other_g, f_on_g in ((ga, gb, -f2), (gb, ga, f2)):
            k = int(tip_geom_of[g])
            if k >= 0:
                f_world[k] += f_on_g
                w = max(fn, 1e-9)
                point_sum[k] += w * pos[i]
                weight[k] += w
                touching[k] |= fn > 1e-6
                if object_geom[other_g]:
                    normal[k] += fn
                    touching_obj[k] |= fn > 1e-6
        if object_geom[ga] or object_geom[gb]:
            partner = gb if object_geom[ga] else ga
            if partner == table_geom:
                table_n += fn
                on_table = on_table or fn > 1e-9
            elif tip_geom_of[partner] < 0 and not object_geom[partner]:
                other += fn
    has = weight > 0
    point = np.zeros((n_tips, 3))
    point[has] = point_sum[has] / weight[has, None]
    return TipContacts(f_world, normal, point, touching, touching_obj, table_n, on_table, other)


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
