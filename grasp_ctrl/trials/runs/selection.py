"""Resolve the user's choice of hand, object file and objects into configs."""

from __future__ import annotations

import difflib
import sys
from pathlib import Path
from typing import Any

from grasp_ctrl.config.objects import ObjectProfile, default_set, load_objects
from grasp_ctrl.config.toml_reader import read_toml
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
    selected = [profiles[n] for n in names]
    for note in near_miss_hand_tables(objects_file, [o.name for o in selected], hand):
        print(f"note: {note}", file=sys.stderr)
    return selected


def near_miss_hand_tables(objects_file: str | Path, names: list[str], hand: str) -> list[str]:
    """One line per object whose ``[objects.NAME.hands.X]`` table is not ``hand``'s but is named
    almost like it (a typo would otherwise leave the hand's tuned thresholds silently unused)."""
    objects: Any = read_toml(objects_file).get("objects", {})
    notes = []
    for name in names:
        tables = objects.get(name, {}).get("hands", {}) if isinstance(objects.get(name), dict) else {}
        if not isinstance(tables, dict) or hand in tables:
            continue
        close = difflib.get_close_matches(hand, list(tables), n=1, cutoff=0.8)
        if close:
            notes.append(
                f"{objects_file}: objects.{name}.hands.{close[0]} is not hand {hand!r}'s table (a typo?): "
                f"{name} runs on {hand!r} with the object's own values"
            )
    return notes
