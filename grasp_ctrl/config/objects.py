"""Object profiles: physical properties for the mock world and per-object
controller thresholds (tau, release threshold and debounce).

A profile file holds one ``[objects.NAME]`` table per object; see
``hand_configs/objects.toml``. Thresholds and grasp settings tuned on one hand
go into that object's ``[objects.NAME.hands.HAND]`` table (``HAND``: the hand
file's ``name``): they apply when the file is loaded for that hand and never
for another. The same keys at the object level apply to every hand.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from grasp_ctrl.config.identifiers import check_identifier
from grasp_ctrl.config.toml_reader import Table, read_toml
from grasp_ctrl.errors import ConfigError

#: How an object's grip targets are set (controller/grip_targets.py).
GRIP_TARGET_MODES = ("equal", "force_closure")

SHAPES = ("cylinder", "box")
MIN_MASS_KG = 0.001  # 1 g: lighter bodies make MuJoCo's inertias degenerate


@dataclass(frozen=True)
class CapProfile:
    """A domed cap on the body's top (the mustard bottle's) and the finger placed on it."""

    diameter_m: float  # base of the dome
    height_m: float  # above the body's top
    offset_m: tuple[float, float]  # dome centre from the footprint centre (x, y)
    finger: str  # this fingertip grasps the cap (a non-flat contact)
    contact_height_m: float  # its contact height above the table


@dataclass(frozen=True)
class ObjectProfile:
    name: str
    shape: str  # cylinder | box (footprint on the table)
    size_m: tuple[float, float]  # cylinder: (diameter, diameter); box: (x, y) footprint
    height_m: float
    mass_kg: float
    mu: float  # fingertip-object friction coefficient
    stiffness_n_per_m: float  # contact stiffness (skin + object surface)
    deformable: bool
    crush_force_n: float | None  # grip force that crushes a deformable object
    grasp_height_m: float  # height of the fingertip contacts above the table
    tip_force_n: float  # push into the table that knocks it over
    cap: CapProfile | None = None  # height_m is then the body's, without the cap
    # controller thresholds (tunable per object)
    tau_n: float = 2.0
    release_threshold_n: float = 0.3
    release_debounce: int = 3
    lift_height_m: float = 0.10
    hold_s: float = 0.5
    grip_targets: str | None = None  # equal | force_closure (controller/grip_targets.py); None: the controller's
    # the grasp (tunable per object: tune --param)
    approach_offset_m: float = 0.0  # added to the grasp height the world uses (positive: the pads grasp higher)
    standoff_m: float | None = None  # the preshape's standoff; None: the controller's setting
    # per finger, offsets added to its reach posture's joint angles (one per joint, rad); None: none
    posture_offsets_rad: tuple[tuple[str, tuple[float, ...]], ...] | None = None
    # the hand whose [objects.NAME.hands.HAND] table applied (its name); None: the object-level values only
    tuned_for: str | None = None

    @property
    def half_width_m(self) -> float:
        return 0.5 * self.size_m[0]

    def posture_offsets(self) -> dict[str, tuple[float, ...]]:
        """``posture_offsets_rad`` as ``{finger: offsets}`` (empty when none)."""
        return dict(self.posture_offsets_rad or ())

    def with_params(self, **params: Any) -> ObjectProfile:
        return replace(self, **params)


TUNABLE = (
    "tau_n",
    "release_threshold_n",
    "release_debounce",
    "lift_height_m",
    "hold_s",
    "approach_offset_m",
    "standoff_m",
)
#: The keys an ``[objects.NAME.hands.HAND]`` table may set: the controller's thresholds and the
#: grasp, tuned on one hand. Every other key describes the object (the same for every hand).
HAND_KEYS = (*TUNABLE, "grip_targets", "posture_offsets_rad")
#: The keys of an ``[objects.NAME]`` table besides ``hands``.
OBJECT_KEYS = (
    "shape",
    "diameter_m",
    "size_m",
    "height_m",
    "mass_kg",
    "mu",
    "stiffness_n_per_m",
    "deformable",
    "crush_force_n",
    "grasp_height_m",
    "tip_force_n",
    "cap",
    *HAND_KEYS,
)
#: The object file's bounds on the grasp keys.
MAX_APPROACH_OFFSET_M = 0.05
MAX_STANDOFF_M = 0.05
MAX_POSTURE_OFFSET_RAD = 0.2
MAX_FINGER_JOINTS = 8


def _object(name: str, t: Table) -> ObjectProfile:
    t.unknown_keys(set(OBJECT_KEYS))
    shape = t.str("shape", choices=SHAPES)
    if shape == "cylinder":
        d = t.float("diameter_m", lo=0.005, hi=0.5)
        size = (d, d)
    else:
        sx, sy = t.vector("size_m", 2)
        if not (0.005 <= sx <= 0.5 and 0.005 <= sy <= 0.5):
            raise t.fail("size_m", "two sizes between 0.005 and 0.5 m")
        size = (sx, sy)
    height = t.float("height_m", lo=0.01, hi=1.0)
    # the engines need a body they can integrate: MuJoCo refuses masses and inertias near zero
    mass = t.float("mass_kg", lo=MIN_MASS_KG, hi=5.0)
    deformable = t.bool("deformable", False)
    crush = t.float("crush_force_n", lo=0.0, hi=1000.0, lo_open=True) if deformable else None
    if not deformable and t.has("crush_force_n"):
        raise t.fail("crush_force_n", "absent for a rigid object (set deformable = true)")
    grasp_h = t.float("grasp_height_m", 0.5 * height, lo=0.005, hi=height)
    cap = _cap(t.table("cap"), size, height) if t.has("cap") else None
    approach = t.float("approach_offset_m", 0.0, lo=-MAX_APPROACH_OFFSET_M, hi=MAX_APPROACH_OFFSET_M)
    if not 0.005 <= grasp_h + approach <= height:
        raise t.fail(
            "approach_offset_m",
            f"an offset that keeps grasp_height_m + approach_offset_m from 0.005 m to height_m = {height:g} m "
            f"(got {grasp_h:g} + {approach:g})",
        )
    return ObjectProfile(
        name=name,
        shape=shape,
        size_m=size,
        height_m=height,
        mass_kg=mass,
        mu=t.float("mu", lo=0.05, hi=3.0),
        stiffness_n_per_m=t.float("stiffness_n_per_m", lo=10.0, hi=1e6),
        deformable=deformable,
        crush_force_n=crush,
        grasp_height_m=grasp_h,
        tip_force_n=t.float("tip_force_n", 15.0, lo=0.0, hi=1000.0, lo_open=True),
        cap=cap,
        tau_n=t.float("tau_n", 2.0, lo=0.1, hi=20.0),
        # the release rule is dot(-f_world, n_world) < -threshold: a positive number
        release_threshold_n=t.float("release_threshold_n", 0.3, lo=0.0, hi=10.0, lo_open=True),
        release_debounce=t.int("release_debounce", 3, lo=1, hi=1000),
        lift_height_m=t.float("lift_height_m", 0.10, lo=0.0, hi=1.0, lo_open=True),
        hold_s=t.float("hold_s", 0.5, lo=0.0, hi=60.0),
        grip_targets=t.str("grip_targets", choices=GRIP_TARGET_MODES) if t.has("grip_targets") else None,
        approach_offset_m=approach,
        standoff_m=t.float("standoff_m", lo=0.0, hi=MAX_STANDOFF_M, lo_open=True) if t.has("standoff_m") else None,
        posture_offsets_rad=_posture_offsets(t) if t.has("posture_offsets_rad") else None,
    )


def _posture_offsets(t: Table) -> tuple[tuple[str, tuple[float, ...]], ...] | None:
    """``posture_offsets_rad = {FINGER = [one offset per joint, rad], ...}``; the finger names and
    joint counts are checked against the hand file when a run starts (config/checks.py)."""
    table = t.table("posture_offsets_rad")
    out = []
    for finger, value in table.data.items():
        check_identifier(finger, table.path, table.key("<finger name>"))
        if not isinstance(value, list) or not 1 <= len(value) <= MAX_FINGER_JOINTS:
            raise table.fail(finger, "a list of joint-angle offsets, one per joint of the finger (rad)")
        out.append((finger, table.vector(finger, len(value), bound=MAX_POSTURE_OFFSET_RAD)))
    return tuple(out) or None


def _cap(t: Table, size: tuple[float, float], height: float) -> CapProfile:
    t.unknown_keys({"diameter_m", "height_m", "offset_m", "finger", "contact_height_m"})
    diameter = t.float("diameter_m", lo=0.005, hi=min(size))
    cap_h = t.float("height_m", lo=0.002, hi=0.2)
    ox, oy = t.vector("offset_m", 2, (0.0, 0.0))
    if abs(ox) + 0.5 * diameter > 0.5 * size[0] + 1e-9 or abs(oy) + 0.5 * diameter > 0.5 * size[1] + 1e-9:
        raise t.fail("offset_m", "an offset that keeps the cap's base on the body's top")
    contact = t.float("contact_height_m", lo=height, lo_open=True)
    if contact >= height + cap_h:
        raise t.fail("contact_height_m", f"a height on the cap, below its top at {height + cap_h:.3f} m")
    return CapProfile(diameter, cap_h, (ox, oy), t.str("finger"), contact)


def profile_table(obj: ObjectProfile) -> dict[str, Any]:
    """The ``[objects.NAME]`` table (as parsed TOML) that loads back to ``obj`` (its resolved values
    at the object level: ``tuned_for``, the hand whose table they came from, is not a key)."""
    doc: dict[str, Any] = {k: v for k, v in asdict(obj).items() if k not in ("name", "size_m", "cap", "tuned_for")}
    if obj.shape == "cylinder":
        doc["diameter_m"] = obj.size_m[0]
    else:
        doc["size_m"] = list(obj.size_m)
    if obj.crush_force_n is None:
        doc.pop("crush_force_n")
    if obj.grip_targets is None:
        doc.pop("grip_targets")
    if obj.cap is not None:
        cap = asdict(obj.cap)
        cap["offset_m"] = list(obj.cap.offset_m)
        doc["cap"] = cap
    if obj.standoff_m is None:
        doc.pop("standoff_m")
    if obj.posture_offsets_rad is None:
        doc.pop("posture_offsets_rad")
    else:
        doc["posture_offsets_rad"] = {f: list(v) for f, v in obj.posture_offsets_rad}
    return doc


#: The grasp keys and their defaults: a profile stored in run.json leaves them out at these, so a
#: run made before the keys existed keeps its run.json and fingerprint (trials/runs/fingerprint.py).
GRASP_KEY_DEFAULTS: dict[str, Any] = {"approach_offset_m": 0.0, "standoff_m": None, "posture_offsets_rad": None}


def profile_json(obj: ObjectProfile) -> dict[str, Any]:
    """``obj`` as run.json stores it (``dataclasses.asdict``; read back by :func:`profile_from_json`):
    the grasp keys only where they differ from their defaults, the posture as ``{finger: [...]}``,
    ``tuned_for`` only where a hand's table applied (a run made before it existed keeps its
    run.json and fingerprint)."""
    doc = asdict(obj)
    for key, default in GRASP_KEY_DEFAULTS.items():
        if doc[key] == default:
            doc.pop(key)
    if obj.tuned_for is None:
        doc.pop("tuned_for")
    if obj.posture_offsets_rad is not None:
        doc["posture_offsets_rad"] = {f: list(v) for f, v in obj.posture_offsets_rad}
    return doc


def profile_from_json(name: object, doc: Any, source: str, prefix: str = "") -> ObjectProfile:
    """A profile stored by :func:`profile_json` (``run.json``) -> checked by the loader's rules.

    The cap comes back as a :class:`CapProfile`, and every bound and cross-field
    rule of the object file applies; errors name ``source`` and ``prefix + key``."""
    if not isinstance(doc, dict):
        raise Table(source, {}, prefix).fail(str(name), "an object profile table")
    check_identifier(name, source, f"{prefix}name")
    tuned_for = doc.get("tuned_for")
    if tuned_for is not None:
        check_identifier(tuned_for, source, f"{prefix}{name}.tuned_for", "the name of the hand whose table applied")
    table = {k: v for k, v in doc.items() if k not in ("name", "size_m", "cap", "tuned_for") and v is not None}
    size = doc.get("size_m")
    if doc.get("shape") == "cylinder":
        if not isinstance(size, (list, tuple)) or len(size) != 2 or size[0] != size[1]:
            raise Table(source, {}, f"{prefix}{name}.").fail("size_m", "[d, d] for a cylinder")
        table["diameter_m"] = size[0]
    elif size is not None:
        table["size_m"] = size
    if doc.get("cap") is not None:
        table["cap"] = doc["cap"]
    return replace(_object(str(name), Table(source, table, f"{prefix}{name}.")), tuned_for=tuned_for)


def revalidate(obj: ObjectProfile, source: str) -> ObjectProfile:
    """``obj`` checked by the loader's own rules (after edits such as a tuning
    sweep's); ConfigError names ``source`` and the offending key. ``tuned_for`` is kept."""
    return replace(_object(obj.name, Table(source, profile_table(obj))), tuned_for=obj.tuned_for)


def _hand_tables(name: str, t: Table) -> dict[str, Table]:
    """The ``[objects.NAME.hands.HAND]`` tables of one object, checked for their keys: a
    threshold or grasp key (:data:`HAND_KEYS`) only; a physical key is the object's."""
    if not t.has("hands"):
        return {}
    hands = t.table("hands")
    out = {}
    for hand in hands.data:
        check_identifier(hand, hands.path, hands.key("<hand name>"), "a hand file's name")
        ht = hands.table(hand)
        for key in ht.data:
            if key in OBJECT_KEYS and key not in HAND_KEYS:
                raise ht.fail(
                    key,
                    f"not a per-hand key: {key} describes the object, set it once in [objects.{name}] "
                    f"(per hand: {', '.join(HAND_KEYS)})",
                )
        ht.unknown_keys(set(HAND_KEYS))
        out[hand] = ht
    return out


def _with_hand(name: str, t: Table, base: dict[str, Any], ht: Table) -> ObjectProfile:
    """The object's values with the hand table's over them, checked as one table; an error about
    a key the hand table sets names that key there (``objects.NAME.hands.HAND.KEY``)."""
    try:
        return _object(name, Table(t.path, {**base, **ht.data}, t.prefix))
    except ConfigError as exc:
        rest = exc.key[len(t.prefix) :] if exc.key.startswith(t.prefix) else ""
        if rest.split(".", 1)[0] in ht.data:
            raise ConfigError(exc.path, ht.key(rest), exc.expected) from None
        raise


def _resolve(name: str, t: Table, hand: str | None) -> ObjectProfile:
    """One object's profile for ``hand``: its object-level values, overridden by its
    ``hands.<hand>`` table when it has one (``tuned_for`` names that hand). Every hand's table
    is checked, whichever hand loads the file."""
    tables = _hand_tables(name, t)
    base = {k: v for k, v in t.data.items() if k != "hands"}
    profile = _object(name, Table(t.path, base, t.prefix))  # what a hand without a table gets
    for h, ht in tables.items():
        resolved = _with_hand(name, t, base, ht)
        if h == hand:
            profile = replace(resolved, tuned_for=h)
    return profile


def load_objects(path: str | Path, hand: str | None = None) -> dict[str, ObjectProfile]:
    """Read an object-profile file into ``{name: profile}`` (file order kept), resolved for
    ``hand``, the name of the hand the trials run on (the hand file's ``name``).

    Each profile holds the object-level values, overridden by the object's
    ``[objects.NAME.hands.HAND]`` table when ``HAND`` is ``hand`` (its ``tuned_for`` is then
    ``hand``); a table under another hand's name never applies. ``hand=None`` resolves no hand's
    table: the object-level values alone, for what does not depend on the hand (object names,
    physical keys, checking the file). Code that runs or evaluates trials passes the hand's name.
    Every hand's table is checked whichever ``hand`` is given."""
    if hand is not None and not isinstance(hand, str):
        raise TypeError(f"load_objects: hand must be a hand's name (str) or None, got {type(hand).__name__}")
    root = Table(path, read_toml(path))
    root.unknown_keys({"objects", "default_set"})
    objs = root.table("objects")
    if not objs.data:
        raise root.fail("objects", "at least one [objects.NAME] table")
    for name in objs.data:
        check_identifier(name, objs.path, "objects.<object name>", "object names become directory names")
    profiles = {name: _resolve(name, objs.table(name), hand) for name in objs.data}
    return profiles


def default_set(path: str | Path) -> list[str]:
    """Names listed in ``default_set`` (all objects when absent)."""
    root = Table(path, read_toml(path))
    profiles = load_objects(path)
    if not root.has("default_set"):
        return list(profiles)
    names = root.data["default_set"]
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise root.fail("default_set", "a list of object names")
    for n in names:
        if n not in profiles:
            raise root.fail("default_set", f"names of [objects.*] tables (unknown: {n!r})")
    return names
