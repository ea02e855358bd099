"""The controller's per-tick fingertip IK for all fingers in one call.

Every tick the controller moves some fingertips' pad points along their closing
vectors: forward kinematics to the pad, its position Jacobian and one damped
least-squares step per finger (``FingerChain.point_and_jacobian`` and
``FingerChain.dls_step``). With the ``sim`` extra (numba) the same arithmetic
runs compiled for all fingers at once, a few microseconds instead of about a
hundred per finger; without it the per-finger numpy methods run. The kernels
read only the chains' generic pieces (base pose, joint origins, axes, tip pose),
so any serial-chain geometry works.

This module holds ``PadIK`` (each method's numpy form and its dispatch to the
kernels), ``Facing`` and the numpy pad-facing step; the kernels live in
kinematics/pad_ik_kernels.py (IK), kinematics/stiffness_squeeze.py (the
stiffness-aware squeeze) and kinematics/sensor_frame_kernels.py (sensor-frame
rotations), the packed geometry they read in kinematics/chain_packing.py.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from grasp_ctrl.kinematics.batched import BatchedKinematics
from grasp_ctrl.kinematics.chain import FingerChain, HandKinematics
from grasp_ctrl.kinematics.chain_packing import pack_geometry
from grasp_ctrl.kinematics.fingertip import PAD_NORMAL_SENSOR, PAD_POINT_SENSOR
from grasp_ctrl.kinematics.pad_ik_kernels import _keep_within, advance_pads_kernel, pad_points_kernel, step_pads_kernel
from grasp_ctrl.kinematics.sensor_frame_kernels import sensor_forces_kernel, sensor_rotations_kernel
from grasp_ctrl.kinematics.stiffness_squeeze import (
    MAX_SQUEEZE_STRETCH,
    squeeze_directions_kernel,
    squeeze_step_kernel,
    squeeze_targets_kernel,
)
from grasp_ctrl.numeric import jit


class PadIK:
    """Pad points and IK steps of all fingers of one hand (hand-file finger order)."""

    def __init__(
        self, kin: HandKinematics, point_sensor: np.ndarray = PAD_POINT_SENSOR, compiled: bool | None = None
    ) -> None:
        self.kin = kin
        self.names = list(kin.chains)
        self.point = np.ascontiguousarray(point_sensor, dtype=float)
        self.normal = np.ascontiguousarray(PAD_NORMAL_SENSOR, dtype=float)
        chains = [kin.chains[n] for n in self.names]
        n_joints = max(sl.stop for sl in kin.slices.values())
        self.lower, self.upper = np.full(n_joints, -np.inf), np.full(n_joints, np.inf)
        for name, chain in zip(self.names, chains):
            self.lower[kin.slices[name]] = chain.lower
            self.upper[kin.slices[name]] = chain.upper
        self.compiled = jit.JIT if compiled is None else compiled
        F = len(chains)
        self.starts = np.array([kin.slices[n].start for n in self.names], dtype=np.int64)
        self.counts = np.array([c.n for c in chains], dtype=np.int64)
        # The kernels' view of the chains (only read): two arrays, so a call passes few arguments.
        self.geometry, self.layout = pack_geometry(chains, self.starts, self.point, self.normal, self.lower, self.upper)
        self._batched = BatchedKinematics(kin)
        self._no_facing = Facing.none(F)

    def pad_points(self, q_all: np.ndarray) -> np.ndarray:
        """(F, 3) pad points, hand frame."""
        q = np.ascontiguousarray(q_all, dtype=float)
        if self.compiled:
            out = np.empty((len(self.names), 3))
            pad_points_kernel(q, self.geometry, self.layout, out)
            return out
        out = np.empty((len(self.names), 3))
        for f, name in enumerate(self.names):
            R, p = self.kin.chains[name].fk_rp(q[self.kin.slices[name]])
            out[f] = R @ self.point + p
        return out

    def sensor_rotations(self, q_all: np.ndarray) -> np.ndarray:
        """(F, 3, 3) sensor-frame rotations in the hand frame."""
        if self.compiled:
            out = np.empty((len(self.names), 3, 3))
            sensor_rotations_kernel(np.ascontiguousarray(q_all, dtype=float), self.geometry, self.layout, out)
            return out
        return self._batched.sensor_frames(q_all)[0]

    def sensor_forces(self, q_all: np.ndarray, f_sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Forces (F, 3) from the sensor frames to the hand frame, and each one's size
        across the hand's z axis (F,): ``(f_hand, grip)``."""
        if self.compiled:
            f_hand = np.empty((len(self.names), 3))
            grip = np.empty(len(self.names))
            sensor_forces_kernel(
                np.ascontiguousarray(q_all, dtype=float),
                self.geometry,
                self.layout,
                np.ascontiguousarray(f_sensor, dtype=float),
                f_hand,
                grip,
            )
            return f_hand, grip
        f_hand = np.einsum("nij,nj->ni", self.sensor_rotations(q_all), f_sensor)
        return f_hand, np.sqrt(f_hand[:, 0] ** 2 + f_hand[:, 1] ** 2)

    def pad_normals(self, q_all: np.ndarray) -> np.ndarray:
        """(F, 3) outward pad normals, hand frame."""
        return np.einsum("nij,j->ni", self.sensor_rotations(q_all), self.normal)

    def advance(
        self,
        q_all: np.ndarray,
        targets: np.ndarray,
        task_vectors: np.ndarray,
        distances: np.ndarray,
        damping: float,
        facing: Facing | None = None,
    ) -> bool:
        """Move the pad ``targets`` (F, 3, in place) along ``task_vectors`` (F, 3) by
        ``distances`` (F,) and take one DLS step for the fingers that moved (``q_all``
        in place); False when every distance is 0 (nothing changes). With ``facing``,
        its fingers also turn their pads toward its normals (``step``)."""
        facing = facing or self._no_facing
        if self.compiled:
            return bool(
                advance_pads_kernel(
                    q_all,
                    targets,
                    task_vectors,
                    distances,
                    self.geometry,
                    self.layout,
                    damping,
                    facing.normals_hand,
                    facing.fingers,
                    facing.damping,
                )
            )
        move = distances != 0.0
        if not move.any():
            return False
        targets += task_vectors * distances[:, None]
        self.step(q_all, targets, move, damping, facing)
        return True

    def squeeze_directions(
        self, q_all: np.ndarray, task_vectors: np.ndarray, distances: np.ndarray, compliance: np.ndarray
    ) -> np.ndarray:
        """(F, 3): for each finger with a distance, the direction to move its pad goal so that
        the joints' position springs (``compliance`` per joint, rad per N m) push the pad
        along its task vector (``_squeeze_directions``); the task vector itself for the others."""
        q = np.ascontiguousarray(q_all, dtype=float)
        v = np.ascontiguousarray(task_vectors, dtype=float)
        out = np.empty((len(self.names), 3))
        if self.compiled:
            squeeze_directions_kernel(
                q,
                v,
                np.ascontiguousarray(distances, dtype=float),
                np.ascontiguousarray(compliance, dtype=float),
                self.geometry,
                self.layout,
                out,
            )
            return out
        out[:] = v
        for f, name in enumerate(self.names):
            d = float(distances[f])
            if d == 0.0:
                continue
            chain, sl = self.kin.chains[name], self.kin.slices[name]
            _, J = chain.point_and_jacobian(q[sl], self.point)
            w = compliance[sl] * (J.T @ v[f])
            blocked = ((w * d > 0.0) & (q[sl] >= chain.upper)) | ((w * d < 0.0) & (q[sl] <= chain.lower))
            u = J @ np.where(blocked, 0.0, w)
            along = float(u @ v[f])
            if along > 0.0 and float((u / along) @ (u / along)) <= MAX_SQUEEZE_STRETCH**2:
                out[f] = u / along
        return out

    def squeeze_targets(
        self,
        q_goal: np.ndarray,
        q_measured: np.ndarray,
        targets: np.ndarray,
        task_vectors: np.ndarray,
        distances: np.ndarray,
        compliance: np.ndarray,
        pad_along: np.ndarray,
        max_cross: float,
    ) -> bool:
        """``squeeze_targets_kernel``: the stiffness-aware squeeze's pad ``targets`` and
        ``pad_along`` (in place); True when a finger moved. The numpy form without numba."""
        if self.compiled:
            F = len(self.names)
            return bool(
                squeeze_targets_kernel(
                    np.ascontiguousarray(q_goal, dtype=float),
                    np.ascontiguousarray(q_measured, dtype=float),
                    targets,
                    np.ascontiguousarray(task_vectors, dtype=float),
                    np.ascontiguousarray(distances, dtype=float),
                    np.ascontiguousarray(compliance, dtype=float),
                    pad_along,
                    float(max_cross),
                    self.geometry,
                    self.layout,
                    np.empty((F, 3)),
                    np.empty((F, 3)),
                )
            )
        v = np.asarray(task_vectors, dtype=float)
        u = self.squeeze_directions(q_goal, v, distances, compliance)
        along = np.einsum("fr,fr->f", self.pad_points(q_measured), v)
        moving = distances != 0.0
        followed = np.where(np.isnan(pad_along), 0.0, along - pad_along)
        cross = np.clip(distances - followed, -max_cross, max_cross)
        targets[moving] += (v * distances[:, None] + (u - v) * cross[:, None])[moving]
        pad_along[:] = along
        return bool(moving.any())

    def squeeze_step(
        self,
        q_goal: np.ndarray,
        q_measured: np.ndarray,
        targets: np.ndarray,
        task_vectors: np.ndarray,
        distances: np.ndarray,
        compliance: np.ndarray,
        pad_along: np.ndarray,
        max_cross: float,
        damping: float,
        facing: Facing | None = None,
    ) -> bool:
        """``squeeze_targets``, then, when a finger moved, ``step`` for the fingers with a
        distance (``q_goal`` in place; compiled: one call); True when one moved."""
        if not self.compiled:
            moved = self.squeeze_targets(
                q_goal, q_measured, targets, task_vectors, distances, compliance, pad_along, max_cross
            )
            if moved:
                self.step(q_goal, targets, distances != 0.0, damping, facing)
            return moved
        facing = facing or self._no_facing
        return bool(
            squeeze_step_kernel(
                q_goal,
                np.ascontiguousarray(q_measured, dtype=float),
                targets,
                task_vectors,
                np.ascontiguousarray(distances, dtype=float),
                compliance,
                pad_along,
                float(max_cross),
                self.geometry,
                self.layout,
                damping,
                facing.normals_hand,
                facing.fingers,
                facing.damping,
            )
        )

    def step(
        self, q_all: np.ndarray, targets: np.ndarray, move: np.ndarray, damping: float, facing: Facing | None = None
    ) -> None:
        """One DLS step toward ``targets`` (F, 3) for the fingers with ``move``; ``q_all``
        in place. Fingers in ``facing`` also turn their pad normal toward its target
        with the joints the position task leaves spare (its null space), so the pad
        keeps facing the object while it moves along the closing vector."""
        facing = facing or self._no_facing
        if self.compiled:
            step_pads_kernel(
                q_all,
                targets,
                move,
                self.geometry,
                self.layout,
                damping,
                facing.normals_hand,
                facing.fingers,
                facing.damping,
            )
            return
        for f, name in enumerate(self.names):
            if not move[f]:
                continue
            chain, sl = self.kin.chains[name], self.kin.slices[name]
            pad, J = chain.point_and_jacobian(q_all[sl], self.point)
            if not facing.fingers[f]:
                q_all[sl] = chain.dls_step(q_all[sl], J, targets[f] - pad, damping)
                continue
            q_all[sl] = facing_dls_step(
                chain, q_all[sl], J, targets[f] - pad, self.normal, facing.normals_hand[f], damping, facing.damping
            )


@functools.lru_cache(maxsize=8)
def shared_pad_ik(kin: HandKinematics) -> PadIK:
    """The PadIK of a hand's kinematics (pad point PAD_POINT_SENSOR), set up once for all
    its controllers and sensing pipelines (they only read it)."""
    return PadIK(kin)


@dataclass
class Facing:
    """Which fingers keep their pads facing a direction while they move, and which
    direction (outward pad normals, hand frame, (F, 3)); ``damping`` of that
    secondary task (its errors are unit-vector differences)."""

    fingers: np.ndarray  # (F,) bool
    normals_hand: np.ndarray  # (F, 3)
    damping: float = 0.1

    @classmethod
    def none(cls, n_fingers: int) -> Facing:
        return cls(np.zeros(n_fingers, dtype=bool), np.zeros((n_fingers, 3)))


def facing_dls_step(
    chain: FingerChain,
    q: np.ndarray,
    J: np.ndarray,
    dp_hand: np.ndarray,
    normal_sensor: np.ndarray,
    normal_target_hand: np.ndarray,
    damping: float,
    orient_damping: float,
) -> np.ndarray:
    """``FingerChain.dls_step`` plus the null-space turn of the pad normal toward
    ``normal_target_hand`` (numpy form of the compiled ``_facing_step``)."""
    R_s = chain.fk_rp(q)[0]
    normal = R_s @ normal_sensor
    axes_hand = chain.joint_axes_and_origins(q)[0]
    Jn = np.cross(axes_hand, normal).T  # (3, n): d(normal)/dq
    dn = normal_target_hand - normal
    step = chain.dls_delta(q, J, dp_hand, damping)
    if step is None:
        return np.clip(q, chain.lower, chain.upper)
    dq1, active = step
    Ja, Jna = J * active, Jn * active  # inactive joints: zero columns
    A = Ja @ Ja.T + damping**2 * np.eye(3)
    N = np.eye(chain.n) - Ja.T @ np.linalg.inv(A) @ Ja
    W = (N @ Jna.T) * active[:, None]
    C = Jna @ W + orient_damping**2 * np.eye(3)
    dq = dq1 + W @ np.linalg.solve(C, dn - Jna @ dq1)
    _keep_within(q, 0, chain.n, dq1, dq, chain.lower, chain.upper)
    return np.clip(q + dq, chain.lower, chain.upper)
