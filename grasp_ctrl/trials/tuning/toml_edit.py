"""Change one value of one object in an object-profile TOML file, textually.

Comments, spacing and key order are kept: only the ``key = value`` line of the
``[objects.NAME]`` table changes (or one line is added to that table); a value
may be a number or an inline table of lists (``posture_offsets_rad``). A comment
line may be set above the table (``# chosen by: ...``: replaced, not repeated,
on the next write). The new text is checked by loading it before the file is
replaced.
"""

from __future__ import annotations

import difflib
import os
import re
import tempfile
from pathlib import Path

from grasp_ctrl.config.objects import load_objects
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import replace_in_place

_HEADER = re.compile(r"^\s*\[\s*([^\]]+?)\s*\]")
_KEY = re.compile(r"^(\s*)([A-Za-z0-9_\-]+)(\s*=\s*)([^#\n]*?)(\s*(#.*)?)$")


CHOSEN_BY = "# chosen by: "

Value = float | int | dict[str, list[float]]


def toml_value(v: Value) -> str:
    if isinstance(v, dict):  # an inline table of lists of numbers: {index = [0.0, 0.05, 0.0, 0.0]}
        return "{" + ", ".join(f"{k} = [{', '.join(toml_value(x) for x in xs)}]" for k, xs in v.items()) + "}"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    text = repr(float(v))
    return text if any(c in text for c in ".eEn") else text + ".0"


def _table_span(lines: list[str], obj: str) -> tuple[int, int]:
    """The line of ``[objects.OBJ]`` and the line where its keys end (the next header or the end)."""
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
    return start, len(lines) if end is None else end


def set_object_comment(text: str, obj: str, comment: str) -> str:
    """``# chosen by: COMMENT`` on the line above ``[objects.OBJ]`` (replacing one already there)."""
    comment = " ".join(comment.split())  # one line, whatever the command held
    lines = text.splitlines(keepends=True)
    start, _ = _table_span(lines, obj)
    line = f"{CHOSEN_BY}{comment}\n"
    if start > 0 and lines[start - 1].startswith(CHOSEN_BY):
        lines[start - 1] = line
    else:
        lines.insert(start, line)
    return "".join(lines)


def set_object_value(text: str, obj: str, key: str, value: Value) -> str:
    lines = text.splitlines(keepends=True)
    start, end = _table_span(lines, obj)
    sub = f"objects.{obj}.{key}"
    if any((m := _HEADER.match(line)) and m.group(1).replace('"', "").replace(" ", "") == sub for line in lines):
        raise UsageError(f"[{sub}] is a table of its own; tune --write writes {key} inline: make it one by hand")
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


def update_object_file(path: Path, obj: str, values: dict[str, Value]) -> str:
    """Write the new values into ``path``; returns the unified diff ('' when unchanged)."""
    return update_objects_file(path, {obj: values})


def update_objects_file(path: Path, values: dict[str, dict[str, Value]], comment: str | None = None) -> str:
    """Write every object's new values into ``path`` at once; returns the unified diff ('' when
    unchanged). ``comment``: set as ``# chosen by: COMMENT`` above each changed object's table.
    The new text must load and read back the values; then the file is replaced in
    place (``safe_write.replace_in_place``: a symlink is followed and its target replaced, the
    link stays; the file keeps its mode and owner)."""
    path = Path(path)
    target = Path(os.path.realpath(path))
    if not target.is_file():
        raise UsageError(f"{path}: not a file")
    old = target.read_text(encoding="utf-8")
    new = old
    for obj, obj_values in values.items():
        before = new
        for key, value in obj_values.items():
            new = set_object_value(new, obj, key, value)
        if comment is not None and new != before:
            new = set_object_comment(new, obj, comment)
    if new == old:
        return ""
    _check_loads(new, path, values)
    replace_in_place(path, new)  # follows a symlink; keeps the target's mode and owner (files/safe_write.py)
    return "".join(
        difflib.unified_diff(
            old.splitlines(keepends=True),
            new.splitlines(keepends=True),
            fromfile=f"{path} (before)",
            tofile=f"{path} (after)",
        )
    )


def _check_loads(text: str, path: Path, values: dict[str, dict[str, Value]]) -> None:
    """Refuse to write an object file that would not load or not read the new values back."""
    with tempfile.TemporaryDirectory() as folder:
        probe = Path(folder) / Path(path).name
        probe.write_text(text, encoding="utf-8")
        profiles = load_objects(probe)
    for obj, obj_values in values.items():
        for key, value in obj_values.items():
            got = getattr(profiles[obj], key)
            if isinstance(value, dict):
                back = profiles[obj].posture_offsets()
                same = back.keys() == value.keys() and all(
                    len(back[f]) == len(xs) and all(abs(a - float(b)) <= 1e-12 for a, b in zip(back[f], xs))
                    for f, xs in value.items()
                )
            else:
                same = got is not None and abs(float(got) - float(value)) <= 1e-12
            if not same:
                raise UsageError(f"{path}: {key} of {obj} did not read back as {value}")
