"""Exact forward kinematics of every finger as one tensor contraction.

A revolute joint's rotation is linear in (1, cos q, sin q):
``R(q) = (I + K^2) - cos(q) K^2 + sin(q) K`` with K the skew matrix of its axis.
A chain of n joints is therefore a multilinear polynomial in the n vectors
``u_i = (1, cos q_i, sin q_i)``: the sensor pose is ``m(q) @ W`` with ``m`` the
3^n products of their entries and W a constant table built once from the chain.
The same holds for each joint's axis and origin, from which the Jacobian of a
fingertip point follows.

So the poses and Jacobians of all fingers come out of one gather, a few
products and one small matrix product per finger, whatever the chain looks
like. The mock world steps with this (it must run hundreds of times faster
than real time); the result equals the joint-by-joint product of
``FingerChain`` to rounding. Fingers with fewer joints than the longest are
padded with fixed joints.
"""

from __future__ import annotations

import itertools

import numpy as np

from grasp_ctrl.kinematics.chain import FingerChain, HandKinematics
from grasp_ctrl.numeric.jit import njit

#: Largest chain handled (3^n monomials per finger).
MAX_JOINTS = 7


def _homogeneous(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    T = np.zeros((4, 4))
    T[:3, :3] = R
    T[:3, 3] = p
    T[3, 3] = 1.0
    return T


def _basis(K: np.ndarray) -> list[np.ndarray]:
    """The joint transform's coefficients of 1, cos q and sin q (4x4 each)."""
    K2 = K @ K
    constant = _homogeneous(np.eye(3) + K2, np.zeros(3))
    cos_part = np.zeros((4, 4))
    cos_part[:3, :3] = -K2
    sin_part = np.zeros((4, 4))
    sin_part[:3, :3] = K
    return [constant, cos_part, sin_part]


def _pose_table(chain: FingerChain, n: int) -> np.ndarray:
    """W (3^n, 12 + 6n): rows per monomial; columns the sensor rotation (row-major
    9), its origin (3), then per joint slot its axis (3) and origin (3), all in
    the hand frame. A joint's own frame depends only on the joints before it, so
    its columns are filled only where the later factors take their constant term."""
    T_base = _homogeneous(chain._R_base, chain._p_base)
    T_tip = _homogeneous(chain._R_tip, chain._p_tip)
    links = []
    for i in range(n):
        if i < chain.n:
            T_org = _homogeneous(chain._R_org[i], chain._p_org[i])
            links.append((T_org, [T_org @ B for B in _basis(chain._K[i])], chain.axes[i]))
        else:  # padding: a fixed joint with no axis
            links.append((np.eye(4), [np.eye(4), np.zeros((4, 4)), np.zeros((4, 4))], np.zeros(3)))
    W = np.zeros((3**n, 12 + 6 * n))
    for row, combo in enumerate(itertools.product(range(3), repeat=n)):
        T = T_base
        for i, k in enumerate(combo):
            T_org, options, axis = links[i]
            if not any(combo[i:]):
                joint = T @ T_org
                col = 12 + 6 * i
                W[row, col : col + 3] = joint[:3, :3] @ axis
                W[row, col + 3 : col + 6] = joint[:3, 3]
            T = T @ options[k]
        T = T @ T_tip
        W[row, :9] = T[:3, :3].reshape(9)
        W[row, 9:12] = T[:3, 3]
    return W


@njit
def contract(q: np.ndarray, take: np.ndarray, W: np.ndarray, rows: np.ndarray) -> None:
    """Rows (F, C) of all fingers at joint angles q: the monomials of (1, cos q_i,
    sin q_i) gathered by ``take`` (n, F, 3^n) and contracted with W (F, 3^n, C).
    Compiled into the mock world's step (grasp_ctrl/numeric/jit.py)."""
    J = q.shape[0]
    vals = np.empty(2 * J + 2)
    vals[0] = 1.0
    vals[1 : J + 1] = np.cos(q)
    vals[J + 1 : 2 * J + 1] = np.sin(q)
    vals[2 * J + 1] = 0.0
    # The monomials: vals gathered by take, multiplied slot by slot in order (what
    # np.take and in-place products computed, without their (n, F, 3^n) temporaries).
    n, F, M = take.shape
    m = np.empty((F, M))
    for f in range(F):
        for j in range(M):
            v = vals[take[0, f, j]]
            for i in range(1, n):
                v *= vals[take[i, f, j]]
            m[f, j] = v
    for f in range(W.shape[0]):
        rows[f] = np.dot(m[f], W[f])


class MultilinearKinematics:
    """Sensor poses, contact points and joint axes of every finger, batched.

    ``evaluate`` returns (F, 12 + 6n) rows laid out as ``ROT``, ``POINT``, then
    per joint slot k its axis (columns 12 + 6k ..) and origin (15 + 6k ..);
    ``jacobian`` turns a row into the point's position Jacobian.
    """

    ROT = slice(0, 9)
    POINT = slice(9, 12)

    def __init__(self, kin: HandKinematics) -> None:
        names = list(kin.chains)
        self.F = F = len(names)
        self.n = n = max(kin.chains[name].n for name in names)
        if n > MAX_JOINTS:
            raise ValueError(f"multilinear kinematics handles chains of up to {MAX_JOINTS} joints, not {n}")
        self.W = np.array([_pose_table(kin.chains[name], n) for name in names])  # (F, 3^n, 12 + 6n)
        # Monomial j of finger f is the product over slots i of vals[take[i, f, j]] with
        # vals = (1, cos q_0..q_J-1, sin q_0..q_J-1, 0): one gather, n - 1 products.
        J = sum(kin.chains[name].n for name in names)
        digits = np.array(list(itertools.product(range(3), repeat=n))).T  # (n, 3^n)
        take = np.zeros((n, F, 3**n), dtype=np.intp)
        for f, name in enumerate(names):
            sl = kin.slices[name]
            for i in range(n):
                if i < sl.stop - sl.start:
                    joint = sl.start + i
                    take[i, f] = np.choose(digits[i], [0, 1 + joint, 1 + J + joint])
                else:  # padded slot: cos and sin terms read the trailing zero
                    take[i, f] = np.where(digits[i] == 0, 0, 1 + 2 * J)
        self.take = take

    def point_table(self, p_sensor: np.ndarray) -> np.ndarray:
        """W with the origin columns moved to one sensor-frame point per finger (F, 3)."""
        W = self.W.copy()
        R = self.W[..., :9].reshape(self.F, -1, 3, 3)
        W[..., 9:12] += (R @ p_sensor[:, None, :, None])[..., 0]
        return W

    def evaluate(self, q_all: np.ndarray, p_sensor: np.ndarray | None = None) -> np.ndarray:
        """(F, 12 + 6n) at joint angles ``q_all``; ``POINT`` is the sensor-frame point
        ``p_sensor[f]`` (per finger, (F, 3)) in the hand frame, or the sensor origin."""
        W = self.W if p_sensor is None else self.point_table(np.ascontiguousarray(p_sensor, dtype=float))
        rows = np.empty((self.F, W.shape[2]))
        contract(np.ascontiguousarray(q_all, dtype=float), self.take, W, rows)
        return rows

    def jacobian(self, row: np.ndarray) -> np.ndarray:
        """Position Jacobian (3, n) of the row's point: axis_k x (point - origin_k)."""
        n = self.n
        a = row[12:].reshape(n, 2, 3)
        return np.cross(a[:, 0], row[None, 9:12] - a[:, 1]).T
