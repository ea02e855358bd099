"""From MuJoCo's solved contacts to the BioTac model's inputs and frames, in one compiled call
per tick (``mj_tick_frames``; the MuJoCo world calls it, sim/mujoco/world.py).

The contact sums follow the reference reading of MuJoCo's contacts (tests/mujoco_contacts_reference.py:
``read_contacts`` and ``skin_point_and_normal``) term for term, checked bit for bit by
tests/sim/test_mujoco_lean.py; the 3x3 products are summed left to right from 0.0 (the same bits on
any CPU, as numeric/vec3.py).
"""

from __future__ import annotations

import math

import numpy as np

from grasp_ctrl.kinematics.fingertip import PAD_X_MIN_M, SKIN_RADIUS_M
from grasp_ctrl.numeric.jit import njit
from grasp_ctrl.sim.biotac.model import frames_kernel

# ``mj_tick_frames`` reads and writes per-fingertip arrays packed into two buffers (fewer
# arguments: each costs the call time). ``tip_f`` (floats): for F fingertips, blocks at these
# offsets (in units of F) of the force ON the skin, world and sensor frame (N), the skin contact
# point and outward normal (sensor frame, m), the object's normal force (N) and the slip speed
# (m/s), then N_SUMS sums. ``tip_b`` (bools): touching anything, touching the object, newly so.
TIP_F_WORLD, TIP_F_SENSOR, TIP_CONTACT, TIP_SKIN_NORMAL, TIP_NORMAL, TIP_SLIP, TIP_FLOATS = 0, 3, 6, 9, 12, 13, 14
TIP_TOUCHING, TIP_TOUCHING_OBJECT, TIP_NEW_CONTACT, TIP_BOOLS = 0, 1, 2, 3
#: The sums after the blocks: the table's normal force on the object (N), whether it stands on
#: the table (1.0 or 0.0), the other hand links' normal force on it (N) and its peak so far
#: (kept across calls), the flags below.
SUM_TABLE_N, SUM_ON_TABLE, SUM_OTHER_N, SUM_PEAK_OTHER_N, SUM_FLAGS, N_SUMS = range(6)
#: The flags: some fingertip touches anything / the object / newly the object.
TOUCHING, TOUCHING_OBJECT, NEW_CONTACT = 1, 2, 4
#: ``geom_kind`` of a geom that is no fingertip's: the object's, or anything else.
GEOM_OBJECT, GEOM_OTHER = -2, -1


def mj_tip_buffers(n_tips: int) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """``tip_f`` and ``tip_b`` for ``n_tips`` fingertips, zeroed, and their blocks as named
    views ((F, 3) or (F,), C-contiguous; ``sums``: the N_SUMS sums)."""
    n = n_tips
    tip_f = np.zeros(TIP_FLOATS * n + N_SUMS)
    tip_b = np.zeros(TIP_BOOLS * n, dtype=np.bool_)
    views = {
        "f_world": tip_f[TIP_F_WORLD * n : (TIP_F_WORLD + 3) * n].reshape(n, 3),
        "f_sensor": tip_f[TIP_F_SENSOR * n : (TIP_F_SENSOR + 3) * n].reshape(n, 3),
        "contact": tip_f[TIP_CONTACT * n : (TIP_CONTACT + 3) * n].reshape(n, 3),
        "skin_normal": tip_f[TIP_SKIN_NORMAL * n : (TIP_SKIN_NORMAL + 3) * n].reshape(n, 3),
        "normal": tip_f[TIP_NORMAL * n : (TIP_NORMAL + 1) * n],
        "slip": tip_f[TIP_SLIP * n : (TIP_SLIP + 1) * n],
        "sums": tip_f[TIP_FLOATS * n :],
        "touching": tip_b[TIP_TOUCHING * n : (TIP_TOUCHING + 1) * n],
        "touching_object": tip_b[TIP_TOUCHING_OBJECT * n : (TIP_TOUCHING_OBJECT + 1) * n],
        "new_contact": tip_b[TIP_NEW_CONTACT * n : (TIP_NEW_CONTACT + 1) * n],
    }
    return tip_f, tip_b, views


@njit
def mj_skin_point(
    x: float, y: float, z: float, skin_radius: float, pad_x_min: float
) -> tuple[float, float, float, float, float, float]:
    """skin_point_and_normal (tests/mujoco_contacts_reference.py): the skin point nearest (x, y, z) (sensor
    frame) and its outward normal, as six floats."""
    if x > 0.0:
        r = math.sqrt(x * x + y * y + z * z)
        if r > 1e-9:
            nx, ny, nz = x / r, y / r, z / r
        else:
            nx, ny, nz = 1.0, 0.0, 0.0
        return skin_radius * nx, skin_radius * ny, skin_radius * nz, nx, ny, nz
    yz = float(np.hypot(y, z))  # libm's hypot, as numpy's
    if yz > 1e-9:
        ny, nz = y / yz, z / yz
    else:
        ny, nz = 0.0, -1.0
    # min(max(x, pad_x_min), 0.0) with Python's choice on ties (the sign of a zero)
    px = pad_x_min if pad_x_min > x else x
    if 0.0 < px:
        px = 0.0
    return px, skin_radius * ny, skin_radius * nz, 0.0, ny, nz


@njit
def mj_body_velocity(
    body: int, cvel: np.ndarray, xipos: np.ndarray, subtree_com: np.ndarray, body_rootid: np.ndarray
) -> tuple[float, float, float, float, float, float]:
    """MuJoCo's ``mj_objectVelocity(m, d, mjOBJ_BODY, body, res, 0)``: the body's ``cvel`` (at its
    tree's centre of mass) moved to its centre of mass ``xipos``, as mju_transformSpatial does
    it: (w, v - (xipos - subtree_com) x w)."""
    root = body_rootid[body]
    dx = xipos[body, 0] - subtree_com[root, 0]
    dy = xipos[body, 1] - subtree_com[root, 1]
    dz = xipos[body, 2] - subtree_com[root, 2]
    wx, wy, wz = cvel[body, 0], cvel[body, 1], cvel[body, 2]
    return (
        wx,
        wy,
        wz,
        cvel[body, 3] - (dy * wz - dz * wy),
        cvel[body, 4] - (dz * wx - dx * wz),
        cvel[body, 5] - (dx * wy - dy * wx),
    )


@njit
def mj_tick_frames(
    geom: np.ndarray,
    efc_address: np.ndarray,
    frame: np.ndarray,
    pos: np.ndarray,
    efc_force: np.ndarray,
    geom_kind: np.ndarray,
    ids: np.ndarray,
    body_rootid: np.ndarray,
    site_xmat: np.ndarray,
    site_xpos: np.ndarray,
    cvel: np.ndarray,
    xipos: np.ndarray,
    subtree_com: np.ndarray,
    xpos: np.ndarray,
    tip_f: np.ndarray,
    tip_b: np.ndarray,
    noisy_base: np.ndarray,
    state: np.ndarray,
    gain: np.ndarray,
    consts: np.ndarray,
    t: float,
    dt: float,
) -> np.ndarray:
    """The fingertips' contacts of this step, in place, and their frames (frames_kernel's from
    ``noisy_base`` .. ``dt``, which it returns). ``geom`` .. ``pos`` are MuJoCo's ``data.contact``
    fields, ``geom_kind[g]`` geom g's fingertip, GEOM_OBJECT or GEOM_OTHER; ``ids``: the table's
    geom, the object's body, the sensors' sites (F), the fingertips' bodies (F); ``site_xmat``
    .. ``xpos``: MuJoCo's data arrays of those names. Writes into ``tip_f`` and ``tip_b`` (see
    TIP_F_WORLD) per fingertip the force ON the skin (world and sensor frame), the normal force
    from the object, the touch flags and new touches of the object and, where it touches, the
    skin point and normal (sensor frame) at the force-weighted contact point and the skin's
    slip speed over the object (0 elsewhere); then the sums SUM_TABLE_N .. SUM_FLAGS."""
    n_tips = tip_b.shape[0] // TIP_BOOLS
    f_world = tip_f[TIP_F_WORLD * n_tips : (TIP_F_WORLD + 3) * n_tips].reshape((n_tips, 3))
    f_sensor = tip_f[TIP_F_SENSOR * n_tips : (TIP_F_SENSOR + 3) * n_tips].reshape((n_tips, 3))
    contact_sensor = tip_f[TIP_CONTACT * n_tips : (TIP_CONTACT + 3) * n_tips].reshape((n_tips, 3))
    skin_normal = tip_f[TIP_SKIN_NORMAL * n_tips : (TIP_SKIN_NORMAL + 3) * n_tips].reshape((n_tips, 3))
    normal_n = tip_f[TIP_NORMAL * n_tips : (TIP_NORMAL + 1) * n_tips]
    slip = tip_f[TIP_SLIP * n_tips : (TIP_SLIP + 1) * n_tips]
    sums = tip_f[TIP_FLOATS * n_tips :]
    touching = tip_b[TIP_TOUCHING * n_tips : (TIP_TOUCHING + 1) * n_tips]
    touching_obj = tip_b[TIP_TOUCHING_OBJECT * n_tips : (TIP_TOUCHING_OBJECT + 1) * n_tips]
    new_contacts = tip_b[TIP_NEW_CONTACT * n_tips : (TIP_NEW_CONTACT + 1) * n_tips]
    table, obj_body = ids[0], ids[1]
    sites, tip_bodies = ids[2 : 2 + n_tips], ids[2 + n_tips : 2 + 2 * n_tips]
    n_tips = f_world.shape[0]
    psum = np.zeros((n_tips, 3))
    weight = np.zeros(n_tips)
    for k in range(n_tips):
        new_contacts[k] = touching_obj[k]  # was touching the object: compared below
        f_world[k, 0] = 0.0
        f_world[k, 1] = 0.0
        f_world[k, 2] = 0.0
        normal_n[k] = 0.0
        touching[k] = False
        touching_obj[k] = False
    table_n = 0.0
    on_table = False
    other = 0.0
    for i in range(geom.shape[0]):
        a = efc_address[i]
        if a < 0:
            continue
        fn = efc_force[a]
        t1 = efc_force[a + 1]
        t2 = efc_force[a + 2]
        # Force on geom2 in the world: frame^T (fn, t1, t2); on geom1 the opposite.
        fx = frame[i, 0] * fn + frame[i, 3] * t1 + frame[i, 6] * t2
        fy = frame[i, 1] * fn + frame[i, 4] * t1 + frame[i, 7] * t2
        fz = frame[i, 2] * fn + frame[i, 5] * t1 + frame[i, 8] * t2
        ga = geom[i, 0]
        gb = geom[i, 1]
        for side in range(2):
            g, partner, sign = (ga, gb, -1.0) if side == 0 else (gb, ga, 1.0)
            k = geom_kind[g]
            if k < 0:
                continue
            f_world[k, 0] += sign * fx
            f_world[k, 1] += sign * fy
            f_world[k, 2] += sign * fz
            w = fn if fn > 1e-9 else 1e-9
            psum[k, 0] += w * pos[i, 0]
            psum[k, 1] += w * pos[i, 1]
            psum[k, 2] += w * pos[i, 2]
            weight[k] += w
            if fn > 1e-6:
                touching[k] = True
            if geom_kind[partner] == GEOM_OBJECT:
                normal_n[k] += fn
                if fn > 1e-6:
                    touching_obj[k] = True
        if geom_kind[ga] == GEOM_OBJECT or geom_kind[gb] == GEOM_OBJECT:
            partner = gb if geom_kind[ga] == GEOM_OBJECT else ga
            if partner == table:
                table_n += fn
                on_table = on_table or fn > 1e-9
            elif geom_kind[partner] == GEOM_OTHER:
                other += fn
    sums[SUM_TABLE_N] = table_n
    sums[SUM_ON_TABLE] = 1.0 if on_table else 0.0
    sums[SUM_OTHER_N] = other
    if other > sums[SUM_PEAK_OTHER_N]:
        sums[SUM_PEAK_OTHER_N] = other
    flags = 0
    ow0 = ow1 = ow2 = ov3 = ov4 = ov5 = 0.0
    for k in range(n_tips):
        s = sites[k]
        R = site_xmat[s]  # row-major 3x3
        for c in range(3):  # R^T f
            f_sensor[k, c] = 0.0 + R[c] * f_world[k, 0] + R[3 + c] * f_world[k, 1] + R[6 + c] * f_world[k, 2]
        new_contacts[k] = touching_obj[k] and not new_contacts[k]
        if new_contacts[k]:
            flags |= NEW_CONTACT
        if not touching[k]:
            slip[k] = 0.0
            continue
        flags |= TOUCHING
        ox, oy, oz = site_xpos[s, 0], site_xpos[s, 1], site_xpos[s, 2]
        vx = psum[k, 0] / weight[k] - ox
        vy = psum[k, 1] / weight[k] - oy
        vz = psum[k, 2] / weight[k] - oz
        px, py, pz, nx, ny, nz = mj_skin_point(
            0.0 + R[0] * vx + R[3] * vy + R[6] * vz,
            0.0 + R[1] * vx + R[4] * vy + R[7] * vz,
            0.0 + R[2] * vx + R[5] * vy + R[8] * vz,
            SKIN_RADIUS_M,
            PAD_X_MIN_M,
        )
        contact_sensor[k, 0] = px
        contact_sensor[k, 1] = py
        contact_sensor[k, 2] = pz
        skin_normal[k, 0] = nx
        skin_normal[k, 1] = ny
        skin_normal[k, 2] = nz
        if not touching_obj[k]:
            slip[k] = 0.0
            continue
        if not flags & TOUCHING_OBJECT:
            flags |= TOUCHING_OBJECT
            ow0, ow1, ow2, ov3, ov4, ov5 = mj_body_velocity(obj_body, cvel, xipos, subtree_com, body_rootid)
        # The skin point and normal in the world: R p + o, R n.
        wpx = (0.0 + R[0] * px + R[1] * py + R[2] * pz) + ox
        wpy = (0.0 + R[3] * px + R[4] * py + R[5] * pz) + oy
        wpz = (0.0 + R[6] * px + R[7] * py + R[8] * pz) + oz
        wnx = 0.0 + R[0] * nx + R[1] * ny + R[2] * nz
        wny = 0.0 + R[3] * nx + R[4] * ny + R[5] * nz
        wnz = 0.0 + R[6] * nx + R[7] * ny + R[8] * nz
        # Slip: the skin's velocity less the object's at that point, its tangential part. Each
        # body's velocity is mj_objectVelocity's, taken about its frame origin ``xpos`` (as the
        # world has always done).
        b = tip_bodies[k]
        w0, w1, w2, v3, v4, v5 = mj_body_velocity(b, cvel, xipos, subtree_com, body_rootid)
        rx, ry, rz = wpx - xpos[b, 0], wpy - xpos[b, 1], wpz - xpos[b, 2]
        rel0 = 0.0 + 1.0 * (v3 + w1 * rz - w2 * ry)
        rel1 = 0.0 + 1.0 * (v4 + w2 * rx - w0 * rz)
        rel2 = 0.0 + 1.0 * (v5 + w0 * ry - w1 * rx)
        rx, ry, rz = wpx - xpos[obj_body, 0], wpy - xpos[obj_body, 1], wpz - xpos[obj_body, 2]
        rel0 += -1.0 * (ov3 + ow1 * rz - ow2 * ry)
        rel1 += -1.0 * (ov4 + ow2 * rx - ow0 * rz)
        rel2 += -1.0 * (ov5 + ow0 * ry - ow1 * rx)
        along = 0.0 + ((rel0 * wnx + rel1 * wny) + rel2 * wnz)
        tx, ty, tz = rel0 - along * wnx, rel1 - along * wny, rel2 - along * wnz
        slip[k] = math.sqrt(0.0 + ((tx * tx + ty * ty) + tz * tz))
    sums[SUM_FLAGS] = flags
    return frames_kernel(noisy_base, contact_sensor, f_sensor, skin_normal, touching, slip, state, gain, consts, t, dt)
