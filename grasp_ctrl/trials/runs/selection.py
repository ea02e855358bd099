"""Resolve the user's choice of hand, object file and objects into configs."""

from __future__ import annotations

from pathlib import Path

from grasp_ctrl.config.objects import ObjectProfile, default_set, load_objects
from grasp_ctrl.errors import UsageError


def select_objects(
    objects_file: str | Path, spec: str | None, flag: str = "--objects", *, hand: str
) -> list[ObjectProfile]:
    """``spec``: None (the file's default set), ``all``, or comma-separated names;
    ``flag``: the option named in errors; ``hand``: the name of the hand the trials run on (its
    ``[objects.NAME.hands.HAND]`` values apply, no other hand's: config/objects.py)."""
    profiles = load_objects(objects_file, hand)
    if spec is None:
        names = default_set(objects_file)
    elif spec.strip() == "all":
        names = list(profiles)
    else:
        names = [n.strip() for n in spec.split(",") if n.strip()]
        if not names:
            raise UsageError(f"{flag}: give names separated by commas, or 'all'")
        unknown = [n for n in names if n not in profiles]
        if unknown:
            raise UsageError(f"{flag}: unknown object {unknown[0]!r} (known: {', '.join(profiles)})")
    return [profiles[n] for n in names]
