"""Figures of the MuJoCo backend: ``mujoco_realtime_factor`` (the world) and
``mujoco_bare_realtime_factor`` (``mj_step`` alone on the same scene and trajectory)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from grasp_ctrl.bench.figure import Figure
from grasp_ctrl.config import load_hand, load_objects
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.files.paths import default_hand_file, default_objects_file
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.loop.sensing import SensingPipeline
from grasp_ctrl.loop.tick import control_tick
from grasp_ctrl.sim.oracle import OracleEstimator

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
    for _ in range(round(sim_s / hand.dt)):
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


class _StepRecorder:
    """The mujoco module, with ``mj_step`` noting the inputs (actuator goals, the arm's mocap
    position) it stepped with, so that the engine alone can replay the same trajectory."""

    def __init__(self, mj: Any) -> None:
        self._mj = mj
        self.inputs: list[tuple[np.ndarray, np.ndarray]] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self._mj, name)

    def mj_step(self, m: Any, d: Any) -> None:
        self.inputs.append((d.ctrl.copy(), d.mocap_pos.copy()))
        self._mj.mj_step(m, d)


def _bare_steps(sim_s: float, seed: int) -> float:
    """Wall-clock seconds of ``mj_step`` alone over the steps of the same oracle trial as
    ``_simulate_trial`` (same scene, same trajectory: the trial's inputs replayed from its
    start state), without the world's contact reading, BioTac frames or bookkeeping."""
    import mujoco

    from grasp_ctrl.sim.mujoco_backends import MockArm, mujoco_backends
    from grasp_ctrl.sim.mujoco_world import MuJoCoWorld

    hand = load_hand(default_hand_file())
    obj = load_objects(default_objects_file())[BENCH_OBJECT]
    kin = HandKinematics(hand)
    world = MuJoCoWorld(hand, obj, seed)
    m, d = world.model, world.data
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    start = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, start, spec)
    recorder = _StepRecorder(mujoco)
    world._mj = recorder
    hand_backend, sensors = mujoco_backends(world, hand)
    arm = MockArm(world, hand)
    pipeline = SensingPipeline(hand, kin, OracleEstimator(world))
    ctrl = GraspController(hand, obj, world.reach_pose_world(), kin=kin)
    for _ in range(round(sim_s / hand.dt)):
        world.step()
        if not ctrl.terminal:
            control_tick(hand_backend, arm, sensors, pipeline, ctrl, world.t)
    mujoco.mj_setState(m, d, start, spec)
    step = mujoco.mj_step
    spent = 0.0
    for ctrl_in, mocap_in in recorder.inputs:
        d.ctrl[:] = ctrl_in
        d.mocap_pos[:] = mocap_in
        t0 = time.perf_counter()
        step(m, d)
        spent += time.perf_counter() - t0
    return spent


def mujoco_bare_realtime_factor(quick: bool) -> Figure:
    """``mj_step`` alone on the scene and trajectory of ``mujoco_realtime_factor`` (its inputs
    replayed): the engine's share; the gap to ``mujoco_realtime_factor`` is the world wrapper's
    (contacts to BioTac frames, events, bookkeeping). Median over the same trials."""
    sim_s = 2.0 if quick else 10.0
    factors = [sim_s / _bare_steps(sim_s, seed) for seed in range(2 if quick else 3)]
    return Figure.rate(factors, "x")


def _has_mujoco() -> bool:
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


# Without mujoco (a broken install) the figures are not listed, so 'bench' runs the others.
FIGURES = (
    {"mujoco_realtime_factor": mujoco_realtime_factor, "mujoco_bare_realtime_factor": mujoco_bare_realtime_factor}
    if _has_mujoco()
    else {}
)
