"""Figures of the MuJoCo backend: ``mujoco_realtime_factor`` (the world),
``mujoco_bare_realtime_factor`` (the world's ``mj_step`` calls alone, timed inside the same
trials) and ``mujoco_replayed_realtime_factor`` (the same steps replayed back to back).

The gap between the first two is the world wrapper's own work (contacts to BioTac frames,
events, the arm's mocap); the gap between the last two is what the controller's work between
control periods costs MuJoCo's step (caches it has to fill again), which no wrapper can remove.
Decision record 0013."""

from __future__ import annotations

import functools
import time
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from grasp_ctrl.bench.figure import Figure
from grasp_ctrl.config import load_hand, load_objects
from grasp_ctrl.controller.registry import settings_for
from grasp_ctrl.files.paths import default_hand_file, default_objects_file
from grasp_ctrl.rigs.registry import REFERENCE_WORLD
from grasp_ctrl.rigs.trial_builder import SimTrial, build_trial
from grasp_ctrl.sim.oracle import OracleEstimator

if TYPE_CHECKING:
    from grasp_ctrl.sim.mujoco.world import MuJoCoWorld

BENCH_OBJECT = "chips_can"


def _trial(seed: int, mujoco_module: Any = None) -> SimTrial:
    """The benchmark's oracle trial of the paper's controller on MuJoCo (``mujoco_module``: the
    module its world steps with)."""
    hand = load_hand(default_hand_file())
    obj = load_objects(default_objects_file(), hand.name)[BENCH_OBJECT]
    make_world = None
    if mujoco_module is not None:
        from grasp_ctrl.sim.mujoco.world import MuJoCoWorld

        def make_world(hand: Any, obj: Any, seed: int, params: Any) -> Any:
            world = MuJoCoWorld(hand, obj, seed, params)
            world._mj = mujoco_module
            return world

    return build_trial(
        hand,
        obj,
        seed,
        OracleEstimator,
        backend=REFERENCE_WORLD,
        settings=settings_for("paper"),
        make_world=make_world,
    )


class TimedSteps:
    """The mujoco module, with ``mj_step``'s wall time summed (``spent``, s)."""

    def __init__(self, mj: Any) -> None:
        self._mj = mj
        self.spent = 0.0

    def __getattr__(self, name: str) -> Any:
        return getattr(self._mj, name)

    def mj_step(self, m: Any, d: Any, nstep: int = 1) -> None:
        t0 = time.perf_counter()
        self._mj.mj_step(m, d, nstep)
        self.spent += time.perf_counter() - t0


def _timed_trial(sim_s: float, seed: int) -> tuple[float, float]:
    """Wall-clock seconds of the MuJoCo world's steps (physics, contacts, BioTac frames, events)
    over ``sim_s`` simulated seconds of an oracle trial, and of their ``mj_step`` calls alone
    within them; the controller's own time is not counted."""
    import mujoco

    timed = TimedSteps(mujoco)
    return _run(_trial(seed, timed), sim_s), timed.spent


def _run(trial: SimTrial, sim_s: float) -> float:
    """``trial`` for ``sim_s`` simulated seconds (the controller ticks until it is done), then
    closed; the wall-clock seconds of its world's steps."""
    world, ctrl = trial.world, trial.ctrl
    spent = 0.0
    for _ in range(round(sim_s / trial.kin.hand.dt)):
        t0 = time.perf_counter()
        world.step()
        spent += time.perf_counter() - t0
        if not ctrl.terminal:
            trial.tick(world.t)
    trial.close()
    return spent


@functools.cache
def _timed_trials(quick: bool) -> tuple[tuple[float, float], ...]:
    """``_timed_trial`` of the benchmark's trials (10 s each, 3 seeds; quick: 2 s, 2 seeds), once
    per process: both figures below come from the same trials, so that the load of a shared
    machine cannot make one of them look faster than the other."""
    sim_s = 2.0 if quick else 10.0
    return tuple(
        (sim_s / world_s, sim_s / engine_s)
        for world_s, engine_s in (_timed_trial(sim_s, seed) for seed in range(2 if quick else 3))
    )


def mujoco_realtime_factor(quick: bool) -> Figure:
    """Simulated seconds per wall-clock second of the MuJoCo world over a 10 s trial of the
    4-fingertip LEAP hand (grasp, lift, hold, start of lowering), median over 3 trials."""
    return Figure.rate([world for world, _ in _timed_trials(quick)], "x")


def mujoco_bare_realtime_factor(quick: bool) -> Figure:
    """``mj_step`` alone, timed inside the trials of ``mujoco_realtime_factor`` (the same runs):
    the engine's share of the world's time; the gap to ``mujoco_realtime_factor`` is the world
    wrapper's (contacts to BioTac frames, events, the arm's mocap). Median over the trials."""
    return Figure.rate([engine for _, engine in _timed_trials(quick)], "x")


class _StepRecorder:
    """The mujoco module, with ``mj_step`` noting the inputs (actuator goals, the arm's mocap
    position) it stepped with, so that the engine alone can replay the same trajectory."""

    def __init__(self, mj: Any) -> None:
        self._mj = mj
        self.inputs: list[tuple[np.ndarray, np.ndarray]] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self._mj, name)

    def mj_step(self, m: Any, d: Any, nstep: int = 1) -> None:
        # nstep steps with the same inputs: noted once each, replayed one step at a time
        self.inputs.extend([(d.ctrl.copy(), d.mocap_pos.copy())] * nstep)
        self._mj.mj_step(m, d, nstep)


def _replayed_steps(sim_s: float, seed: int) -> float:
    """Wall-clock seconds of ``mj_step`` alone over the steps of the same oracle trial as
    ``_timed_trial``, replayed back to back (the trial's inputs from its start state) with
    nothing between them: the engine on warm caches."""
    import mujoco

    recorder = _StepRecorder(mujoco)
    trial = _trial(seed, recorder)
    mj_world = cast("MuJoCoWorld", trial.world)  # backend=REFERENCE_WORLD (_trial)
    m, d = mj_world.model, mj_world.data
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    start = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, start, spec)
    _run(trial, sim_s)
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


def mujoco_replayed_realtime_factor(quick: bool) -> Figure:
    """``mj_step`` alone on the scene and trajectory of ``mujoco_realtime_factor``, its inputs
    replayed back to back: the engine's best case. Median over the same trials."""
    sim_s = 2.0 if quick else 10.0
    factors = [sim_s / _replayed_steps(sim_s, seed) for seed in range(2 if quick else 3)]
    return Figure.rate(factors, "x")


def _has_mujoco() -> bool:
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


# Without mujoco (a broken install) the figures are not listed, so 'bench' runs the others.
FIGURES = (
    {
        "mujoco_realtime_factor": mujoco_realtime_factor,
        "mujoco_bare_realtime_factor": mujoco_bare_realtime_factor,
        "mujoco_replayed_realtime_factor": mujoco_replayed_realtime_factor,
    }
    if _has_mujoco()
    else {}
)
