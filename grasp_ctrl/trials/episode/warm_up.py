"""The compiled kernels of a trial's control tick, loaded before a trial needs them.

numba loads each cached kernel on its first call, tens of milliseconds apiece. In a simulated
trial that only costs time; on the wall clock (a real hand, or ``--realtime``) it stalls the first
trial's control loop by up to a tenth of a second, long enough for a stale-sensor fault. So the
fork server of ``run --jobs N`` (trials/runs/worker_preload.py) and the wall-clock and hand trials
(before their first trial) touch them here: the first control ticks of a mock trial on the
default hand, with a stand-in policy and a tick log that is never written, and the kernels those
ticks do not reach; and the reach postures of the default objects with a cap are fitted. No
policy is loaded, so no inference session or thread is shared by forked workers. A wall-clock
dry run also steps a throwaway copy of its simulated world (``warm_world``).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

    from grasp_ctrl.config.hand import HandConfig
    from grasp_ctrl.controller.paper_settings import PaperSettings


WARM_TRIAL_S = 8.0  # the most simulated time a warm-up trial runs to reach the lift


class _NoForce:
    """A stand-in policy for the warm-up ticks: no force."""

    name = "warm-up"
    has_variance = False

    def estimate(self, tared: np.ndarray, fingers: Sequence[str]):  # noqa: ANN201
        import numpy as np

        from grasp_ctrl.estimators.base import Estimate

        return Estimate(f_sensor=np.zeros((len(fingers), 3)))


def warm_kernels(hand: HandConfig | None = None, settings: PaperSettings | None = None, make_estimator=None) -> None:  # noqa: ANN001
    """The first ticks of a mock trial of ``hand`` (default: the default hand file's) with the
    controller ``settings`` choose (default: the paper's) and the policy ``make_estimator`` makes
    for a world (default: a stand-in without force), then the kernels those ticks do not reach.
    A run's own hand, controller and policy call the kernels with its own argument types: those
    are what a wall-clock trial needs loaded."""
    import numpy as np

    from grasp_ctrl.config import load_objects
    from grasp_ctrl.config.sensor_layout import FRAME_LEN
    from grasp_ctrl.controller.machine import raised_reach_posture
    from grasp_ctrl.controller.motion import FingertipMotion
    from grasp_ctrl.controller.registry import settings_for
    from grasp_ctrl.files.paths import default_objects_file
    from grasp_ctrl.loop.ticklog import TickLog
    from grasp_ctrl.numeric.finite import all_finite
    from grasp_ctrl.numeric.limits import limit_goal
    from grasp_ctrl.rigs.registry import TEST_WORLD
    from grasp_ctrl.rigs.trial_builder import build_trial
    from grasp_ctrl.tactile.tare import scatter_rows, tare_and_gate

    hand = hand or _default_hand()
    objects = load_objects(default_objects_file(), hand.name)
    obj = next(iter(objects.values()))
    for capped in objects.values():  # the reach postures of capped objects: a scipy fit each, kept per hand
        if capped.cap is not None:
            raised_reach_posture(hand, capped.cap.finger, capped.cap.contact_height_m - capped.grasp_height_m)
    # a trial's first ticks: the sensing pipeline's and the pad IK's kernels
    trial = build_trial(
        hand,
        obj,
        0,
        make_estimator or (lambda world: _NoForce()),
        backend=TEST_WORLD,
        settings=settings or settings_for("paper"),
    )
    pipeline, kin = trial.pipeline, trial.kin
    n = len(hand.fingers)
    log = TickLog(Path("unwritten_ticks.parquet"), pipeline.names, len(hand.joints), truth=True)  # never closed
    peaks = np.zeros((3, n))
    for _ in range(hand.tactile.tare_frames + 3):  # past the tare: the tick's compiled halves
        trial.record(*trial.step(), peaks, log)
    if make_estimator is not None:
        # with a policy that sees the contacts: on through the close, the ramp and into the lift,
        # where the policy's, the placed forces' and the squeeze's kernels run (a mock trial's
        # few simulated seconds, a fraction of a second here)
        for _ in range(int(round(WARM_TRIAL_S / hand.dt))):
            if trial.ctrl.terminal or trial.ctrl.state in ("lift", "hold"):
                break
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


def warm_world(make_world, hand: HandConfig, params: object = None, steps: int = 3) -> bool:  # noqa: ANN001
    """An arm command and a few steps of a throwaway world from ``make_world`` (the first default
    object), so that the simulated world's own kernels (MuJoCo's contacts to BioTac frames, the
    wrist target's check) are loaded before a wall-clock trial's first tick steps the real one;
    False (nothing raised) when it could not."""
    try:
        from grasp_ctrl.config import load_objects
        from grasp_ctrl.files.paths import default_objects_file

        obj = next(iter(load_objects(default_objects_file(), hand.name).values()))
        world = make_world(hand, obj, 0, params)
        try:
            world.palm_target = world.palm_target.copy()  # the arm's command, as the first tick's
            for _ in range(steps):
                world.step()
        finally:
            world.close()
    except Exception:
        return False
    return True


@functools.cache
def warm_kernels_once(
    hand: HandConfig | None = None, settings: PaperSettings | None = None, policy: str | None = None
) -> bool:
    """``warm_kernels`` once per process for each hand, settings and policy spec (the policy
    loaded here for its own mock trial); False (nothing raised) when it could not run (a missing
    default object file, say): the kernels then load on their first call."""
    try:
        make_estimator = None
        if policy is not None:
            from grasp_ctrl.trials.episode.estimators import estimator_factory

            make_estimator = estimator_factory(policy, hand or _default_hand(), 1)
        warm_kernels(hand, settings, make_estimator)
    except Exception:
        return False
    return True


def _default_hand() -> HandConfig:
    from grasp_ctrl.config import load_hand
    from grasp_ctrl.files.paths import default_hand_file

    return load_hand(default_hand_file())
