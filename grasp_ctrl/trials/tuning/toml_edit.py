"""Change one value of one object in an object-profile TOML file, textually.

Comments, spacing and key order are kept: only the ``key = value`` line of the
``[objects.NAME]`` table changes (or one line is added to that table). The new
text is checked by loading it before the file is replaced.
"""

from __future__ import annotations

import difflib
import os
import re
import tempfile
from pathlib import Path

from grasp_ctrl.config.objects import load_objects
from grasp_ctrl.errors import UsageError
from grasp_ctrl.safe_write import replace_in_place

_HEADER = re.compile(r"^\s*\[\s*([^\]]+?)\s*\]")
_KEY = re.compile(r"^(\s*)([A-Za-z0-9_\-]+)(\s*=\s*)([^#\n]*?)(\s*(#.*)?)$")


def toml_value(v: float | int) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    text = repr(float(v))
    return text if any(c in text for c in ".eEn") else text + ".0"


def set_object_value(text: str, obj: str, key: str, value: float | int) -> str:
    lines = text.splitlines(keepends=True)
    target = f"objects.{obj}"
    start = end = None
    for i, line in enumerate(lines):
        m = _HEADER.match(line)
        if m:
            if start is not None:
                end = i
                break
            if m.group(1).replace('"', "").replace(" ", "") == target:
                start = i
    if start is None:
        raise UsageError(f"no [{target}] table in the object file")
    end = len(lines) if end is None else end
    last_key = start
    for i in range(start + 1, end):
        m = _KEY.match(lines[i].rstrip("\r\n"))
        if not m:
            continue
        last_key = i
        if m.group(2) == key:
            nl = lines[i][len(lines[i].rstrip("\r\n")) :]
            lines[i] = f"{m.group(1)}{key}{m.group(3)}{toml_value(value)}{m.group(5)}{nl}"
            return "".join(lines)
    nl = "\n"
    if not lines[last_key].endswith(("\n", "\r")):
        lines[last_key] += nl
    lines.insert(last_key + 1, f"{key} = {toml_value(value)}{nl}")
    return "".join(lines)


def update_object_file(path: Path, obj: str, values: dict[str, float | int]) -> str:
    """Write the new values into ``path``; returns the unified diff ('' when unchanged)."""
    return update_objects_file(path, {obj: values})


def update_objects_file(path: Path, values: dict[str, dict[str, float | int]]) -> str:
    """Write every object's new values into ``path`` at once; returns the unified diff ('' when
    unchanged). The new text must load and read back the values; then the file is replaced in
    place (``safe_write.replace_in_place``: a symlink is followed and its target replaced, the
    link stays; the file keeps its mode and owner)."""
    path = Path(path)
    target = Path(os.path.realpath(path))
    if not target.is_file():
        raise UsageError(f"{path}: not a file")
    old = target.read_text(encoding="utf-8")
    new = old
    for obj, obj_values in values.items():
        for key, value in obj_values.items():
            new = set_object_value(new, obj, key, value)
    if new == old:
        return ""
    _check_loads(new, path, values)
    replace_in_place(path, new)  # follows a symlink; keeps the target's mode and owner (safe_write.py)
    return "".join(
        difflib.unified_diff(
            old.splitlines(keepends=True),
            new.splitlines(keepends=True),
            fromfile=f"{path} (before)",
            tofile=f"{path} (after)",
        )
    )


def _check_loads(text: str, path: Path, values: dict[str, dict[str, float | int]]) -> None:
    """Refuse to write an object file that would not load or not read the new values back."""
    with tempfile.TemporaryDirectory() as folder:
        probe = Path(folder) / Path(path).name
        probe.write_text(text, encoding="utf-8")
        profiles = load_objects(probe)
    for obj, obj_values in values.items():
        for key, value in obj_values.items():
            if abs(float(getattr(profiles[obj], key)) - float(value)) > 1e-12:
                raise UsageError(f"{path}: {key} of {obj} did not read back as {value}")
