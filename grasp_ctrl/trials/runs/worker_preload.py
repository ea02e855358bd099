"""Imported once by the fork server of ``run --jobs N`` (see series.parallel_trials).

Importing the trial code and loading its compiled kernels take about as long as
a few trials; done here once, every worker process forked from the server starts
with both ready. Only the kernels are touched (the first control ticks of a mock
trial on the default hand, with a stand-in policy and a tick log that is never
written, and the kernels those ticks do not reach), and the reach postures of the
default objects with a cap are fitted (scipy's least squares, kept per hand); no
policy is loaded, so no inference session or thread is shared by the forked workers.

First of all the server asks to die with the command that started it, and each worker
with the server (process_cleanup.forkserver_dies_with_command): a command killed
outright leaves no fork server still importing, nor workers waiting for work.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from grasp_ctrl.trials.runs.process_cleanup import forkserver_dies_with_command

if TYPE_CHECKING:
    import numpy as np


class _NoForce:
    """A stand-in policy for the warm-up ticks: no force."""

    name = "warm-up"
    has_variance = False

    def estimate(self, tared: np.ndarray, fingers: Sequence[str]):  # noqa: ANN201
        import numpy as np

        from grasp_ctrl.estimators.base import Estimate

        return Estimate(f_sensor=np.zeros((len(fingers), 3)))


def warm_kernels() -> None:
    import numpy as np

    from grasp_ctrl.config import load_hand, load_objects
    from grasp_ctrl.config.sensor_layout import FRAME_LEN
    from grasp_ctrl.controller.machine import raised_reach_posture
    from grasp_ctrl.controller.motion import FingertipMotion
    from grasp_ctrl.controller.registry import settings_for
    from grasp_ctrl.files.paths import default_hand_file, default_objects_file
    from grasp_ctrl.loop.ticklog import TickLog
    from grasp_ctrl.numeric.finite import all_finite
    from grasp_ctrl.numeric.limits import limit_goal
    from grasp_ctrl.rigs.registry import TEST_WORLD
    from grasp_ctrl.rigs.trial_builder import build_trial
    from grasp_ctrl.tactile.tare import scatter_rows, tare_and_gate

    hand = load_hand(default_hand_file())
    objects = load_objects(default_objects_file(), hand.name)
    obj = next(iter(objects.values()))
    for capped in objects.values():  # the reach postures of capped objects: a scipy fit each, kept per hand
        if capped.cap is not None:
            raised_reach_posture(hand, capped.cap.finger, capped.cap.contact_height_m - capped.grasp_height_m)
    # a trial's first ticks: the sensing pipeline's and the pad IK's kernels
    trial = build_trial(hand, obj, 0, lambda world: _NoForce(), backend=TEST_WORLD, settings=settings_for("paper"))
    pipeline, kin = trial.pipeline, trial.kin
    n = len(hand.fingers)
    log = TickLog(Path("unwritten_ticks.parquet"), pipeline.names, len(hand.joints), truth=True)  # never closed
    peaks = np.zeros((3, n))
    for _ in range(hand.tactile.tare_frames + 3):  # past the tare: the tick's compiled halves
        trial.record(*trial.step(), peaks, log)
    motion = FingertipMotion(hand, kin)
    motion.advance_all(np.full(n, 1e-4))
    FingertipMotion(hand, kin, stiffness_aware=True).squeeze_all(np.full(n, 1e-4), motion.q_goal.copy(), 1e-4)
    motion.next_goal()
    motion.ik.sensor_forces(motion.q_goal, np.zeros((n, 3)))
    limit_goal(motion.q_goal, motion.q_goal, 0.1, motion.lower, motion.upper, np.empty_like(motion.q_goal))
    all_finite(motion.q_goal)
    tare_and_gate(
        np.zeros((n, FRAME_LEN)),
        np.zeros((n, FRAME_LEN)),
        np.zeros(n, dtype=np.int64),
        10.0,
        10,
        np.empty((n, FRAME_LEN)),
        np.empty(n, dtype=bool),
    )
    scatter_rows(np.zeros((1, 3)), 1, np.zeros((n, 3)))  # some fingertips in contact


forkserver_dies_with_command()  # before the seconds of importing and compiling below
try:
    warm_kernels()
except Exception:  # a missing default file, say: the workers then load the kernels themselves
    pass
