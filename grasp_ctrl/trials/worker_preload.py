"""Imported once by the fork server of ``run --jobs N`` (see runner.parallel_trials).

Importing the trial code and loading its compiled kernels take about as long as
a few trials; done here once, every worker process forked from the server starts
with both ready. Only the kernels are touched (one world step, IK step, goal
step, force rotation, finiteness check and tare on the default hand), and the
reach postures of the default objects with a cap are fitted (scipy's least
squares, kept per hand); no policy is loaded, so no inference session or thread
is shared by the forked workers.
"""

from __future__ import annotations

import numpy as np


def warm_kernels() -> None:
    from grasp_ctrl.config import load_hand, load_objects
    from grasp_ctrl.controller.machine import raised_reach_posture
    from grasp_ctrl.controller.motion import FingertipMotion
    from grasp_ctrl.finite import all_finite
    from grasp_ctrl.kinematics.chain import HandKinematics
    from grasp_ctrl.limits import limit_goal
    from grasp_ctrl.paths import default_hand_file, default_objects_file
    from grasp_ctrl.sim.world import MockWorld
    from grasp_ctrl.tactile.layout import FRAME_LEN
    from grasp_ctrl.tactile.tare import tare_and_gate

    hand = load_hand(default_hand_file())
    objects = load_objects(default_objects_file())
    obj = next(iter(objects.values()))
    for capped in objects.values():   # the reach postures of capped objects: a scipy fit each, kept per hand
        if capped.cap is not None:
            raised_reach_posture(hand, capped.cap.finger, capped.cap.contact_height_m - capped.grasp_height_m)
    MockWorld(hand, obj, 0).step()
    kin = HandKinematics(hand)
    motion = FingertipMotion(hand, kin)
    motion.advance_all(np.full(len(hand.fingers), 1e-4))
    motion.next_goal()
    motion.ik.sensor_forces(motion.q_goal, np.zeros((len(hand.fingers), 3)))
    limit_goal(motion.q_goal, motion.q_goal, 0.1, motion.lower, motion.upper, np.empty_like(motion.q_goal))
    all_finite(motion.q_goal)
    n = len(hand.fingers)
    tare_and_gate(np.zeros((n, FRAME_LEN)), np.zeros((n, FRAME_LEN)), np.zeros(n, dtype=np.int64), 10.0, 10,
                  np.empty((n, FRAME_LEN)), np.empty(n, dtype=bool))


try:
    warm_kernels()
except Exception:   # a missing default file, say: the workers then load the kernels themselves
    pass
