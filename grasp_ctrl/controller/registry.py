"""The lift-and-place controllers by name (``run --controller NAME``, ``ControllerSettings.controller``).

- ``paper``: the paper's controller (section V): a fixed grasp per object, a ramp to a fixed tau,
  a lift at constant speed (controller/machine.py). The paper preset runs it, so Fig. 6 stays
  the paper's experiment.
- ``grip_load``: the paper's states plus a load phase, grip-load coordination and a slip response
  from the estimated force vectors (controller/grip_load.py, docs/controller.md).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from grasp_ctrl.controller.settings import unknown_controller

if TYPE_CHECKING:
    from grasp_ctrl.controller.machine import GraspController


def controller_class(name: str) -> type[GraspController]:
    """The class behind ``name``, or a one-line error naming the controllers."""
    if name == "paper":
        from grasp_ctrl.controller.machine import GraspController

        return GraspController
    if name == "grip_load":
        from grasp_ctrl.controller.grip_load import GripLoadController

        return GripLoadController
    raise unknown_controller(name)


def make_controller(
    hand: Any, obj: Any, reach_pose_world: Any, settings: Any = None, kin: Any = None
) -> GraspController:
    """The controller that ``settings.controller`` names (the default settings' when None)."""
    from grasp_ctrl.controller.settings import ControllerSettings

    settings = settings or ControllerSettings()
    return controller_class(settings.controller)(hand, obj, reach_pose_world, settings, kin)
