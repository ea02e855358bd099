"""grip_load in MuJoCo: the object's friction falls mid-lift and the grip rises and holds.

The chips can's friction is lowered to 40 % of its value over 2 s once the lift has raised it
2 cm (a film of oil on the skin, say). The paper's controller keeps its grip and the can slides
out; grip_load feels the skin vibrate as the grasp starts to slide (PAC), lowers its friction
estimate to what the grasp held, raises every grip along the friction cone and carries the can
through. The controller never reads the world's friction.
"""

from __future__ import annotations

import numpy as np
import pytest

from grasp_ctrl.controller.registry import settings_for
from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial, trial_seed

pytest.importorskip("mujoco")

FRICTION_LEFT = 0.4
RAMP_S = 2.0


def _trial(hand, obj, controller: str, trial: int):
    seen: dict[str, float] = {}

    def lower_friction(world, ctrl) -> None:
        geoms = np.flatnonzero(world._object_geom)
        if "t0" not in seen and ctrl.state == "lift" and world.obj_z > 0.02:
            seen["t0"], seen["scale0"] = world.t, getattr(ctrl, "scale", 1.0)
            seen["mu0"] = float(world.model.geom_friction[geoms[0], 0])
        if "t0" in seen:
            done = min(1.0, (world.t - seen["t0"]) / RAMP_S)
            world.model.geom_friction[geoms, 0] = seen["mu0"] * (1.0 - done * (1.0 - FRICTION_LEFT))
            seen["scale"] = max(seen.get("scale", 0.0), getattr(ctrl, "scale", 1.0))
            seen["mu_hat"] = getattr(ctrl, "mu_hat", float("nan"))

    result = run_sim_trial(
        hand,
        obj,
        estimator_factory("oracle", hand),
        trial_seed(0, obj.name, trial),
        "oracle",
        trial,
        settings_for(controller),
        backend="mujoco",
        on_tick=lower_friction,
    )
    return result, seen


def test_the_grip_rises_and_holds_when_the_friction_falls_mid_lift(hand, objects):
    can = objects["chips_can"]
    held, seen = _trial(hand, can, "grip_load", 0)
    assert "t0" in seen, "the lift never raised the can 2 cm"
    assert held.success, held.reason
    assert seen["mu_hat"] < can.mu  # the estimate came down from the profile's
    assert seen["scale"] > seen["scale0"] + 0.1  # every grip rose from where the lift had it
    dropped, _ = _trial(hand, can, "paper", 0)
    assert not dropped.success and dropped.reason == "slipped"  # the paper's grip lets it go
