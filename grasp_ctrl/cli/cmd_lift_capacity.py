"""``lift-capacity``: how heavy an object the hand file's grasp can lift (statics, no simulation)."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from grasp_ctrl.config.objects import ObjectProfile
    from grasp_ctrl.sim.variation import Variation

NAME = "lift-capacity"
HELP = "per object, the largest weight the hand's grasp carries within the joints' torque limits and friction"
DESCRIPTION = (
    "Places the hand on each object as the controller does (the object's preshape, the cap finger "
    "raised to its cap, the grasping pads closed along their task vectors onto the object's side) "
    "and solves the statics of the free object: the largest weight the pads carry with every "
    "contact force in its friction cone and every joint within its torque limit (a Dynamixel hand's: "
    "its current limit x the servo model's torque per amp, XC330-M288-T: 0.93 N m / 1.8 A = 0.517 N m/A; "
    "a torque-controlled hand's: its torque_limit_nm). "
    "Prints that weight, its ratio to the object's weight and, per pad, the normal force, the "
    "part carried up, the most loaded joint's share of its torque limit and how far the pad's normal "
    "is off the surface's (far off: the contact is not on the pad, and the figure is not to be trusted). An upper bound on "
    "what any grip law gets from this posture: use it to compare mounts (base_rpy) and postures "
    "of a hand file. An object the pads cannot close around (as wide as the pregrasp gap between "
    "opposing pads, a pad starting inside it or never reaching it) gets no figure but the reason, and so "
    "does one whose lift_height_m takes the palm above the arm's z_max_m. Exits 1 when an object's "
    "ratio is below --min-margin or it has no figure. Under --variation (default "
    "bench) each object is judged at the profile's worst corner: its mass raised and its friction lowered "
    "by the profile's half-widths (nominal: the object file's values)."
)
ORDER = 45


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.cli._common_options import add_hand_file, add_object_file, add_object_list

    add_hand_file(p)
    add_object_file(p)
    add_object_list(
        p, words=True, help="objects to check, separated by commas, or all (default: the object file's default_set)"
    )
    p.add_argument(
        "--min-margin",
        type=float,
        default=1.0,
        metavar="X",
        help="exit 1 when a liftable weight is below X times the object's weight (default 1.0)",
    )
    from grasp_ctrl.sim.variation import add_variation_argument

    add_variation_argument(p)


def worst_corner(obj: ObjectProfile, v: Variation) -> ObjectProfile:
    """``obj`` at the variation's worst corner for lifting: heaviest (mass x (1 + mass_frac))
    and most slippery (mu x (1 - friction_frac)); under nominal the profile's own values."""
    from grasp_ctrl.sim.variation import NOMINAL

    if v == NOMINAL:
        return obj
    return obj.with_params(mass_kg=obj.mass_kg * (1.0 + v.mass_frac), mu=obj.mu * (1.0 - v.friction_frac))


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.config.actuation import describe
    from grasp_ctrl.config.checks import lift_above_arm
    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.controller.grasp_capacity import GRAVITY_M_S2, object_capacity
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.sim.variation import DEFAULT_VARIATION, NOMINAL, variation
    from grasp_ctrl.trials.runs.selection import select_objects

    v = variation(args.variation or DEFAULT_VARIATION)
    if not args.min_margin > 0.0:
        raise UsageError(f"--min-margin: expected a positive number, got {args.min_margin}")
    hand = load_hand(args.hand)
    selected = select_objects(args.object_file, args.objects, hand=hand.name)
    print(f"lift-capacity: {hand.name}, {describe(hand)}")
    if v == NOMINAL:
        print(f"  variation {v.name}: each object at the object file's mass and friction")
    else:
        print(
            f"  variation {v.name}: each object at its worst corner, mass +{100 * v.mass_frac:g} % and "
            f"friction -{100 * v.friction_frac:g} % (placement, yaw, stiffness and joint offsets are not in the statics)"
        )
    print(
        f"  {'object':16s} {'weight_N':>8s} {'liftable_N':>10s} {'ratio':>6s}  per pad: normal N / up N / most loaded joint (share of its limit), pad facing off the surface"
    )
    short: list[str] = []
    unable: list[str] = []
    for profile in selected:
        name = profile.name
        obj = worst_corner(profile, v)
        weight = obj.mass_kg * GRAVITY_M_S2
        above = lift_above_arm(obj, hand)
        if above is not None:  # the trials could not lift it whatever the statics say
            print(
                f"  {name:16s} {weight:8.2f} {'-':>10s} {'-':>6s}  no lift: {args.object_file}: objects.{name}.lift_height_m: {above}"
            )
            unable.append(name)
            continue
        try:
            cap, contacts, _ = object_capacity(hand, obj)
        except ValueError as exc:  # NoGrasp, or a posture the hand cannot take (e.g. a cap out of reach)
            print(f"  {name:16s} {weight:8.2f} {'-':>10s} {'-':>6s}  no grasp: {exc}")
            unable.append(name)
            continue
        ratio = cap.weight_n / weight
        facing = {c.finger: c.facing_deg for c in contacts}
        pads = "  ".join(
            f"{ld.finger} {ld.normal_n:.2f}/{ld.lift_n:.2f}/{ld.joint} ({ld.torque_share:.2f}), "
            f"{facing[ld.finger]:.0f} deg"
            for ld in cap.loads
        )
        print(f"  {name:16s} {weight:8.2f} {cap.weight_n:10.2f} {ratio:6.2f}  {pads}")
        if ratio < args.min_margin:
            short.append(name)
    if unable:
        print(f"lift-capacity: no grasp or no lift (the reason is on each line): {', '.join(unable)}")
    if short:
        print(f"lift-capacity: below {args.min_margin:g}x the weight: {', '.join(short)}")
    return 1 if short or unable else 0
