"""Least-squares pusher force (paper eq. 9):

    argmin_fc  k ||f_c + f_f - m a||^2 + ||c x f_c + n_f - I alpha||^2

It is linear in f_c (c x f_c = [-c_y, c_x] . f_c), so it has a closed form;
SLSQP (scipy) solves the same problem numerically as a cross-check. f_c is the
force of the pusher ON the object, world plane; c is the contact point
relative to the centre of mass, rotated into the world plane.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from grasp_ctrl.pushing.box import PushedBox
from grasp_ctrl.pushing.kinematics import PlanarMotion
from grasp_ctrl.pushing.particles import footprint_particles, friction_force_moment, rotate2

METHODS = ("closed-form", "slsqp")


@dataclass(frozen=True)
class PushForces:
    t: np.ndarray
    f_world: np.ndarray  # (s, 2) N, NaN where undefined
    f_object: np.ndarray  # (s, 2) N, object frame
    moving: np.ndarray  # (s,) bool


@dataclass(frozen=True)
class Problem:
    """Per-sample data of the least-squares problem (world plane)."""

    b_lin: np.ndarray  # (s, 2) m a - f_f
    b_rot: np.ndarray  # (s,)   I alpha - n_f
    c_perp: np.ndarray  # (s, 2) [-c_y, c_x]
    k: float


def build_problem(
    motion: PlanarMotion, contact_object: np.ndarray, box: PushedBox, n_particles: int = 80, k: float = 10.0
) -> Problem:
    particles = footprint_particles(box.size_m, n_particles)
    f_f, n_f = friction_force_moment(motion.v, motion.omega, motion.theta, particles, box.mass_kg, box.mu, box.gravity)
    c_world = rotate2(motion.theta, np.asarray(contact_object, dtype=float))
    return Problem(
        b_lin=box.mass_kg * motion.a - f_f,
        b_rot=box.inertia * motion.alpha - n_f,
        c_perp=np.column_stack([-c_world[:, 1], c_world[:, 0]]),
        k=k,
    )


def solve_closed_form(p: Problem) -> np.ndarray:
    """Normal equations (k I + c c^T) f = k b_lin + c b_rot, a 2x2 system per sample."""
    c = p.c_perp
    a11 = p.k + c[:, 0] ** 2
    a22 = p.k + c[:, 1] ** 2
    a12 = c[:, 0] * c[:, 1]
    r1 = p.k * p.b_lin[:, 0] + c[:, 0] * p.b_rot
    r2 = p.k * p.b_lin[:, 1] + c[:, 1] * p.b_rot
    det = a11 * a22 - a12 * a12  # >= k^2 > 0
    return np.column_stack([(a22 * r1 - a12 * r2) / det, (a11 * r2 - a12 * r1) / det])


def solve_slsqp(p: Problem) -> np.ndarray:
    """The same problem by Sequential Least Squares Programming, one sample at a time."""
    out = np.empty((len(p.b_rot), 2))
    for i in range(len(p.b_rot)):
        b, br, c = p.b_lin[i], p.b_rot[i], p.c_perp[i]

        def cost(f: np.ndarray) -> float:
            e = f - b
            r = c @ f - br
            return float(p.k * (e @ e) + r * r)

        def grad(f: np.ndarray) -> np.ndarray:
            return 2.0 * p.k * (f - b) + 2.0 * (c @ f - br) * c

        res = minimize(cost, x0=b.copy(), jac=grad, method="SLSQP", options={"ftol": 1e-16, "maxiter": 200})
        out[i] = res.x
    return out


def moving_mask(motion: PlanarMotion, box: PushedBox, speed_threshold: float) -> np.ndarray:
    """Kinetic friction is only defined while the object slides: the CM or a
    footprint corner moves faster than ``speed_threshold`` (m/s)."""
    corner = 0.5 * float(np.hypot(*box.size_m))
    return (np.linalg.norm(motion.v, axis=1) > speed_threshold) | (np.abs(motion.omega) * corner > speed_threshold)


def pusher_forces(
    motion: PlanarMotion,
    contact_object: np.ndarray,
    in_contact: np.ndarray,
    box: PushedBox,
    method: str = "closed-form",
    n_particles: int = 80,
    k: float = 10.0,
    speed_threshold: float = 0.01,
) -> PushForces:
    """Pusher force per sample; NaN where there is no contact or the box is static."""
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)} (got {method!r})")
    moving = moving_mask(motion, box, speed_threshold)
    valid = moving & np.asarray(in_contact, dtype=bool)
    f_world = np.full((len(motion.t), 2), np.nan)
    if np.any(valid):
        sub = PlanarMotion(*(getattr(motion, f)[valid] for f in ("t", "theta", "v", "a", "omega", "alpha")))
        prob = build_problem(sub, np.asarray(contact_object)[valid], box, n_particles, k)
        f_world[valid] = solve_closed_form(prob) if method == "closed-form" else solve_slsqp(prob)
    f_object = rotate2(-motion.theta, f_world)
    return PushForces(t=motion.t, f_world=f_world, f_object=f_object, moving=moving)


def plane_force_to_sensor(f_plane_world: np.ndarray, r_world_sensor: np.ndarray) -> np.ndarray:
    """The 3D label f_3d = R f_c in the sensor frame: the force ON the sensor skin
    (docs/design.md 4) is the reaction -f_c of the pusher force, rotated by
    R_sensor_world = R_world_sensor^T. r_world_sensor: (s, 3, 3) or (3, 3)."""
    f3 = np.zeros(f_plane_world.shape[:-1] + (3,))
    f3[..., :2] = -f_plane_world
    r = np.asarray(r_world_sensor, dtype=float)
    if r.ndim == 2:
        return f3 @ r  # (R^T f)^T = f^T R
    return np.einsum("sji,sj->si", r, f3)
