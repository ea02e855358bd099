"""How much a simulated world varies from trial to trial: named variation profiles.

Each number of a ``Variation`` is the half-width of a uniform draw per trial (from the
trial's seed): the object's placement on the table (x and y, m), its rotation about the
vertical (yaw, deg), its mass, friction and contact stiffness (fractions of the object
profile's values) and each hand joint's calibration offset (deg). ``run``, ``tune`` and
``lift-capacity`` take ``--variation NAME``; results are reported under ``bench``.

``bench`` (the default) is a hand-set bench; where each range comes from:

- placement +-10 mm in x and y, yaw +-10 deg: engineering judgment, not a measurement. An
  operator sets the object down by hand against an outline marked on the table.
- mass +-15 %: the YCB object set publishes one mass per item, while real items differ
  (a bottle full or partly empty, another production lot, another brand's packaging). The
  width is judgment informed by that, not a measured spread.
- friction +-20 %: the friction of rubber-like fingertip skin varies by tens of percent with
  humidity, cleanliness (skin oils, dust) and normal load; +-20 % is a round figure in that range.
- contact stiffness +-20 %: judgment (the skin's and the object's compliance differ between
  items and with where on the object the pad lands), chosen like friction's.
- joint offsets +-1 deg per joint: Dynamixel X-series servos resolve 4096 ticks per turn
  (0.088 deg), but the LEAP hand's joint zero is set by hand at assembly, to about a degree.
  The servo reports, and is commanded in, its calibrated angle; the real joint sits ``offset``
  away (q_measured = q_true - offset).

``nominal`` is the small variation of the worlds before the profiles existed (placement 3 mm,
mass 3 %, friction 3 %, stiffness 5 %, no yaw, no joint offsets): with it a world draws exactly
what it drew then, from the same random stream (the yaw and the joint offsets come from a
second stream of the trial's seed, ``extra_rng``), and changes nothing in the physics.
See docs/mujoco.md, "Variation profiles".
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from grasp_ctrl.errors import UsageError

# Tags the yaw and joint-offset draws' stream apart from the trial's main stream.
_EXTRA_STREAM = 0x5641_5249  # "VARI"


@dataclass(frozen=True)
class Variation:
    """Half-widths of the per-trial uniform draws (SI units, except the ``_deg`` fields)."""

    name: str
    placement_m: float  # object placement, x and y each
    yaw_deg: float  # object rotation about the vertical
    mass_frac: float  # object mass, fraction of the profile's
    friction_frac: float  # friction coefficient, fraction of the profile's
    stiffness_frac: float  # contact stiffness, fraction of the profile's
    joint_offset_deg: float  # each joint's calibration offset

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    def describe(self) -> str:
        """One line: ``bench (placement +-10 mm, yaw +-10 deg, mass +-15 %, ...)``."""
        return f"{self.name} ({self.ranges()})"

    def ranges(self) -> str:
        """The half-widths in words: ``placement +-10 mm, yaw +-10 deg, mass +-15 %, ...``."""
        parts = (
            f"placement +-{1000 * self.placement_m:g} mm",
            f"yaw +-{self.yaw_deg:g} deg",
            f"mass +-{100 * self.mass_frac:g} %",
            f"friction +-{100 * self.friction_frac:g} %",
            f"stiffness +-{100 * self.stiffness_frac:g} %",
            f"joint offsets +-{self.joint_offset_deg:g} deg",
        )
        return ", ".join(parts)


BENCH = Variation("bench", 0.010, 10.0, 0.15, 0.20, 0.20, 1.0)
NOMINAL = Variation("nominal", 0.003, 0.0, 0.03, 0.03, 0.05, 0.0)

VARIATIONS: dict[str, Variation] = {v.name: v for v in (BENCH, NOMINAL)}
DEFAULT_VARIATION = BENCH.name  # the command line's default; library worlds default to NOMINAL

# Bounds of a profile read back from a file (run.json): a fraction of 1 or more could make a
# mass, friction or stiffness zero or negative.
_LIMITS = {
    "placement_m": 0.1,
    "yaw_deg": 180.0,
    "mass_frac": 0.99,
    "friction_frac": 0.99,
    "stiffness_frac": 0.99,
    "joint_offset_deg": 10.0,
}


def variation(name: str) -> Variation:
    """The profile called ``name``, or a one-line error listing the profiles."""
    try:
        return VARIATIONS[name]
    except (KeyError, TypeError):
        raise UsageError(f"--variation {name!r}: unknown (one of {', '.join(sorted(VARIATIONS))})") from None


def variation_from_json(doc: Any, where: str) -> Variation:
    """A profile as ``Variation.to_json`` wrote it (run.json), every field checked: one line
    naming the file and the field otherwise."""
    if not isinstance(doc, dict):
        raise UsageError(f"{where}: variation: a table of {', '.join(['name', *_LIMITS])}")
    name = doc.get("name")
    if not isinstance(name, str) or not name:
        raise UsageError(f"{where}: variation.name: a non-empty string (got {name!r})")
    values: dict[str, float] = {}
    for key, top in _LIMITS.items():
        v = doc.get(key)
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not (math.isfinite(v) and 0 <= v <= top):
            raise UsageError(f"{where}: variation.{key}: a number from 0 to {top:g} (got {v!r})")
        values[key] = float(v)
    extra = sorted(set(doc) - {"name", *_LIMITS})
    if extra:
        raise UsageError(f"{where}: variation.{extra[0]}: not a field (the fields: {', '.join(['name', *_LIMITS])})")
    return Variation(name=name, **values)


def add_variation_argument(p: Any) -> None:
    """``--variation NAME`` on a command's parser, one of the profiles (argparse refuses another name
    in its one-line error; ``variation`` checks names from elsewhere, run.json say)."""
    text = (
        f"how much the simulated world varies per trial, one of {', '.join(sorted(VARIATIONS))} "
        f"(default {DEFAULT_VARIATION}). bench: {BENCH.ranges()}; nominal: {NOMINAL.ranges()} "
        "(docs/mujoco.md, 'Variation profiles')"
    )
    help_text = text.replace("%", "%%")  # argparse's % format
    p.add_argument("--variation", default=None, choices=sorted(VARIATIONS), help=help_text)


# ----- the draws ---------------------------------------------------------------


@dataclass(frozen=True)
class ObjectDraw:
    """One trial's object draw: placement (m) and fractions off the profile's values."""

    xy_m: tuple[float, float]
    mass_frac: float
    friction_frac: float
    stiffness_frac: float


def draw_object(rng: np.random.Generator, v: Variation) -> ObjectDraw:
    """The object's draws from the trial's main stream, in the order the worlds always drew
    them (placement x and y, mass, friction, stiffness): the same bits under ``nominal``."""
    xy = rng.uniform(-v.placement_m, v.placement_m, size=2)
    mass = v.mass_frac * rng.uniform(-1, 1)
    mu = v.friction_frac * rng.uniform(-1, 1)
    k = v.stiffness_frac * rng.uniform(-1, 1)
    return ObjectDraw((float(xy[0]), float(xy[1])), float(mass), float(mu), float(k))


def extra_rng(seed: int) -> np.random.Generator:
    """The stream of the yaw and the joint offsets: the trial's seed, tagged, so the main
    stream (placement, mass, friction, stiffness, then the sensors' noise) is untouched."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), _EXTRA_STREAM]))


def draw_extra(seed: int, v: Variation, n_joints: int) -> tuple[float, np.ndarray]:
    """(yaw in rad, each joint's calibration offset in rad), exactly 0 where the profile's
    half-width is 0."""
    rng = extra_rng(seed)
    yaw = math.radians(v.yaw_deg) * float(rng.uniform(-1, 1)) + 0.0  # + 0.0: no -0.0
    offsets = math.radians(v.joint_offset_deg) * rng.uniform(-1, 1, size=n_joints) + 0.0
    return yaw, offsets


def draw_record(obj: ObjectDraw, yaw_rad: float, offsets_rad: np.ndarray) -> dict[str, Any]:
    """A world's ``draw`` (the trial record's ``variation_draw``): the actual draws, the
    fractions relative to the object profile's values (e.g. mass / profile mass - 1)."""
    return {
        "placement_m": [round(obj.xy_m[0], 7), round(obj.xy_m[1], 7)],
        "yaw_deg": round(math.degrees(yaw_rad), 5),
        "mass_frac": round(obj.mass_frac, 7),
        "friction_frac": round(obj.friction_frac, 7),
        "stiffness_frac": round(obj.stiffness_frac, 7),
        "joint_offset_deg": [round(math.degrees(float(o)), 5) for o in offsets_rad],
    }


def max_rotated_half_extents(half_x: float, half_y: float, yaw_max_rad: float) -> tuple[float, float]:
    """The half-extents along x and y of a ``half_x`` x ``half_y`` rectangle turned by any yaw
    within +-``yaw_max_rad`` (at 0 the rectangle's own)."""

    def widest(a: float, b: float) -> float:  # max of a cos t + b sin t over t in [0, yaw_max]
        return (
            math.hypot(a, b)
            if math.atan2(b, a) <= yaw_max_rad
            else a * math.cos(yaw_max_rad) + b * math.sin(yaw_max_rad)
        )

    if yaw_max_rad <= 0.0:
        return half_x, half_y
    return widest(half_x, half_y), widest(half_y, half_x)
