"""Each policy as the trials use it: a function from a trial's world to its force estimator."""

from __future__ import annotations

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.estimators.registry import load_policy
from grasp_ctrl.rigs.trial_builder import EstimatorFactory
from grasp_ctrl.sim.oracle import OracleEstimator, is_oracle, parse_oracle


def estimator_factory(spec: str, hand: HandConfig, threads: int = 1) -> EstimatorFactory:
    """Oracles read each trial's world; other policies are loaded once and shared."""
    if is_oracle(spec):
        scale = parse_oracle(spec)
        return lambda world: OracleEstimator(world, scale, name=spec)
    est = load_policy(spec, hand, threads)
    return lambda world: est
