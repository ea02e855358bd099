"""Simulated pushes with a known pusher force, for tests and synthetic data.

Inverse dynamics: a smooth planar trajectory of the box is chosen (speed
profile with rest phases, a slow yaw change); friction comes from a FINE
particle grid (the solver uses a coarser one), the pusher force from
f_c = m a - f_f, and the contact point on the pushed face (object x = -lx/2)
from the moment balance c x f_c = I alpha - n_f. The result is exactly
consistent with the physics of paper eqs. (1)-(8), so the solver's error is
only its own discretisation, differentiation and the tracking noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasp_ctrl.pushing.box import PushedBox
from grasp_ctrl.pushing.particles import cross2, footprint_particles, friction_force_moment, rotate2

PAPER_BOX = PushedBox(mass_kg=0.65, size_m=(0.12, 0.16), mu=0.1)


@dataclass(frozen=True)
class SimulatedPush:
    t: np.ndarray  # (s,) s
    x: np.ndarray  # (s,) m, true CM
    y: np.ndarray
    theta: np.ndarray  # (s,) rad
    contact_object: np.ndarray  # (s, 2) m, contact point relative to the CM, object frame
    in_contact: np.ndarray  # (s,) bool
    f_world_true: np.ndarray  # (s, 2) N, pusher force on the object (0 when not in contact)

    def tracked(self, rng: np.random.Generator, pos_noise_m: float, yaw_noise_rad: float) -> SimulatedPush:
        """The same push as a tracker would report it (Gaussian pose noise)."""
        s = len(self.t)
        return SimulatedPush(
            t=self.t,
            x=self.x + pos_noise_m * rng.standard_normal(s),
            y=self.y + pos_noise_m * rng.standard_normal(s),
            theta=self.theta + yaw_noise_rad * rng.standard_normal(s),
            contact_object=self.contact_object,
            in_contact=self.in_contact,
            f_world_true=self.f_world_true,
        )


def _smoothstep(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Quintic 0->1 ramp and its derivative in u (zero slope and curvature at both ends)."""
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u * u), 30 * u * u * (1 - u) ** 2


def simulate_push(
    rng: np.random.Generator,
    box: PushedBox = PAPER_BOX,
    rate_hz: float = 100.0,
    true_particles: int = 2500,
    max_tries: int = 50,
) -> SimulatedPush:
    """One push: rest, accelerate, cruise, decelerate, rest; a random heading,
    speed and yaw change. Retries until the contact stays on the pushed face
    and the pusher only pushes (never pulls)."""
    for _ in range(max_tries):
        push = _try_push(rng, box, rate_hz, true_particles)
        if push is not None:
            return push
    raise RuntimeError("could not generate a feasible push; check the box parameters")


def _try_push(rng: np.random.Generator, box: PushedBox, rate_hz: float, true_particles: int) -> SimulatedPush | None:
    lx, ly = box.size_m
    t_rest0, t_rest1 = rng.uniform(0.2, 0.5), rng.uniform(0.2, 0.5)
    t_acc, t_cruise, t_dec = rng.uniform(0.3, 0.8), rng.uniform(0.0, 1.0), rng.uniform(0.5, 1.0)
    v_max = rng.uniform(0.03, 0.25)
    dtheta = rng.uniform(-0.25, 0.25)  # yaw change over the whole push
    phi = rng.uniform(-0.1, 0.1)  # heading offset from the object x axis
    theta0 = rng.uniform(-np.pi, np.pi)
    total = t_rest0 + t_acc + t_cruise + t_dec + t_rest1

    # fine time grid for integrating the position, then sample at rate_hz
    fine = 1000.0
    tf = np.arange(0.0, total, 1.0 / fine)
    up, dup = _smoothstep((tf - t_rest0) / t_acc)
    down, ddown = _smoothstep((tf - t_rest0 - t_acc - t_cruise) / t_dec)
    speed = v_max * (up - down)
    dspeed = v_max * (dup / t_acc - ddown / t_dec)
    dist = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) / fine)])
    s_total = dist[-1]
    theta = theta0 + dtheta * dist / s_total
    omega = dtheta * speed / s_total
    alpha = dtheta * dspeed / s_total
    heading = theta + phi
    u = np.column_stack([np.cos(heading), np.sin(heading)])
    u_perp = np.column_stack([-np.sin(heading), np.cos(heading)])
    v = speed[:, None] * u
    a = dspeed[:, None] * u + (speed * omega)[:, None] * u_perp
    pos = np.column_stack([np.concatenate([[0.0], np.cumsum(0.5 * (v[1:, i] + v[:-1, i]) / fine)]) for i in range(2)])

    step = int(round(fine / rate_hz))
    idx = np.arange(0, len(tf), step)
    moving = speed[idx] > 1e-6
    fine_particles = footprint_particles(box.size_m, true_particles)
    f_f, n_f = friction_force_moment(v[idx], omega[idx], theta[idx], fine_particles, box.mass_kg, box.mu, box.gravity)
    f_world = np.where(moving[:, None], box.mass_kg * a[idx] - f_f, 0.0)
    moment = box.inertia * alpha[idx] - n_f
    f_obj = rotate2(-theta[idx], f_world)
    c = np.zeros((len(idx), 2))
    c[:, 0] = -lx / 2
    m = moving
    if np.any(f_obj[m, 0] <= 1e-3):
        return None  # would need to pull the box
    # c x f = c_x f_y - c_y f_x = moment  ->  c_y
    c[m, 1] = (c[m, 0] * f_obj[m, 1] - moment[m]) / f_obj[m, 0]
    if np.any(np.abs(c[m, 1]) > 0.4 * ly):
        return None  # contact would leave the face
    # at rest the pusher keeps the point where motion starts/ends
    first, last = np.argmax(m), len(m) - 1 - np.argmax(m[::-1])
    c[:first, 1] = c[first, 1]
    c[last + 1 :, 1] = c[last, 1]
    assert np.allclose(cross2(rotate2(theta[idx][m], c[m]), f_world[m]), moment[m], atol=1e-9)
    return SimulatedPush(
        t=tf[idx],
        x=pos[idx, 0],
        y=pos[idx, 1],
        theta=theta[idx],
        contact_object=c,
        in_contact=moving.copy(),
        f_world_true=f_world,
    )
