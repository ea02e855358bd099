"""The lift-and-place controllers by name (``run --controller NAME``, ``ControllerSettings.controller``).

- ``paper``: the paper's controller (section V): a fixed grasp per object, a ramp to a fixed tau,
  a lift at constant speed (controller/machine.py). The paper preset runs it, so Fig. 6 stays
  the paper's experiment.
- ``grip_load``: the paper's states plus a load phase, grip-load coordination and a slip response
  from the estimated force vectors (controller/grip_load.py, docs/controller.md).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from grasp_ctrl.errors import UsageError

if TYPE_CHECKING:
    from grasp_ctrl.controller.machine import GraspController
    from grasp_ctrl.controller.settings import ControllerSettings

CONTROLLER_NAMES: tuple[str, ...] = ("paper", "grip_load")
DEFAULT_CONTROLLER = "grip_load"  # it measures better under both variation profiles (docs/results.md)

# Each controller's own choices where ControllerSettings' defaults (grip_load's) are not its own:
# the paper's controller squeezes along the closing vectors toward tau on every fingertip.
CONTROLLER_CHOICES: dict[str, dict[str, Any]] = {
    "paper": {
        "stiffness_aware_squeeze": False,
        "grip_targets": "equal",
        "open_s": 0.4,
        "release_back_off_m_s": 0.05,
        "lower_speed_m_s": 0.015,
    },
    "grip_load": {},
}


def controller_class(name: str) -> type[GraspController]:
    """The class behind ``name``, or a one-line error naming the controllers."""
    if name == "paper":
        from grasp_ctrl.controller.machine import GraspController

        return GraspController
    if name == "grip_load":
        from grasp_ctrl.controller.grip_load import GripLoadController

        return GripLoadController
    raise UsageError(f"--controller {name!r}: unknown (one of {', '.join(CONTROLLER_NAMES)})")


def settings_for(name: str, **overrides: Any) -> ControllerSettings:
    """The settings a run of controller ``name`` starts from: ``ControllerSettings``' defaults
    with the controller's own choices (``CONTROLLER_CHOICES``), then ``overrides``."""
    import dataclasses

    from grasp_ctrl.controller.settings import ControllerSettings

    controller_class(name)  # one line naming the controllers when unknown
    return dataclasses.replace(ControllerSettings(controller=name), **{**CONTROLLER_CHOICES[name], **overrides})


def make_controller(
    hand: Any, obj: Any, reach_pose_world: Any, settings: Any = None, kin: Any = None
) -> GraspController:
    """The controller that ``settings.controller`` names (the default settings' when None)."""
    from grasp_ctrl.controller.settings import ControllerSettings

    settings = settings or ControllerSettings()
    return controller_class(settings.controller)(hand, obj, reach_pose_world, settings, kin)
