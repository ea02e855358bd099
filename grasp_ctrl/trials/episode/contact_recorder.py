"""Record where the hand's grasps press its fingertips: oracle trials in MuJoCo (``grasp-contacts``)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, cast

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.rigs.registry import REFERENCE_WORLD
from grasp_ctrl.sim.biotac.grasp_contacts import DEFAULT_EVERY, DEFAULT_SEED, MIN_FORCE_N, GraspContacts
from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial, trial_seed

if TYPE_CHECKING:
    from grasp_ctrl.controller.machine import GraspController
    from grasp_ctrl.sim.mujoco.world import MuJoCoWorld
    from grasp_ctrl.sim.world_api import World


def record_grasp_contacts(
    hand: HandConfig,
    objects: Sequence[ObjectProfile],
    trials: int,
    seed: int = DEFAULT_SEED,
    every: int = DEFAULT_EVERY,
    progress: Callable[[str], None] | None = None,
) -> GraspContacts:
    """Run ``trials`` oracle trials per object in MuJoCo and keep the fingertips' object
    contacts every ``every`` control periods."""
    if trials < 1 or every < 1:
        raise ValueError("trials and every must be positive")
    rows: dict[str, list] = {k: [] for k in ("object", "finger", "t", "p", "n", "f")}
    oracle = estimator_factory("oracle", hand)
    for obj in objects:
        for trial in range(trials):
            ticks = [0]

            def keep(world: World, ctrl: GraspController, obj_name: str = obj.name, ticks: list[int] = ticks) -> None:
                ticks[0] += 1
                if ticks[0] % every:
                    return
                mj = cast("MuJoCoWorld", world)  # backend=REFERENCE_WORLD below
                points, normals, forces, touching = mj.skin_contacts()
                for i in np.flatnonzero(touching):
                    if float(np.linalg.norm(forces[i])) < MIN_FORCE_N:
                        continue
                    rows["object"].append(obj_name)
                    rows["finger"].append(mj.fingers[i])
                    rows["t"].append(mj.t)
                    rows["p"].append(points[i])
                    rows["n"].append(normals[i])
                    rows["f"].append(forces[i])

            result = run_sim_trial(
                hand,
                obj,
                oracle,
                trial_seed(seed, obj.name, trial),
                "oracle",
                trial,
                backend=REFERENCE_WORLD,
                on_tick=keep,
            )
            if progress is not None:
                progress(
                    f"{obj.name} trial {trial}: {'success' if result.success else result.reason}, "
                    f"{len(rows['t'])} contacts so far"
                )
    n = len(rows["t"])
    return GraspContacts(
        np.array(rows["object"], dtype=object),
        np.array(rows["finger"], dtype=object),
        np.array(rows["t"], dtype=float),
        np.array(rows["p"], dtype=float).reshape(n, 3),
        np.array(rows["n"], dtype=float).reshape(n, 3),
        np.array(rows["f"], dtype=float).reshape(n, 3),
    )
