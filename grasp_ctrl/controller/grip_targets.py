"""Per-fingertip grip targets (N) for the force loops.

With every grasping fingertip ramping toward the same tau, two fingers opposing
one thumb on a free object ask for inconsistent forces: the thumb must push what
the two fingers push together, so the loops drift and the grasp settles wherever
the object's balance puts it (controller/ramp_settle.py, docs/mujoco.md).

``force_closure``: targets t_i along the closing vectors v_i whose horizontal
parts cancel, sum_i t_i v_i,xy = 0, with the smallest target tau (bounded least
squares over the closing vectors; opposite fingers of one each keep tau, two
fingers against a thumb give the thumb about 2 tau).

``weight_margin`` > 0 (the object's ``mass_kg`` is known): the targets are scaled
up, if needed, so that mu times their sum carries ``weight_margin`` times the
object's weight. Off (0) by default: tau_n is the user's tuned grip.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config.objects import GRIP_TARGET_MODES  # noqa: F401  (the modes, named with the profiles)
from grasp_ctrl.numeric.gravity import GRAVITY_M_S2
from grasp_ctrl.numeric.solve_cache import stored


def grip_targets(
    task_vectors_hand: np.ndarray,
    grasping: np.ndarray,
    tau_n: float,
    mode: str = "equal",
    mass_kg: float = 0.0,
    mu: float = 1.0,
    weight_margin: float = 0.0,
) -> np.ndarray:
    """One target per fingertip (finger order; non-grasping fingers get tau_n, unused)."""
    if mode not in GRIP_TARGET_MODES:
        raise ValueError(f"grip target mode must be one of {GRIP_TARGET_MODES} (got {mode!r})")
    vectors = np.asarray(task_vectors_hand, dtype=float)
    grasping = np.asarray(grasping, dtype=bool)
    targets = np.full(len(vectors), float(tau_n))
    idx = np.flatnonzero(grasping)
    if mode == "force_closure" and len(idx) >= 2:
        targets[idx] = closure_targets(vectors[idx, :2].T, float(tau_n))
    if weight_margin > 0.0 and mass_kg > 0.0 and len(idx):
        needed = weight_margin * mass_kg * GRAVITY_M_S2 / max(mu, 1e-6)
        total = float(targets[idx].sum())
        if total < needed:
            targets[idx] *= needed / total
    return targets


@stored()
def closure_targets(horizontal: np.ndarray, tau_n: float) -> np.ndarray:
    """Targets t_i >= tau_n whose pushes along the columns v_i,xy of ``horizontal`` (2, k) cancel,
    the smallest of them tau_n."""
    from scipy.optimize import lsq_linear

    k = horizontal.shape[1]
    # the net horizontal push (minimised) and, lightly weighted, the distance from tau
    # (picks the smallest consistent targets when the cancellation has many solutions)
    a = np.vstack([horizontal, 1e-6 * np.eye(k)])
    b = np.concatenate([np.zeros(2), 1e-6 * np.full(k, tau_n)])
    fit = lsq_linear(a, b, bounds=(tau_n, np.inf), method="bvls")
    t = np.asarray(fit.x, dtype=float)
    return t * (tau_n / float(t.min()))
