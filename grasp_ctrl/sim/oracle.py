"""Debugging policies of the mock world: the true contact force (times K)."""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

from grasp_ctrl.errors import PolicyError
from grasp_ctrl.estimators.base import Estimate
from grasp_ctrl.sim.world_api import World

_SPEC = re.compile(r"^oracle(?::scale=(?P<k>[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?))?$")


# A debugging multiplier: 1e6 already makes every touch an overforce fault; far larger ones
# overflow the logs' float32 columns.
MAX_SCALE = 1e6


def is_oracle(spec: str) -> bool:
    return spec == "oracle" or spec.startswith("oracle:")


def parse_oracle(spec: str) -> float:
    m = _SPEC.match(spec)
    if not m:
        raise PolicyError(f"policy {spec!r}: expected 'oracle' or 'oracle:scale=K' with 0 < K <= {MAX_SCALE:g}")
    k = float(m.group("k")) if m.group("k") else 1.0
    if k <= 0:
        raise PolicyError(f"policy {spec!r}: scale must be positive")
    if k > MAX_SCALE:  # forces beyond float32, the tick log's type: inf and an overflow warning
        raise PolicyError(f"policy {spec!r}: scale at most {MAX_SCALE:g}")
    return k


class OracleEstimator:
    """Reads f_sensor from the world's ground truth (mock backend only)."""

    has_variance = False

    def __init__(self, world: World, scale: float = 1.0, name: str = "oracle") -> None:
        self.world = world
        self.scale = scale
        self.name = name

    def estimate(self, tared: np.ndarray, fingers: Sequence[str]) -> Estimate:
        f = np.array([self.world.true_f_sensor(name) for name in fingers]).reshape(len(fingers), 3)
        return Estimate(f_sensor=self.scale * f)
