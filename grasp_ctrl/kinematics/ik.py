"""Position IK on top of ``FingerChain``: iterated damped least squares.

``FingerChain.ik_step`` moves a sensor-frame point by one small Cartesian
displacement. ``solve_position_ik`` repeats it toward an absolute target,
limiting each iteration's Cartesian step so the linearisation holds, and
stays within the joint limits (ik_step freezes joints at a limit and clamps).
It works for any serial chain built like a finger (the Dynamixel arm uses it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypedDict, Unpack

import numpy as np

from grasp_ctrl.kinematics.chain import FingerChain, HandKinematics


@dataclass(frozen=True)
class IKResult:
    q: np.ndarray
    error_m: float  # remaining distance to the target
    iterations: int
    converged: bool


class IKOptions(TypedDict, total=False):
    """``solve_position_ik``'s tuning keywords, passed through by ``move_fingertips``."""

    tol_m: float
    max_iters: int
    max_step_m: float
    damping: float


def point_position(chain: FingerChain, q: np.ndarray, p_sensor: np.ndarray | None = None) -> np.ndarray:
    R, p = chain.fk_rp(np.asarray(q, dtype=float))
    return p if p_sensor is None else R @ np.asarray(p_sensor, dtype=float) + p


def solve_position_ik(
    chain: FingerChain,
    q0: np.ndarray,
    p_target_hand: np.ndarray,
    p_sensor: np.ndarray | None = None,
    tol_m: float = 1e-4,
    max_iters: int = 50,
    max_step_m: float = 0.005,
    damping: float = 0.01,
) -> IKResult:
    """Joint angles that put the sensor-frame point ``p_sensor`` at ``p_target_hand``.

    Starts from ``q0`` (clamped to the limits); the result is always within the
    limits. ``converged`` is False when the target is out of reach (the result
    is then the closest point found)."""
    q = np.clip(np.asarray(q0, dtype=float), chain.lower, chain.upper)
    target = np.asarray(p_target_hand, dtype=float)
    best_q, best_err = q.copy(), np.inf
    for it in range(max_iters + 1):
        err_vec = target - point_position(chain, q, p_sensor)
        err = float(np.linalg.norm(err_vec))
        if err < best_err:
            best_q, best_err = q.copy(), err
        if err <= tol_m:
            return IKResult(q, err, it, True)
        if it == max_iters:
            break
        if err > max_step_m:
            err_vec = err_vec * (max_step_m / err)
        # Damping matters far from the target (and near singularities); close to
        # it, fixed damping only slows convergence, so it shrinks with the error.
        lam = damping * min(1.0, max(err / max_step_m, 1e-3))
        q_new = chain.ik_step(q, err_vec, p_sensor, lam)
        if np.allclose(q_new, q, atol=1e-12):
            break  # stuck at limits / singular: no further progress
        q = q_new
    return IKResult(best_q, best_err, it, best_err <= tol_m)


def closing_vectors(kin: HandKinematics) -> dict[str, np.ndarray]:
    """Unit task-space closing direction per finger, hand frame (from the hand file)."""
    return {f.name: np.array(f.task_vector_hand, dtype=float) for f in kin.hand.fingers}


def move_fingertips(
    kin: HandKinematics,
    q_all: np.ndarray,
    dp_hand: dict[str, np.ndarray],
    p_sensor: np.ndarray | None = None,
    **ik_options: Unpack[IKOptions],
) -> tuple[np.ndarray, dict[str, IKResult]]:
    """Displace the given fingertips' points by ``dp_hand`` (hand frame, m) with
    position IK per finger; other fingers keep their angles."""
    q_new = np.array(q_all, dtype=float, copy=True)
    results: dict[str, IKResult] = {}
    for name, dp in dp_hand.items():
        chain, sl = kin.chains[name], kin.slices[name]
        start = point_position(chain, q_new[sl], p_sensor)
        res = solve_position_ik(chain, q_new[sl], start + np.asarray(dp, dtype=float), p_sensor, **ik_options)
        q_new[sl] = res.q
        results[name] = res
    return q_new, results


def close_along_task_vectors(
    kin: HandKinematics,
    q_all: np.ndarray,
    distance_m: float | dict[str, float],
    p_sensor: np.ndarray | None = None,
    grasp_only: bool = True,
) -> tuple[np.ndarray, dict[str, IKResult]]:
    """Move fingertips ``distance_m`` along their closing vectors (negative opens)."""
    vectors = closing_vectors(kin)
    fingers = [f.name for f in kin.hand.fingers if f.grasp or not grasp_only]
    dist = distance_m if isinstance(distance_m, dict) else {n: float(distance_m) for n in fingers}
    return move_fingertips(kin, q_all, {n: vectors[n] * d for n, d in dist.items() if n in fingers}, p_sensor)
