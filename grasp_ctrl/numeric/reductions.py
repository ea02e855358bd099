"""numpy's reductions of a handful of Python floats, bit for bit, without a numpy call.

The controller's per-finger arithmetic runs on lists of four or five values, where one numpy
call costs more than the whole loop; its sums must still give the bits ``np.sum`` gives.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: numpy sums fewer values than this one by one from +0.0; more, pairwise (8 accumulators).
PAIRWISE_FROM = 8


def np_sum(values: Sequence[float]) -> float:
    """``float(np.sum(np.array(values, dtype=float)))``: fewer than ``PAIRWISE_FROM`` values
    added left to right from +0.0 (so a lone -0.0 sums to +0.0), longer ones by numpy."""
    if len(values) >= PAIRWISE_FROM:
        return float(np.add.reduce(np.array(values, dtype=float)))
    total = 0.0
    for v in values:
        total += v
    return total
