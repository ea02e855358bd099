"""The ForceEstimator interface.

Input: tared frames (raw counts minus a no-contact baseline, ``value - baseline``,
so pressed electrodes are negative) for the fingertips in contact, one row each.
Output: ``f_sensor`` in N: the force the environment exerts ON the sensor skin,
in the sensor frame (docs/design.md 4). A pad press gives mostly +z.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np


class Estimate(NamedTuple):  # immutable, and cheap to make every tick
    f_sensor: np.ndarray  # (n, 3) N
    variance: np.ndarray | None = None  # (n, 3) N^2, when the policy provides it


@runtime_checkable
class ForceEstimator(Protocol):
    name: str
    has_variance: bool

    def estimate(self, tared: np.ndarray, fingers: Sequence[str]) -> Estimate:
        """One batched call for all fingertips in contact.

        ``tared``: (n, 44) float; ``fingers``: the n finger names (row order).
        """
        ...
