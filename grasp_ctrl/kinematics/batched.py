"""Forward kinematics and pad Jacobians of all fingers at once.

The mock world and the sensing pipeline need every fingertip's pose every
tick; one vectorised pass over the fingers costs about as much as one finger
done alone. Fingers with different joint counts are grouped by count.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.kinematics.chain import HandKinematics


class _Group:
    def __init__(self, kin: HandKinematics, names: list[str]) -> None:
        chains = [kin.chains[n] for n in names]
        self.rows = names
        self.idx = np.array([np.arange(kin.slices[n].start, kin.slices[n].stop) for n in names])
        self.n = self.idx.shape[1]
        self.R_base = np.array([c._R_base for c in chains])
        self.p_base = np.array([c._p_base for c in chains])
        self.R_org = np.array([c._R_org for c in chains])  # (F, n, 3, 3)
        # Joint origins without a rotation (the common case) skip a matrix product.
        self.org_rotates = [not np.allclose(self.R_org[:, i], np.eye(3)) for i in range(self.R_org.shape[1])]
        self.p_org = np.array([c._p_org for c in chains])[..., None]  # (F, n, 3, 1)
        self.eye = np.eye(3)
        self.K = np.array([c._K for c in chains])
        self.K2 = np.array([c._K2 for c in chains])
        self.axes = np.array([c.axes for c in chains])  # (F, n, 3)
        self.R_tip = np.array([c._R_tip for c in chains])
        self.p_tip = np.array([c._p_tip for c in chains])[..., None]  # (F, 3, 1)

    def frames(self, q_all: np.ndarray):
        q = q_all[self.idx]  # (F, n)
        # All joint rotations at once (Rodrigues with precomputed K, K^2).
        rots = self.eye + np.sin(q)[..., None, None] * self.K + (1.0 - np.cos(q))[..., None, None] * self.K2
        F = len(self.rows)
        R = self.R_base
        p = self.p_base[..., None]  # (F, 3, 1)
        Rs = np.empty((F, self.n, 3, 3))
        ps = np.empty((F, self.n, 3, 1))
        for i in range(self.n):
            p = p + R @ self.p_org[:, i]
            if self.org_rotates[i]:
                R = R @ self.R_org[:, i]
            Rs[:, i] = R
            ps[:, i] = p
            R = R @ rots[:, i]
        return Rs, ps[..., 0], R @ self.R_tip, (p + R @ self.p_tip)[..., 0]


class BatchedKinematics:
    def __init__(self, kin: HandKinematics) -> None:
        self.names = list(kin.chains)
        by_len: dict[int, list[str]] = {}
        for name in self.names:
            by_len.setdefault(kin.chains[name].n, []).append(name)
        self.groups = [_Group(kin, names) for names in by_len.values()]
        self.order = {name: i for i, name in enumerate(self.names)}

    def sensor_frames(self, q_all: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rotations (F, 3, 3) and origins (F, 3) of every sensor frame, hand frame,
        in hand-file finger order."""
        F = len(self.names)
        R = np.empty((F, 3, 3))
        p = np.empty((F, 3))
        for g in self.groups:
            _, _, Rg, pg = g.frames(q_all)
            rows = [self.order[n] for n in g.rows]
            R[rows] = Rg
            p[rows] = pg
        return R, p

    def points_and_jacobians(
        self, q_all: np.ndarray, p_sensor: np.ndarray
    ) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
        """A sensor-frame point on every fingertip in the hand frame (F, 3), each
        finger's position Jacobian of it (3, n_joints of that finger), and the sensor
        rotations (F, 3, 3). ``p_sensor``: one point (3,) for all fingers, or one per
        finger (F, 3) in hand-file finger order."""
        F = len(self.names)
        p_sensor = np.asarray(p_sensor, dtype=float)
        per_finger = p_sensor.ndim == 2
        pts = np.empty((F, 3))
        rots = np.empty((F, 3, 3))
        jacs: list[np.ndarray] = [np.empty(0)] * F
        for g in self.groups:
            rows = [self.order[n] for n in g.rows]
            Rs, ps, R, p = g.frames(q_all)
            local = p_sensor[rows][..., None] if per_finger else p_sensor
            pt = (R @ local)[..., 0] + p if per_finger else R @ p_sensor + p  # (F, 3)
            a = (Rs @ g.axes[..., None])[..., 0]  # (F, n, 3) joint axes, hand frame
            b = pt[:, None, :] - ps
            J = np.stack(
                [
                    a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                    a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                    a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0],
                ],
                axis=-1,
            )  # (F, n, 3)
            pts[rows] = pt
            rots[rows] = R
            for k, i in enumerate(rows):
                jacs[i] = J[k].T
        return pts, jacs, rots
