"""Force estimators: raw tactile signals -> force on the sensor skin (sensor frame)."""

from grasp_ctrl.estimators.base import Estimate, ForceEstimator

__all__ = ["Estimate", "ForceEstimator"]
