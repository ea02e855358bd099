"""Judge a mock trial from the simulated ground truth, not from the estimates."""

from __future__ import annotations

from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.sim.world_api import World

LIFTED_FRACTION = 0.8  # of the commanded lift height
RESTING_Z_M = 0.001


def judge(world: World, controller: GraspController) -> tuple[bool, str | None]:
    """(success, failure reason). Physical damage outranks the controller's own view."""
    if world.crushed:
        return False, "crushed"
    if world.knocked_over:
        return False, "knocked_over"
    fell_in = [e.detail.rsplit(" while ", 1)[-1] for e in world.events if e.kind == "fell"]
    if controller.state == "fault":
        if any(phase in ("lift", "hold") for phase in fell_in):
            return False, "slipped"
        return False, controller.failure_reason or "aborted"
    if world.max_obj_z < LIFTED_FRACTION * controller.obj.lift_height_m:
        return False, "slipped"
    if any(phase in ("lift", "hold") for phase in fell_in):
        return False, "slipped"
    if any(phase in ("lower", "release", "retreat", "done") for phase in fell_in):
        return False, "dropped_early"
    if world.obj_z > RESTING_Z_M:
        return False, "not_released"
    return True, None
