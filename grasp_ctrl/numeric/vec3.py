"""Fixed-order arithmetic on 3-vectors, the same bits on every CPU.

``a.dot(b)`` and ``a @ b`` hand a 3-vector to BLAS, and which kernel BLAS picks
(and so the order and width in which it sums) depends on the CPU: the last bit of
a distance can differ between an AVX2 and an AVX-512 machine. The control loop's
distances (the controller's palm moves, the MuJoCo wrist step) sum
``0 + x0*y0 + x1*y1 + x2*y2`` left to right instead, so a trial's records do not
depend on the BLAS.
"""

from __future__ import annotations

import math

import numpy as np


def dot3(a: np.ndarray, b: np.ndarray) -> float:
    """``a . b`` of two 3-vectors, summed left to right."""
    return 0.0 + ((float(a[0]) * float(b[0]) + float(a[1]) * float(b[1])) + float(a[2]) * float(b[2]))


def norm3(d: np.ndarray) -> float:
    """``|d|`` of a 3-vector, from ``dot3(d, d)``."""
    return math.sqrt(dot3(d, d))
