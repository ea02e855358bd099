"""The paper's contact gate on a tared stream: tared pdc above a threshold for N consecutive
frames (the rule of ``grasp_ctrl.tactile.tare.ContactGate``, vectorised over one trial)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class GateRule:
    pdc_threshold: float = 10.0  # counts, tared
    frames: int = 10  # consecutive frames above the threshold


def contact_gate(tared_pdc: np.ndarray, rule: GateRule = GateRule()) -> np.ndarray:
    """(n,) tared pdc of one trial in time order -> (n,) bool, True where the gate is on."""
    above = np.asarray(tared_pdc, dtype=float) > rule.pdc_threshold
    pos = np.arange(len(above))
    last_below = np.maximum.accumulate(np.where(above, -1, pos)) if len(above) else pos
    return (pos - last_below) >= rule.frames
