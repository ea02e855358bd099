"""Figures of the mock backend: ``control_tick_ms`` and ``mock_realtime_factor``."""

from __future__ import annotations

import time
from collections.abc import Callable

from grasp_ctrl.bench.figure import Figure, time_ms
from grasp_ctrl.config import load_hand, load_objects
from grasp_ctrl.controller.registry import settings_for
from grasp_ctrl.estimators.registry import DEFAULT_POLICY, load_policy
from grasp_ctrl.files.paths import default_hand_file, default_objects_file
from grasp_ctrl.rigs.registry import TEST_WORLD
from grasp_ctrl.rigs.trial_builder import build_trial
from grasp_ctrl.sim.oracle import OracleEstimator

BENCH_OBJECT = "chips_can"


class _Loop:
    """A mock trial (rigs/trial_builder.py) with its parts exposed, for timing them separately."""

    def __init__(self, estimator_for_world, seed: int = 0, controller: str = "paper") -> None:
        self.hand = load_hand(default_hand_file())
        obj = load_objects(default_objects_file(), self.hand.name)[BENCH_OBJECT]
        self.trial = build_trial(
            self.hand, obj, seed, estimator_for_world, backend=TEST_WORLD, settings=settings_for(controller)
        )
        self.world, self.pipeline, self.ctrl = self.trial.world, self.trial.pipeline, self.trial.ctrl

    def control(self) -> None:
        """Everything of one tick except the world's physics step."""
        self.trial.tick(self.world.t)

    def run_until(self, state: str, limit_s: float = 30.0) -> None:
        while self.ctrl.state != state:
            if self.world.t > limit_s or self.ctrl.terminal:
                raise RuntimeError(f"benchmark trial did not reach {state} (in {self.ctrl.state})")
            self.world.step()
            self.control()


NETWORK_POLICY = "icra19_official"


def _control_tick(
    policy: str, quick: bool, timer: Callable[[], float] = time.perf_counter, controller: str = "paper"
) -> Figure:
    """One control tick (sensors, tare, gate, features, the policy's batched
    inference, kinematics, state machine, IK, goals) with the grasping fingertips
    in contact. The trial is driven to the lift with the default policy; ``policy``
    is then timed in its place (1 thread)."""
    hand = load_hand(default_hand_file())
    est = load_policy(DEFAULT_POLICY, hand, threads=1)
    loop = _Loop(lambda world: est, controller=controller)
    loop.run_until("lift")
    loop.pipeline.tactile.estimator = load_policy(policy, hand, threads=1)
    return time_ms(loop.control, repeats=200 if quick else 3000, timer=timer)


def measure_control_tick(quick: bool) -> Figure:
    """``control_tick_ms``: the default policy, as the default trials run it."""
    return _control_tick(DEFAULT_POLICY, quick)


def measure_control_tick_cpu(quick: bool) -> Figure:
    """``control_tick_cpu_ms``: the same in this thread's CPU time: the code's own tail,
    without the waits of a machine shared with other jobs."""
    return _control_tick(DEFAULT_POLICY, quick, timer=time.thread_time)


def measure_control_tick_grip_load(quick: bool) -> Figure:
    """``control_tick_grip_load_ms``: the same with the grip_load controller (its tick adds
    grip-load coordination, slip signals, the PAC spread), in the lift."""
    return _control_tick(DEFAULT_POLICY, quick, controller="grip_load")


def measure_control_tick_network(quick: bool) -> Figure:
    """``control_tick_icra19_ms``: the same with the official voxel network."""
    return _control_tick(NETWORK_POLICY, quick)


def _simulate_trial(sim_s: float) -> float:
    """Wall-clock seconds of the world's physics over ``sim_s`` simulated seconds."""
    loop = _Loop(lambda world: OracleEstimator(world))
    spent = 0.0
    for _ in range(int(round(sim_s / loop.hand.dt))):
        t0 = time.perf_counter()
        loop.world.step()
        spent += time.perf_counter() - t0
        if not loop.ctrl.terminal:
            loop.control()
    return spent


def mock_realtime_factor(quick: bool) -> Figure:
    """Simulated seconds per wall-clock second of the world's physics over a 10 s
    trial (4 fingertips, oracle control so the controller's cost is not counted),
    after a warm-up world has loaded (or compiled) the kernels (grasp_ctrl/numeric/jit.py).
    The median over 5 trials: one trial's 40 ms of physics is easily disturbed (a
    garbage collection of the controller's objects that lands in a step, the VM)."""
    warm_up = _Loop(lambda world: OracleEstimator(world), seed=1)
    for _ in range(3):
        warm_up.world.step()
    sim_s = 2.0 if quick else 10.0
    factors = [sim_s / _simulate_trial(sim_s) for _ in range(2 if quick else 5)]
    return Figure.rate(factors, "x")


FIGURES = {
    "control_tick_ms": measure_control_tick,
    "control_tick_cpu_ms": measure_control_tick_cpu,
    "control_tick_grip_load_ms": measure_control_tick_grip_load,
    "control_tick_icra19_ms": measure_control_tick_network,
    "mock_realtime_factor": mock_realtime_factor,
}
