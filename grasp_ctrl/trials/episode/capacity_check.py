"""Before any trial: can the grasp carry each object at the configured currents and grip targets?

The statics of ``controller/grasp_capacity.py`` (the controller's grasp posture, friction cones,
every joint within its current limit x the servo model's torque per amp), with each grasping pad's normal force at
most its grip target (the object's ``tau_n`` through the controller's grip-target rule): the
largest weight that grasp carries, over the object's weight. Below 1 the object cannot be
lifted whatever the estimator; ``run`` names such objects (ratio and what binds), refuses them
on a Dynamixel hand (real or emulated) unless ``--force-capacity``, and flags them in a simulated run's
summary.
"""

from __future__ import annotations

import builtins
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from grasp_ctrl.config.actuation import current_limits_a, torque_limits_nm
from grasp_ctrl.config.checks import check_objects_for_hand
from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.controller.grasp_capacity import GRAVITY_M_S2, object_capacity
from grasp_ctrl.controller.grip_targets import grip_targets
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.registry import default_settings
from grasp_ctrl.errors import GraspCtrlError

#: A joint at this share of its torque limit, or a pad at this share of its target, binds.
BINDING_SHARE = 0.999


@dataclass(frozen=True)
class CapacityVerdict:
    """What the statics say about one object at the configured currents and grip targets."""

    object: str
    ratio: float  # the liftable weight over the object's weight (0: no grasp)
    binding: str  # what limits it: joint names (with current), grip targets, or why no grasp
    targets_n: dict[str, float]

    @property
    def carried(self) -> bool:
        return self.ratio >= 1.0

    @property
    def no_grasp(self) -> bool:
        """The pads cannot close on the object (or take the posture): there is no figure."""
        return self.ratio == 0.0 and self.binding.startswith("no grasp")

    def line(self) -> str:
        if self.no_grasp:  # no figure to print: say why instead
            return f"{self.object}: {self.binding}"
        return f"{self.object}: the grasp carries {self.ratio:.2f}x its weight (binding: {self.binding})"

    def to_json(self) -> dict[str, builtins.object]:  # builtins: the field ``object`` shadows it here
        return {
            "object": self.object,
            "ratio": round(self.ratio, 4),
            "binding": self.binding,
            "grip_targets_n": {k: round(v, 4) for k, v in self.targets_n.items()},
        }


def object_targets(hand: HandConfig, obj: ObjectProfile, settings: PaperSettings) -> dict[str, float]:
    """Each grasping finger's grip target (N), as the controller computes it for ``obj``."""
    vectors = np.array([f.task_vector_hand for f in hand.fingers], dtype=float)
    mask = np.array([f.grasp for f in hand.fingers])
    t = grip_targets(
        vectors,
        mask,
        obj.tau_n,
        obj.grip_targets or settings.grip_targets,
        obj.mass_kg,
        obj.mu,
        settings.grip_weight_margin,
    )
    return {f.name: float(t[i]) for i, f in enumerate(hand.fingers) if f.grasp}


def joint_limit_labels(hand: HandConfig) -> dict[str, str]:
    """Each joint's torque limit as the hand file sets it: a servo's current limit (``0.55 A``), a
    torque-controlled joint's torque (``0.237 N m``)."""
    currents = current_limits_a(hand)
    if currents is not None:
        return {name: f"{amps:g} A" for name, amps in currents.items()}
    return {j.name: f"{tau:.3g} N m" for j, tau in zip(hand.joints, torque_limits_nm(hand))}


def check_object(hand: HandConfig, obj: ObjectProfile, settings: PaperSettings | None = None) -> CapacityVerdict:
    targets = object_targets(hand, obj, settings or default_settings())
    try:
        cap, _, _ = object_capacity(hand, obj, normal_max_n=targets)
    except ValueError as exc:  # NoGrasp (the pads cannot close on it), a cap out of reach, ...
        return CapacityVerdict(obj.name, 0.0, f"no grasp: {exc}", targets)
    if not cap.loads:
        return CapacityVerdict(obj.name, 0.0, "no grasp: the pads do not reach the object", targets)
    limits = joint_limit_labels(hand)
    binds = [f"{ld.joint} at {limits[ld.joint]}" for ld in cap.loads if ld.torque_share >= BINDING_SHARE]
    binds += [
        f"{ld.finger}'s grip target {targets[ld.finger]:.2f} N"
        for ld in cap.loads
        if ld.normal_n >= BINDING_SHARE * targets[ld.finger]
    ]
    top = max(cap.loads, key=lambda ld: ld.torque_share)
    if top.torque_share < BINDING_SHARE:  # name the joint closest to its limit as well
        binds.append(f"most loaded joint {top.joint} at {100 * top.torque_share:.0f} % of {limits[top.joint]}")
    ratio = cap.weight_n / (obj.mass_kg * GRAVITY_M_S2)
    return CapacityVerdict(obj.name, ratio, ", ".join(binds), targets)


def check_objects(
    hand: HandConfig, objects: list[ObjectProfile], settings: PaperSettings | None = None
) -> list[CapacityVerdict]:
    return [check_object(hand, o, settings) for o in objects]


class CapacityRefused(GraspCtrlError):
    """A Dynamixel hand was asked to lift an object its grasp cannot carry (without --force-capacity)."""

    exit_status = 2


def preflight_capacity(
    hand: HandConfig,
    objects: list[ObjectProfile],
    settings: PaperSettings | None,
    on_hand: bool,
    force: bool,
    say: Callable[[str], None],
    source: str = "the object file",
) -> list[CapacityVerdict]:
    """The objects the grasp cannot carry, each named through ``say``. On a (real or emulated)
    Dynamixel hand they are refused (CapacityRefused) unless ``force``; in simulation they run.
    The objects are first checked against the hand (ConfigError naming ``source``'s key)."""
    check_objects_for_hand(objects, hand, source)
    short = [v for v in check_objects(hand, objects, settings) if not v.carried]
    if not short:
        return []
    names = "; ".join(v.line() for v in short)
    if on_hand and not force:
        stronger = "" if all(v.no_grasp for v in short) else "raise the current limits or tau_n (lift-capacity), "
        raise CapacityRefused(f"capacity: {names}; {stronger}leave the object out, or pass --force-capacity")
    for v in short:
        say(f"capacity: {v.line()}; its trials will likely fail" + (" (--force-capacity)" if on_hand else ""))
    return short
