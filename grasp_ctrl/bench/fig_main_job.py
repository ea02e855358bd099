"""Figures of the main job's trial: ``main_job_realtime_factor`` and, timed inside the same
trials, ``main_job_mujoco_step_realtime_factor``.

The trial is the one ``python launch.py`` runs: MuJoCo, the default controller (grip_load)
and policy, the default variation profile (bench), the tick log written to disk, through
``sim_trial_fn`` as a run's worker calls it. The first figure is simulated seconds per
wall-clock second of the whole trial; the second counts only its ``mj_step`` calls, so the
ratio of the two is the share of the trial's time that is MuJoCo's own. One sample per trial
over the default objects, after one warm-up trial per object (what a worker pays once: the
scene's first compile, the kernels, pyarrow).
"""

from __future__ import annotations

import functools
import tempfile
import time
from pathlib import Path
from typing import Any

from grasp_ctrl.bench.fig_mujoco import TimedSteps
from grasp_ctrl.bench.figure import Figure
from grasp_ctrl.config import load_hand
from grasp_ctrl.estimators.registry import DEFAULT_POLICY
from grasp_ctrl.files.paths import default_hand_file, default_objects_file
from grasp_ctrl.rigs.registry import REFERENCE_WORLD
from grasp_ctrl.sim.variation import DEFAULT_VARIATION, variation
from grasp_ctrl.trials.episode.runner import sim_trial_fn, trial_seed
from grasp_ctrl.trials.runs.selection import select_objects


@functools.cache
def _main_job_trials(quick: bool) -> tuple[tuple[float, float], ...]:
    """Per trial: (simulated s per wall s of the whole trial, of its ``mj_step`` calls alone).
    Once per process: both figures come from the same trials, so that the load of a shared
    machine cannot make one look faster than the other."""
    import mujoco

    from grasp_ctrl.sim.mujoco.world import MuJoCoWorld

    timed = TimedSteps(mujoco)

    def make_world(hand: Any, obj: Any, seed: int, params: Any) -> Any:
        world = MuJoCoWorld(hand, obj, seed, params)
        world._mj = timed
        return world

    hand = load_hand(default_hand_file())
    objects = select_objects(default_objects_file(), None, hand=hand.name)[: 2 if quick else None]
    run = sim_trial_fn(
        hand, [DEFAULT_POLICY], backend=REFERENCE_WORLD, make_world=make_world, variation=variation(DEFAULT_VARIATION)
    )
    rounds = 1 if quick else 2
    samples = []
    with tempfile.TemporaryDirectory(prefix="grasp-bench-") as tmp:
        log = Path(tmp) / "trial_ticks.parquet"
        for obj in objects:  # warm-up: the scene's first compile, kernels, pyarrow
            run(DEFAULT_POLICY, obj, 0, trial_seed(0, obj.name, 0), log)
        for k in range(rounds):
            for obj in objects:
                timed.spent = 0.0
                t0 = time.perf_counter()
                record = run(DEFAULT_POLICY, obj, k, trial_seed(1, obj.name, k), log)
                wall = time.perf_counter() - t0
                sim_s = float(record["sim_duration_s"])
                samples.append((sim_s / wall, sim_s / max(timed.spent, 1e-9)))
    return tuple(samples)


def main_job_realtime_factor(quick: bool) -> Figure:
    """Simulated seconds per wall-clock second of the main job's trial (MuJoCo, grip_load, the
    default policy, bench, tick log on), median over the default objects' trials."""
    return Figure.rate([whole for whole, _ in _main_job_trials(quick)], "x")


def main_job_mujoco_step_realtime_factor(quick: bool) -> Figure:
    """``mj_step`` alone, timed inside the trials of ``main_job_realtime_factor``: what the trial
    would reach if MuJoCo's steps were all it did."""
    return Figure.rate([engine for _, engine in _main_job_trials(quick)], "x")


FIGURES = {
    "main_job_realtime_factor": main_job_realtime_factor,
    "main_job_mujoco_step_realtime_factor": main_job_mujoco_step_realtime_factor,
}
