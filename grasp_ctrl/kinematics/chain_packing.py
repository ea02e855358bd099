"""The chains' geometry packed for the compiled kernels: every finger's base pose, joint
origins, axes and tip pose, the pad point and normal and the joint limits as one float64
array plus one int64 array of sizes and joint ranges (``pack_geometry``, which reads
``FingerChain``'s private fields), and the kernels' views of them (``_unpack``).
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.kinematics.chain import FingerChain
from grasp_ctrl.numeric.jit import njit

# ----- the chains' geometry packed into two arrays for the kernels PadIK calls -----
# (a compiled call costs about 65 ns per array argument: two instead of fifteen)


def pack_geometry(
    chains: list[FingerChain],
    starts: np.ndarray,
    point: np.ndarray,
    normal: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """``(geometry, layout)``: every chain's base pose, joint origins, axes and tip pose
    (fingers with fewer joints than the longest padded with zeros), the pad point and
    normal (sensor frame) and the joint limits, as one float64 array; the sizes and
    each finger's first joint and joint count as one int64 array (``_unpack``)."""
    nmax = max(c.n for c in chains)

    def padded(get):
        return np.array([np.concatenate([get(c), np.zeros((nmax - c.n, *get(c).shape[1:]))]) for c in chains])

    parts = [
        np.array([c._R_base for c in chains]),
        np.array([c._p_base for c in chains]),
        padded(lambda c: c._R_org),
        padded(lambda c: c._p_org),
        padded(lambda c: c._K),
        padded(lambda c: c._K2),
        padded(lambda c: c.axes),
        np.array([c._R_tip for c in chains]),
        np.array([c._p_tip for c in chains]),
        point,
        normal,
        lower,
        upper,
    ]
    geometry = np.concatenate([np.ascontiguousarray(p, dtype=float).ravel() for p in parts])
    layout = np.concatenate([[len(chains), nmax, len(lower)], starts, [c.n for c in chains]]).astype(np.int64)
    return geometry, layout


@njit
def _unpack(geometry, layout):
    """Views of ``pack_geometry``'s arrays: starts, counts, R_base, p_base, R_org, p_org,
    K, K2, axes, R_tip, p_tip, point, normal, lower, upper."""
    F, nmax, J = layout[0], layout[1], layout[2]
    o = 0
    R_base = geometry[o : o + 9 * F].reshape((F, 3, 3))
    o += 9 * F
    p_base = geometry[o : o + 3 * F].reshape((F, 3))
    o += 3 * F
    R_org = geometry[o : o + 9 * F * nmax].reshape((F, nmax, 3, 3))
    o += 9 * F * nmax
    p_org = geometry[o : o + 3 * F * nmax].reshape((F, nmax, 3))
    o += 3 * F * nmax
    K = geometry[o : o + 9 * F * nmax].reshape((F, nmax, 3, 3))
    o += 9 * F * nmax
    K2 = geometry[o : o + 9 * F * nmax].reshape((F, nmax, 3, 3))
    o += 9 * F * nmax
    axes = geometry[o : o + 3 * F * nmax].reshape((F, nmax, 3))
    o += 3 * F * nmax
    R_tip = geometry[o : o + 9 * F].reshape((F, 3, 3))
    o += 9 * F
    p_tip = geometry[o : o + 3 * F].reshape((F, 3))
    o += 3 * F
    point = geometry[o : o + 3]
    normal = geometry[o + 3 : o + 6]
    lower = geometry[o + 6 : o + 6 + J]
    upper = geometry[o + 6 + J : o + 6 + 2 * J]
    return (
        layout[3 : 3 + F],
        layout[3 + F : 3 + 2 * F],
        R_base,
        p_base,
        R_org,
        p_org,
        K,
        K2,
        axes,
        R_tip,
        p_tip,
        point,
        normal,
        lower,
        upper,
    )
