"""Checks that span two files: the object profiles against the hand they run on.

Each file is valid on its own (its loader checks it); these rules need both,
so they run before a run starts (``run``, ``tune``, ``run --resume``).
"""

from __future__ import annotations

from collections.abc import Sequence

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.errors import ConfigError


def check_objects_for_hand(objects: Sequence[ObjectProfile], hand: HandConfig, source: str) -> None:
    """Raise ConfigError naming ``source`` and ``objects.NAME.KEY`` for the first broken rule."""
    limit = hand.safety.max_fingertip_force_n
    grasping = [f.name for f in hand.fingers if f.grasp]
    for obj in objects:
        key = f"objects.{obj.name}."
        if obj.tuned_for is not None and obj.tuned_for != hand.name:  # another hand's thresholds
            raise ConfigError(
                source,
                f"{key}hands.{obj.tuned_for}",
                f"profiles resolved for hand {hand.name!r} (these carry {obj.tuned_for!r}'s thresholds: "
                f"load the object file with the hand it runs on)",
            )
        if obj.tau_n >= limit:
            raise ConfigError(
                source,
                key + "tau_n",
                f"a grip target below safety.max_fingertip_force_n = {limit:g} N of hand "
                f"{hand.name!r} (got {obj.tau_n:g} N: every grasp would end as overforce)",
            )
        if obj.cap is not None and obj.cap.finger not in grasping:
            raise ConfigError(
                source,
                key + "cap.finger",
                f"a grasping finger of hand {hand.name!r} ({', '.join(grasping)}; got {obj.cap.finger!r})",
            )
        check_posture_offsets(obj, hand, source)
        above = lift_above_arm(obj, hand)
        if above is not None:
            raise ConfigError(source, key + "lift_height_m", above)


def palm_lift_top_m(obj: ObjectProfile, hand: HandConfig) -> float:
    """The palm's height (m, world) at the top of the lift: the controller's reach pose (the grasp
    height plus ``approach_offset_m``, the hand's ``palm_above_contact_m`` higher) plus the lift."""
    return obj.grasp_height_m + obj.approach_offset_m + hand.grasp.palm_above_contact_m + obj.lift_height_m


def lift_above_arm(obj: ObjectProfile, hand: HandConfig) -> str | None:
    """Why ``obj``'s lift cannot be done by ``hand``'s arm, or None: the arm clamps the palm at
    ``arm.z_max_m``, so a lift above it never arrives and its trials end with a misleading reason."""
    top, z_max = palm_lift_top_m(obj, hand), hand.arm.z_max_m
    if top <= z_max + 1e-9:
        return None
    room = max(z_max - (top - obj.lift_height_m), 0.0)
    return (
        f"a lift_height_m of at most {room:.3f} m: the palm must stay at or below arm.z_max_m = {z_max:g} m "
        f"of hand {hand.name!r}, and {obj.lift_height_m:g} m takes it to {top:.3f} m (grasp_height_m "
        f"{obj.grasp_height_m:g} + approach_offset_m {obj.approach_offset_m:g} + grasp.palm_above_contact_m "
        f"{hand.grasp.palm_above_contact_m:g} + lift_height_m {obj.lift_height_m:g})"
    )


def check_posture_offsets(obj: ObjectProfile, hand: HandConfig, source: str) -> None:
    """``posture_offsets_rad``: fingers of ``hand``, one offset per joint of each."""
    joints = {f.name: len(f.joints) for f in hand.fingers}
    for finger, offsets in obj.posture_offsets().items():
        key = f"objects.{obj.name}.posture_offsets_rad.{finger}"
        if finger not in joints:
            raise ConfigError(source, key, f"a finger of hand {hand.name!r} ({', '.join(joints)}; got {finger!r})")
        if len(offsets) != joints[finger]:
            raise ConfigError(
                source, key, f"{joints[finger]} offsets, one per joint of finger {finger} (got {len(offsets)})"
            )
