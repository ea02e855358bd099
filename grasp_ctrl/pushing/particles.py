"""Coulomb friction of a rigid footprint made of n particles (paper eqs. 7-8).

Uniform pressure: every particle carries m g / n of the normal load. Friction
opposes each particle's velocity ``v + omega x r_i``; all vectors are in the
world plane (the particle offsets are rotated by the object's yaw).
"""

from __future__ import annotations

import math

import numpy as np

# Below this particle speed the direction of sliding is undefined; the particle
# contributes no kinetic friction (static samples are flagged before this matters).
_SPEED_EPS = 1e-9


def footprint_particles(size_m: tuple[float, float], n: int) -> np.ndarray:
    """(k, 2) particle centres on a regular grid over the lx x ly rectangle,
    object frame, centred on the centre of mass; k is the grid closest to n
    with near-square cells (k == n whenever n factors that way, e.g. 80 = 10 x 8)."""
    if n < 1:
        raise ValueError("need at least one particle")
    lx, ly = size_m
    best: tuple[float, int, int] | None = None
    for nx in range(1, n + 1):
        ny = max(1, round(n / nx))
        # prefer exact counts, then square cells
        cost = abs(nx * ny - n) * 10.0 + abs(math.log((lx / nx) / (ly / ny)))
        if best is None or cost < best[0]:
            best = (cost, nx, ny)
    assert best is not None
    _, nx, ny = best
    xs = (np.arange(nx) + 0.5) / nx * lx - lx / 2
    ys = (np.arange(ny) + 0.5) / ny * ly - ly / 2
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    return np.column_stack([gx.ravel(), gy.ravel()])


def rotate2(theta: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """Rotate vectors by yaw theta. theta (s,), vec (s, 2) or (s, k, 2)."""
    c, s = np.cos(theta), np.sin(theta)
    if vec.ndim == 2:
        return np.column_stack([c * vec[:, 0] - s * vec[:, 1], s * vec[:, 0] + c * vec[:, 1]])
    c, s = c[:, None], s[:, None]
    return np.stack([c * vec[..., 0] - s * vec[..., 1], s * vec[..., 0] + c * vec[..., 1]], axis=-1)


def cross2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z component of the 3D cross product of planar vectors."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def friction_force_moment(
    v_world: np.ndarray,
    omega: np.ndarray,
    theta: np.ndarray,
    particles_object: np.ndarray,
    mass_kg: float,
    mu: float,
    gravity: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Friction force f_f (s, 2) [N, world] and moment n_f (s,) [N m, about the CM].

    v_world (s, 2) CM velocity, omega (s,) yaw rate, theta (s,) yaw;
    particles_object (k, 2) from ``footprint_particles``.
    """
    s = len(theta)
    r_world = rotate2(theta, np.broadcast_to(particles_object, (s,) + particles_object.shape))  # (s, k, 2)
    # v(r_i) = v + omega x r_i
    v_p = v_world[:, None, :] + omega[:, None, None] * np.stack([-r_world[..., 1], r_world[..., 0]], axis=-1)
    speed = np.linalg.norm(v_p, axis=-1, keepdims=True)
    v_hat = np.where(speed > _SPEED_EPS, v_p / np.maximum(speed, _SPEED_EPS), 0.0)
    load = mu * mass_kg * gravity / particles_object.shape[0]
    f_f = -load * v_hat.sum(axis=1)
    n_f = -load * cross2(r_world, v_hat).sum(axis=1)
    return f_f, n_f
