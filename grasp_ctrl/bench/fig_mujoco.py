"""Figure of the MuJoCo backend: ``mujoco_realtime_factor`` (listed only with the sim extra's mujoco)."""

from __future__ import annotations

import time

from grasp_ctrl.bench.figure import Figure
from grasp_ctrl.config import load_hand, load_objects
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.paths import default_hand_file, default_objects_file
from grasp_ctrl.sim.oracle import OracleEstimator
from grasp_ctrl.loop.sensing import SensingPipeline
from grasp_ctrl.loop.tick import control_tick

BENCH_OBJECT = "chips_can"


def _simulate_trial(sim_s: float, seed: int) -> float:
    """Wall-clock seconds of the MuJoCo world's steps (physics, contacts, BioTac frames) over
    ``sim_s`` simulated seconds of an oracle trial; the controller's own time is not counted."""
    from grasp_ctrl.sim.mujoco_backends import MockArm, mujoco_backends
    from grasp_ctrl.sim.mujoco_world import MuJoCoWorld

    hand = load_hand(default_hand_file())
    obj = load_objects(default_objects_file())[BENCH_OBJECT]
    kin = HandKinematics(hand)
    world = MuJoCoWorld(hand, obj, seed)
    hand_backend, sensors = mujoco_backends(world, hand)
    arm = MockArm(world, hand)
    pipeline = SensingPipeline(hand, kin, OracleEstimator(world))
    ctrl = GraspController(hand, obj, world.reach_pose_world(), kin=kin)
    spent = 0.0
    for _ in range(int(round(sim_s / hand.dt))):
        t0 = time.perf_counter()
        world.step()
        spent += time.perf_counter() - t0
        if not ctrl.terminal:
            control_tick(hand_backend, arm, sensors, pipeline, ctrl, world.t)
    return spent


def mujoco_realtime_factor(quick: bool) -> Figure:
    """Simulated seconds per wall-clock second of the MuJoCo world over a 10 s trial of the
    4-fingertip LEAP hand (grasp, lift, hold, start of lowering), median over 3 trials."""
    sim_s = 2.0 if quick else 10.0
    factors = [sim_s / _simulate_trial(sim_s, seed) for seed in range(2 if quick else 3)]
    return Figure.rate(factors, "x")


def _has_mujoco() -> bool:
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


# Without mujoco (the sim extra) the figure is not listed, so 'bench' runs the others.
FIGURES = {"mujoco_realtime_factor": mujoco_realtime_factor} if _has_mujoco() else {}
