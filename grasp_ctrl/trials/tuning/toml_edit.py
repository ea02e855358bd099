"""Change one value of one object in an object-profile TOML file, textually.

Comments, spacing and key order are kept: only the ``key = value`` line of the
``[objects.NAME]`` table, or of its ``[objects.NAME.hands.HAND]`` table, changes
(or one line is added to that table; a missing hand table is added after the
object's keys or its last hand table); a value may be a number or an inline table
of lists (``posture_offsets_rad``). A comment line may be set above the table
(``# chosen by: ...``: replaced, not repeated, on the next write). The new text is
checked by loading it for the hand before the file is replaced.

``tune --write`` writes through :func:`update_objects_file`, which takes the name of
the hand the values were tuned on and writes into that hand's tables only, never
into another hand's or the object level (config/objects.py: per-hand values).
"""

from __future__ import annotations

import difflib
import os
import re
import tempfile
from pathlib import Path

from grasp_ctrl.config.identifiers import check_identifier_arg
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


def _header(line: str) -> str | None:
    """The table name of a ``[header]`` line, quotes and spaces dropped; None for other lines."""
    m = _HEADER.match(line)
    return m.group(1).replace('"', "").replace(" ", "") if m else None


def _table_name(obj: str, hand: str | None) -> str:
    return f"objects.{obj}" if hand is None else f"objects.{obj}.hands.{hand}"


def _find_span(lines: list[str], target: str) -> tuple[int, int] | None:
    """The line of ``[TARGET]`` and the line where its keys end (the next header or the end)."""
    start = end = None
    for i, line in enumerate(lines):
        name = _header(line)
        if name is not None:
            if start is not None:
                end = i
                break
            if name == target:
                start = i
    if start is None:
        return None
    return start, len(lines) if end is None else end


def _table_span(lines: list[str], obj: str, hand: str | None = None) -> tuple[int, int]:
    """The span of ``[objects.OBJ]`` (``hand``: of ``[objects.OBJ.hands.HAND]``, which must exist)."""
    target = _table_name(obj, hand)
    span = _find_span(lines, target)
    if span is None:
        raise UsageError(f"no [{target}] table in the object file")
    return span


def _check_hand_name(hand: str) -> None:
    check_identifier_arg(hand, "the hand's name (its [objects.NAME.hands.HAND] table)")


def _add_hand_table(lines: list[str], obj: str, hand: str) -> tuple[int, int]:
    """Add an empty ``[objects.OBJ.hands.HAND]`` after the object's last hand table (or its own
    keys); returns its span. Comments directly above the next header stay with that header."""
    start, end = _table_span(lines, obj)
    prefix = f"objects.{obj}.hands."
    for line in lines:
        name = _header(line)
        if name is not None and name.startswith(prefix):
            span = _find_span(lines, name)
            assert span is not None
            start, end = span
    at = end
    if end < len(lines):  # the comment block right above the next header belongs to it
        while at - 1 > start and lines[at - 1].lstrip().startswith("#"):
            at -= 1
    while at - 1 > start and not lines[at - 1].strip():
        at -= 1
    if not lines[at - 1].endswith(("\n", "\r")):
        lines[at - 1] += "\n"
    block = ["\n", f"[{_table_name(obj, hand)}]\n"]
    if at < len(lines) and lines[at].strip():
        block.append("\n")  # a blank line before what follows
    lines[at:at] = block
    return at + 1, at + 2


def set_object_comment(text: str, obj: str, comment: str, hand: str | None = None) -> str:
    """``# chosen by: COMMENT`` on the line above ``[objects.OBJ]`` (``hand``: above
    ``[objects.OBJ.hands.HAND]``), replacing one already there."""
    comment = " ".join(comment.split())  # one line, whatever the command held
    lines = text.splitlines(keepends=True)
    start, _ = _table_span(lines, obj, hand)
    line = f"{CHOSEN_BY}{comment}\n"
    if start > 0 and lines[start - 1].startswith(CHOSEN_BY):
        lines[start - 1] = line
    else:
        lines.insert(start, line)
    return "".join(lines)


def set_object_value(text: str, obj: str, key: str, value: Value, hand: str | None = None) -> str:
    """``key = value`` in ``[objects.OBJ]``, or with ``hand`` in ``[objects.OBJ.hands.HAND]``
    (added when missing): the line replaced, or added after the table's last key."""
    lines = text.splitlines(keepends=True)
    if hand is not None:
        _check_hand_name(hand)
        start, end = _table_span(lines, obj)  # the object's own table must exist
        if any(_header(line) == f"objects.{obj}.hands" for line in lines) or any(
            (m := _KEY.match(lines[i].rstrip("\r\n"))) and m.group(2) == "hands" for i in range(start + 1, end)
        ):
            raise UsageError(
                f"[objects.{obj}] holds its hands in one table or inline; tune --write writes "
                f"[objects.{obj}.hands.{hand}] tables: make them tables of their own by hand"
            )
        span = _find_span(lines, _table_name(obj, hand))
        start, end = span if span is not None else _add_hand_table(lines, obj, hand)
    else:
        start, end = _table_span(lines, obj)
    table = _table_name(obj, hand)
    sub = f"{table}.{key}"
    if any(_header(line) == sub for line in lines):
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


def update_object_file(path: Path, obj: str, values: dict[str, Value], *, hand: str) -> str:
    """Write the new values into ``path`` for ``hand``; returns the unified diff ('' when unchanged)."""
    return update_objects_file(path, {obj: values}, hand=hand)


def update_objects_file(
    path: Path, values: dict[str, dict[str, Value]], comment: str | None = None, *, hand: str
) -> str:
    """Write every object's new values into ``path`` at once, into the tables of ``hand`` (the
    name of the hand they were tuned on: ``[objects.NAME.hands.HAND]``, added where missing;
    never the object level or another hand's table); returns the unified diff ('' when
    unchanged). ``comment``: set as ``# chosen by: COMMENT`` above each changed hand table.
    The new text must load for ``hand`` and read the values back from its tables; then the
    file is replaced in place (``safe_write.replace_in_place``: a symlink is followed and its
    target replaced, the link stays; the file keeps its mode and owner)."""
    _check_hand_name(hand)
    path = Path(path)
    target = Path(os.path.realpath(path))
    if not target.is_file():
        raise UsageError(f"{path}: not a file")
    old = target.read_text(encoding="utf-8")
    new = old
    for obj, obj_values in values.items():
        before = new
        for key, value in obj_values.items():
            new = set_object_value(new, obj, key, value, hand)
        if comment is not None and new != before:
            new = set_object_comment(new, obj, comment, hand)
    if new == old:
        return ""
    _check_loads(new, path, values, hand)
    replace_in_place(path, new)  # follows a symlink; keeps the target's mode and owner (files/safe_write.py)
    return "".join(
        difflib.unified_diff(
            old.splitlines(keepends=True),
            new.splitlines(keepends=True),
            fromfile=f"{path} (before)",
            tofile=f"{path} (after)",
        )
    )


def _check_loads(text: str, path: Path, values: dict[str, dict[str, Value]], hand: str) -> None:
    """Refuse to write an object file that would not load or not read the new values back
    from ``hand``'s tables."""
    with tempfile.TemporaryDirectory() as folder:
        probe = Path(folder) / Path(path).name
        probe.write_text(text, encoding="utf-8")
        profiles = load_objects(probe, hand)
    for obj, obj_values in values.items():
        if profiles[obj].tuned_for != hand:
            raise UsageError(f"{path}: {obj} did not read back [objects.{obj}.hands.{hand}]")
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
