"""The lift-and-place controllers by name (``run --controller NAME``), each with its settings class
and its table of states and transitions, and the flat settings table run.json and trial records keep.

- ``paper``: the paper's controller (section V): a fixed grasp per object, a ramp to a fixed tau,
  a lift at constant speed (controller/machine.py, controller/paper_settings.py). The paper preset
  runs it, so Fig. 6 stays the paper's experiment.
- ``grip_load``: the paper's states plus a load phase, grip-load coordination and a slip response
  from the estimated force vectors (controller/grip_load.py, controller/grip_load_settings.py,
  docs/controller.md).

Adding a controller: a module with its ``GraspController`` subclass (its own ``STATES``,
``TRANSITIONS`` and guards as it needs) and its settings class (a ``PaperSettings`` subclass named
by the controller's ``SETTINGS``, its ``controller`` the new name), and one line in ``CONTROLLERS``.
"""

from __future__ import annotations

import functools
import importlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from grasp_ctrl.errors import ConfigError, UsageError

if TYPE_CHECKING:
    from grasp_ctrl.config.hand import HandConfig
    from grasp_ctrl.controller.machine import GraspController
    from grasp_ctrl.controller.paper_settings import PaperSettings

#: Each controller's class as ``module:class``, imported on first use: the names (every
#: command's ``--controller`` choices) cost no import of the controllers.
CONTROLLERS: dict[str, str] = {
    "paper": "grasp_ctrl.controller.machine:GraspController",
    "grip_load": "grasp_ctrl.controller.grip_load:GripLoadController",
}
DEFAULT_CONTROLLER = "grip_load"  # it measures better under both variation profiles (docs/results.md)


@dataclass(frozen=True)
class ControllerEntry:
    """A registered controller: its class, settings class and table of states and transitions."""

    name: str
    controller: type[GraspController]

    @property
    def settings(self) -> type[PaperSettings]:
        return self.controller.SETTINGS

    @property
    def states(self) -> list[str]:
        return self.controller.STATES

    @property
    def transitions(self) -> list[tuple[str, str, str, str | None]]:
        return self.controller.TRANSITIONS


def controller_names() -> tuple[str, ...]:
    return tuple(CONTROLLERS)


def unknown_controller(name: str) -> UsageError:
    """The one-line error for a controller name that is not registered."""
    return UsageError(f"--controller {name!r}: unknown (one of {', '.join(controller_names())})")


def entry(name: str) -> ControllerEntry:
    """The registered controller ``name``, or a one-line error naming the controllers."""
    if name not in CONTROLLERS:
        raise unknown_controller(name)
    return _load(name, CONTROLLERS[name])


@functools.cache
def _load(name: str, where: str) -> ControllerEntry:
    module, _, attr = where.partition(":")
    cls = getattr(importlib.import_module(module), attr)
    if cls.SETTINGS.controller != name:  # the settings' flat table names their controller
        raise TypeError(
            f"{where}: its settings {cls.SETTINGS.__name__} are for {cls.SETTINGS.controller!r}, not {name!r}"
        )
    return ControllerEntry(name, cls)


def controller_class(name: str) -> type[GraspController]:
    """The class behind ``name``, or a one-line error naming the controllers."""
    return entry(name).controller


def settings_for(name: str, hand: HandConfig | None = None, **overrides: Any) -> PaperSettings:
    """The settings a run of controller ``name`` starts from: its settings class's defaults, the
    hand file's ``[controllers.NAME]`` choices (checked), then ``overrides`` (flat keys)."""
    cls = entry(name).settings
    own: dict[str, Any] = {}
    if hand is not None:
        for table, _ in hand.controller_choices:  # a misspelt table would be ignored without a word
            if table not in CONTROLLERS:
                raise ConfigError(
                    hand.path, f"controllers.{table}", f"a controller's name, one of {', '.join(controller_names())}"
                )
        choices = hand.choices_of(name)
        if "controller" in choices:
            raise ConfigError(hand.path, f"controllers.{name}.controller", "not a setting here (the table's name is)")
        own = cls.check(choices, hand.path, f"controllers.{name}")
    return cls().replace(**{**own, **overrides})


def default_settings() -> PaperSettings:
    """The default controller's settings (without a hand file's choices)."""
    return settings_for(DEFAULT_CONTROLLER)


def make_controller(
    hand: Any, obj: Any, reach_pose_world: Any, settings: PaperSettings | None = None, kin: Any = None
) -> GraspController:
    """The controller that ``settings.controller`` names (the default controller's when None)."""
    settings = settings or default_settings()
    return controller_class(settings.controller)(hand, obj, reach_pose_world, settings, kin)


# ----- the flat table of run.json and trial records ---------------------------------------------
def flat_defaults() -> dict[str, Any]:
    """Every registered controller's settings by flat key, each at the default of the first
    controller that has it, in the flat table's order (each controller's keys in its own order)."""
    return dict(_flat_defaults(tuple(CONTROLLERS.items())))


@functools.cache
def _flat_defaults(registered: tuple[tuple[str, str], ...]) -> tuple[tuple[str, Any], ...]:
    keys: list[str] = []
    defaults: dict[str, Any] = {}
    for name, _ in registered:
        table = entry(name).settings().as_flat_dict()
        del table["controller"]
        pos = 0
        for key, value in table.items():
            if key in defaults:
                pos = keys.index(key) + 1
                continue
            keys.insert(pos, key)
            defaults[key] = value
            pos += 1
    return tuple((key, defaults[key]) for key in keys)


def flat_settings(settings: PaperSettings) -> dict[str, Any]:
    """``settings`` as run.json and trial records keep them: one flat table of every registered
    controller's settings (``controller`` first), those of ``settings``' controller at its values,
    the others at their defaults (``flat_defaults``), so that every controller's records have the
    same keys."""
    own = settings.as_flat_dict()
    out = {"controller": own.pop("controller")}
    for key, default in flat_defaults().items():
        out[key] = own.pop(key, default)
    out.update(own)  # (an unregistered controller's own keys)
    return out


def settings_from_flat(values: Any, where: str) -> PaperSettings:
    """The settings of a flat table (run.json's ``settings``): its ``controller``'s class with its
    keys (checked: ``ControllerSettings.check``); another registered controller's keys are checked
    by that controller's rules and left out. A run written before the controllers had names ran
    the paper's, and resumes with it."""
    if not isinstance(values, Mapping):
        raise UsageError(f"{where}: settings: a table of controller settings")
    name = values.get("controller", "paper")
    if not isinstance(name, str) or name not in CONTROLLERS:
        raise UsageError(f"{where}: settings.controller: one of {', '.join(controller_names())} (got {name!r})")
    cls = entry(name).settings
    own_keys = set(cls.flat_keys())
    own = {k: v for k, v in values.items() if k in own_keys}
    for key, value in values.items():
        if key == "controller" or key in own_keys:
            continue
        owner = next((entry(n).settings for n in CONTROLLERS if key in entry(n).settings.flat_keys()), None)
        if owner is None:
            known = ", ".join(sorted(["controller", *flat_defaults()]))
            raise UsageError(f"{where}: settings.{key}: a known setting (one of {known})")
        owner.check({key: value}, where)
    return cls.from_flat(own, where)
