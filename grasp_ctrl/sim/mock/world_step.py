"""One step of the mock world (arm, servos, contacts, object, sensor frames), as
a kernel over plain arrays that numba compiles when installed (grasp_ctrl/numeric/jit.py).

The model is documented in sim/mock/world.py and docs/mock_world.md. Array layouts:
``c`` holds the constants (indices below), ``obj`` the object's state
(x, y, z, table force, largest normal force, new contacts), per-finger arrays are in
hand-file finger order and per-joint arrays span all fingers.
"""

from __future__ import annotations

import math

import numpy as np

from grasp_ctrl.kinematics.fingertip import skin_contact_point
from grasp_ctrl.kinematics.multilinear import contract
from grasp_ctrl.numeric.jit import njit
from grasp_ctrl.sim.biotac.model import frames_kernel
from grasp_ctrl.sim.mock.grip import friction_limits, solve_object_height, tangential_forces
from grasp_ctrl.sim.mock.shapes import penetration

# Constants (c).
DT, ARM_SPEED, ALPHA, MAX_SERVO_STEP, KP, KT, K_CONTACT, MU, WEIGHT, TORQUE_ON, SKIN_CONTACT, NEAR = range(12)
N_CONSTS = 12
# Object state (obj) and the step's contact events.
OX, OY, OZ, TABLE_N, MAX_NORMAL, NEW_CONTACTS = range(6)


@njit
def _rotate(wx: float, wy: float, wz: float, vx: float, vy: float, vz: float) -> tuple[float, float, float]:
    """(vx, vy, vz) rotated by the rotation vector w (Rodrigues)."""
    theta = math.sqrt(wx * wx + wy * wy + wz * wz)
    if theta < 1e-12:
        return vx, vy, vz
    kx, ky, kz = wx / theta, wy / theta, wz / theta
    cs, sn = math.cos(theta), math.sin(theta)
    dot = (kx * vx + ky * vy + kz * vz) * (1.0 - cs)
    return (
        vx * cs + (ky * vz - kz * vy) * sn + kx * dot,
        vy * cs + (kz * vx - kx * vz) * sn + ky * dot,
        vz * cs + (kx * vy - ky * vx) * sn + kz * dot,
    )


@njit
def _move_arm(palm: np.ndarray, target: np.ndarray, max_step: float) -> None:
    """Straight line toward the target at the speed limit."""
    dx, dy, dz = target[0] - palm[0], target[1] - palm[1], target[2] - palm[2]
    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
    s = 1.0 if dist <= max_step else max_step / dist
    palm[0] += dx * s
    palm[1] += dy * s
    palm[2] += dz * s


@njit
def _move_servos(q_goal: np.ndarray, q_servo: np.ndarray, q: np.ndarray, reach: np.ndarray, c: np.ndarray) -> None:
    """First-order lag toward the goal, speed limited; no torque = limp (stays).
    The servo's internal position cannot run away from the actual one further
    than the current limit allows (current-based position mode)."""
    for j in range(q_servo.shape[0]):
        if c[TORQUE_ON] == 0.0:
            q_servo[j] = q[j]
            continue
        step = c[ALPHA] * (q_goal[j] - q_servo[j])
        step = min(max(step, -c[MAX_SERVO_STEP]), c[MAX_SERVO_STEP])
        q_servo[j] = min(max(q_servo[j] + step, q[j] - reach[j]), q[j] + reach[j])


@njit
def world_step(
    q_goal: np.ndarray,
    palm_target: np.ndarray,
    frame_base: np.ndarray,
    sensor_t: float,
    frame_out: np.ndarray,
    q_servo: np.ndarray,
    q: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    reach: np.ndarray,
    tau_max: np.ndarray,
    starts: np.ndarray,
    counts: np.ndarray,
    palm: np.ndarray,
    take: np.ndarray,
    W: np.ndarray,
    pad_local: np.ndarray,
    contact_local: np.ndarray,
    skin_normal: np.ndarray,
    shape: np.ndarray,
    obj: np.ndarray,
    normal: np.ndarray,
    touch: np.ndarray,
    stick: np.ndarray,
    slip: np.ndarray,
    n_out: np.ndarray,
    contact_z: np.ndarray,
    omega: np.ndarray,
    t_up: np.ndarray,
    f_world: np.ndarray,
    f_sensor: np.ndarray,
    rows: np.ndarray,
    c: np.ndarray,
    sensor_state: np.ndarray,
    gain: np.ndarray,
    sensor_consts: np.ndarray,
) -> None:
    """Advance the world by one control period; the fingertips' raw frames
    (sim/biotac/model.py, built on ``frame_base``) into ``frame_out`` (a new array
    of the caller's, as returning one would cost more: boxing it). The first five
    arguments change from step to step; the rest are the world's own arrays,
    updated in place. ``obj[NEW_CONTACTS]`` flags (bit per finger) the contacts
    made in this step."""
    _move_arm(palm, palm_target, c[ARM_SPEED] * c[DT])
    _move_servos(q_goal, q_servo, q, reach, c)
    contract(q_servo, take, W, rows)
    _contacts(
        q_servo,
        q,
        lower,
        upper,
        tau_max,
        starts,
        counts,
        palm,
        pad_local,
        contact_local,
        skin_normal,
        shape,
        obj,
        normal,
        touch,
        stick,
        n_out,
        contact_z,
        omega,
        rows,
        c,
    )
    _object(obj, normal, touch, stick, slip, n_out, contact_z, t_up, c)
    _forces(normal, touch, n_out, t_up, omega, rows, f_world, f_sensor)
    frame = frames_kernel(
        frame_base,
        contact_local,
        f_sensor,
        skin_normal,
        touch,
        slip,
        sensor_state,
        gain,
        sensor_consts,
        sensor_t,
        c[DT],
    )
    for i in range(frame.shape[0]):
        for k in range(frame.shape[1]):
            frame_out[i, k] = frame[i, k]


@njit
def _skin_facing(row: np.ndarray, nx: float, ny: float, nz: float) -> tuple[float, float, float, float, float, float]:
    """The skin point facing a surface of outward normal n (world) and the skin's outward
    normal there, both sensor frame (``skin_contact_point``): u = R^T (-n) is the pressing
    direction in the sensor frame (R's rows in ``row[0:9]``)."""
    ux = -(row[0] * nx + row[3] * ny + row[6] * nz)
    uy = -(row[1] * nx + row[4] * ny + row[7] * nz)
    uz = -(row[2] * nx + row[5] * ny + row[8] * nz)
    return skin_contact_point(ux, uy, uz)


@njit
def _contacts(
    q_servo: np.ndarray,
    q: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    tau_max: np.ndarray,
    starts: np.ndarray,
    counts: np.ndarray,
    palm: np.ndarray,
    pad_local: np.ndarray,
    contact_local: np.ndarray,
    skin_normal: np.ndarray,
    shape: np.ndarray,
    obj: np.ndarray,
    normal: np.ndarray,
    touch: np.ndarray,
    stick: np.ndarray,
    n_out: np.ndarray,
    contact_z: np.ndarray,
    omega: np.ndarray,
    rows: np.ndarray,
    c: np.ndarray,
) -> None:
    """Normal force per fingertip: the servo spring in series with the contact
    springs, solved in closed form; the deflected joint angles go to ``q``."""
    kp, kt, k = c[KP], c[KT], c[K_CONTACT]
    obj[NEW_CONTACTS] = 0.0
    a = np.empty(8)  # d(penetration)/dq per joint of one finger
    b = np.empty(8)  # d(contact height)/dq
    dq = np.empty(8)
    for j in range(q.shape[0]):
        q[j] = q_servo[j]
    for i in range(rows.shape[0]):
        row = rows[i]
        omega[i, 0] = omega[i, 1] = omega[i, 2] = 0.0
        # The pad centre, or with skin_contact the skin point facing the object there.
        cx, cy, cz = row[9], row[10], row[11]
        if c[SKIN_CONTACT] != 0.0:
            d, nx, ny, nz = penetration(shape, palm[0] + cx - obj[OX], palm[1] + cy - obj[OY], palm[2] + cz - obj[OZ])
            if d > -c[NEAR] and (nx != 0.0 or ny != 0.0 or nz != 0.0):
                px_, py_, pz_, sx, sy, sz = _skin_facing(row, nx, ny, nz)
                contact_local[i, 0], contact_local[i, 1], contact_local[i, 2] = px_, py_, pz_
                skin_normal[i, 0], skin_normal[i, 1], skin_normal[i, 2] = sx, sy, sz
            ex = contact_local[i, 0] - pad_local[0]
            ey = contact_local[i, 1] - pad_local[1]
            ez = contact_local[i, 2] - pad_local[2]
            cx += row[0] * ex + row[1] * ey + row[2] * ez
            cy += row[3] * ex + row[4] * ey + row[5] * ez
            cz += row[6] * ex + row[7] * ey + row[8] * ez
        z_world = palm[2] + cz
        contact_z[i] = z_world
        was = touch[i]
        # A contact that holds stays where it touched the object's surface: the pad's
        # vertical offset from there is skin shear (the stick spring), not sliding. It
        # matters on the cap, whose surface turns away higher up.
        z_on_object = stick[i] if was else z_world - obj[OZ]
        d0, nx, ny, nz = penetration(shape, palm[0] + cx - obj[OX], palm[1] + cy - obj[OY], z_on_object)
        if c[SKIN_CONTACT] != 0.0 and d0 > 0.0:
            # The skin faces the surface that pushes it: the skin point comes again from this
            # contact's own normal, which differs from the one found at the pad centre where
            # the pad is near two surfaces (the mustard bottle's wall and dome) or beyond the
            # near distance of both; otherwise the sensor would feel the force on a skin patch
            # facing elsewhere, outside any friction cone.
            px_, py_, pz_, sx, sy, sz = _skin_facing(row, nx, ny, nz)
            ex = px_ - contact_local[i, 0]
            ey = py_ - contact_local[i, 1]
            ez = pz_ - contact_local[i, 2]
            if abs(ex) + abs(ey) + abs(ez) > 1e-7:
                contact_local[i, 0], contact_local[i, 1], contact_local[i, 2] = px_, py_, pz_
                skin_normal[i, 0], skin_normal[i, 1], skin_normal[i, 2] = sx, sy, sz
                cx += row[0] * ex + row[1] * ey + row[2] * ez
                cy += row[3] * ex + row[4] * ey + row[5] * ez
                cz += row[6] * ex + row[7] * ey + row[8] * ez
                z_world = palm[2] + cz
                contact_z[i] = z_world
                z_on_object = stick[i] if was else z_world - obj[OZ]
                d0, nx, ny, nz = penetration(shape, palm[0] + cx - obj[OX], palm[1] + cy - obj[OY], z_on_object)
        if d0 <= 0.0:
            normal[i] = 0.0
            touch[i] = False
            continue
        start, n = starts[i], counts[i]
        g11 = g12 = g22 = 0.0
        for j in range(n):
            base = 12 + 6 * j
            ax, ay, az = row[base], row[base + 1], row[base + 2]
            rx, ry, rz = cx - row[base + 3], cy - row[base + 4], cz - row[base + 5]
            jx, jy, jz = ay * rz - az * ry, az * rx - ax * rz, ax * ry - ay * rx
            a[j] = -(jx * nx + jy * ny + jz * nz)
            b[j] = jz
            g11 += a[j] * a[j]
            g12 += a[j] * b[j]
            g22 += b[j] * b[j]
        # Vertical stick spring of a contact that already sticks: it resists the pad
        # sliding up or down the object while the finger deflects.
        stretch = z_world - stick[i] - obj[OZ] if was else 0.0
        up, down = friction_limits(normal[i], nz, c[MU])
        sticking = was and -down < kt * stretch < up
        if c[TORQUE_ON] == 0.0 or g11 < 1e-12:
            # A limp finger yields completely: no squeeze force.
            _retract(a, n, g11, d0, dq)
            f_n = 0.0
        else:
            # Servo spring (kp per joint) in series with the contact springs: the
            # minimiser of 0.5*kp*|dq|^2 + 0.5*k*(d0 + a.dq)^2 + 0.5*kt*(s0 + b.dq)^2.
            if sticking:
                # (kp I + D G) y = D r, 2x2, solved in closed form.
                m11, m12, m21, m22 = kp + k * g11, k * g12, kt * g12, kp + kt * g22
                det = m11 * m22 - m12 * m21
                r1, r2 = k * d0, kt * stretch
                y1 = (m22 * r1 - m12 * r2) / det
                y2 = (m11 * r2 - m21 * r1) / det
                for j in range(n):
                    dq[j] = -(a[j] * y1 + b[j] * y2)
            else:
                y = k * d0 / (kp + k * g11)
                for j in range(n):
                    dq[j] = -a[j] * y
            depth = d0
            for j in range(n):
                depth += a[j] * dq[j]
            f_n = k * depth
            over = 0.0
            for j in range(n):
                over = max(over, f_n * abs(a[j]) / max(tau_max[start + j], 1e-9))
            if over > 1.0:  # current limit: the servo yields
                f_n /= over
                _retract(a, n, g11, d0 - f_n / k, dq)
        # The deflection moves the contact and turns the sensor frame, to first order.
        dz = 0.0
        for j in range(n):
            q[start + j] = min(max(q_servo[start + j] + dq[j], lower[start + j]), upper[start + j])
            dz += b[j] * dq[j]
            base = 12 + 6 * j
            omega[i, 0] += row[base] * dq[j]
            omega[i, 1] += row[base + 1] * dq[j]
            omega[i, 2] += row[base + 2] * dq[j]
        contact_z[i] = z_world + dz
        normal[i] = f_n
        n_out[i, 0], n_out[i, 1], n_out[i, 2] = nx, ny, nz
        touch[i] = f_n > 1e-6
        if touch[i] and not was:
            stick[i] = z_world - obj[OZ]
            obj[NEW_CONTACTS] += 2.0**i


@njit
def _retract(a: np.ndarray, n: int, a2: float, depth: float, dq: np.ndarray) -> None:
    """Smallest joint motion that backs a fingertip out of the object by ``depth``."""
    for j in range(n):
        dq[j] = -(depth / a2) * a[j] if a2 > 1e-12 else 0.0


@njit
def _object(
    obj: np.ndarray,
    normal: np.ndarray,
    touch: np.ndarray,
    stick: np.ndarray,
    slip: np.ndarray,
    n_out: np.ndarray,
    contact_z: np.ndarray,
    t_up: np.ndarray,
    c: np.ndarray,
) -> None:
    """The object's height: friction of the contacts against its weight and the table."""
    F = normal.shape[0]
    cap_up = np.zeros(F)
    cap_down = np.zeros(F)
    anchors = np.empty(F)
    load = c[WEIGHT]
    for i in range(F):
        if touch[i]:
            cap_up[i], cap_down[i] = friction_limits(normal[i], n_out[i, 2], c[MU])
        anchors[i] = contact_z[i] - stick[i]
        if touch[i]:
            # A contact on a tilted surface (the cap) also pushes the object down
            # with the vertical part of its normal force.
            load += normal[i] * n_out[i, 2]
    z, table_n = solve_object_height(anchors, cap_up, cap_down, c[KT], load)
    forces, slipping = tangential_forces(anchors, cap_up, cap_down, c[KT], z)
    largest = 0.0
    for i in range(F):
        # Slipping contacts drag their anchor: the spring stays at the friction limit.
        if slipping[i] and touch[i]:
            new = contact_z[i] - (z + forces[i] / c[KT])
            slip[i] = abs(new - stick[i]) / c[DT]
            stick[i] = new
        else:
            slip[i] = 0.0
        t_up[i] = forces[i] if touch[i] else 0.0
        largest = max(largest, normal[i])
    obj[OZ] = z
    obj[TABLE_N] = table_n
    obj[MAX_NORMAL] = largest


@njit
def _forces(
    normal: np.ndarray,
    touch: np.ndarray,
    n_out: np.ndarray,
    t_up: np.ndarray,
    omega: np.ndarray,
    rows: np.ndarray,
    f_world: np.ndarray,
    f_sensor: np.ndarray,
) -> None:
    """Force ON each fingertip skin: the object pushes the pad outward and drags it
    opposite to the finger's upward force on the object; world and sensor frames."""
    for i in range(normal.shape[0]):
        if not touch[i]:
            for k in range(3):
                f_world[i, k] = 0.0
                f_sensor[i, k] = 0.0
            continue
        fx = normal[i] * n_out[i, 0]
        fy = normal[i] * n_out[i, 1]
        fz = normal[i] * n_out[i, 2] - t_up[i]
        f_world[i, 0], f_world[i, 1], f_world[i, 2] = fx, fy, fz
        # f_sensor = (Rot(omega) R)^T f = R^T Rot(-omega) f, R the sensor frame at the servo angles.
        vx, vy, vz = _rotate(-omega[i, 0], -omega[i, 1], -omega[i, 2], fx, fy, fz)
        r = rows[i]
        f_sensor[i, 0] = r[0] * vx + r[3] * vy + r[6] * vz
        f_sensor[i, 1] = r[1] * vx + r[4] * vy + r[7] * vz
        f_sensor[i, 2] = r[2] * vx + r[5] * vy + r[8] * vz
