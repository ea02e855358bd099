"""``trial_realtime_factor``: whole default mock trials, as the main job runs them.

Physics, sensing, estimation (the default policy), control and the tick log
written to disk, through ``run_sim_trial``; simulated seconds per wall-clock
second, one sample per trial over the default objects, after one warm-up trial
per object. The warm-up takes what a worker process pays once, not per trial:
loading or compiling the kernels, importing pyarrow, and the set-up a hand or
object needs once (the world's kinematics tables, the least-squares fit of a
capped object's reach posture, which imports scipy). ``p99`` is the slow tail
(Figure.rate).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from grasp_ctrl.bench.figure import Figure
from grasp_ctrl.config import load_hand
from grasp_ctrl.estimators.registry import DEFAULT_POLICY
from grasp_ctrl.files.paths import default_hand_file, default_objects_file
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.rigs.registry import TEST_WORLD
from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial, trial_seed
from grasp_ctrl.trials.runs.selection import select_objects


def trial_realtime_factor(quick: bool) -> Figure:
    hand = load_hand(default_hand_file())
    objects = select_objects(default_objects_file(), None, hand=hand.name)[: 2 if quick else None]
    make_estimator = estimator_factory(DEFAULT_POLICY, hand)
    kin = HandKinematics(hand)
    rounds = 1 if quick else 3
    factors = []
    with tempfile.TemporaryDirectory(prefix="grasp-bench-") as tmp:
        log = Path(tmp) / "trial_ticks.parquet"
        for obj in objects:  # warm-up: kernels, pyarrow, and each object's one-off set-up (a cap's posture fit)
            run_sim_trial(hand, obj, make_estimator, 0, DEFAULT_POLICY, log_path=log, kin=kin, backend=TEST_WORLD)
        for k in range(rounds):
            for obj in objects:
                t0 = time.perf_counter()
                res = run_sim_trial(
                    hand,
                    obj,
                    make_estimator,
                    trial_seed(0, obj.name, k),
                    DEFAULT_POLICY,
                    k,
                    log_path=log,
                    kin=kin,
                    backend=TEST_WORLD,
                )
                factors.append(res.sim_duration_s / (time.perf_counter() - t0))
    return Figure.rate(factors, "x")


FIGURES = {"trial_realtime_factor": trial_realtime_factor}
