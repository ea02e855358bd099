"""Change one value of one object in an object-profile TOML file, textually.

Comments, spacing and key order are kept: only the ``key = value`` line of the
``[objects.NAME]`` table changes (or one line is added to that table). The new
text is checked by loading it before the file is replaced.
"""

from __future__ import annotations

import difflib
import os
import re
import stat
import tempfile
from pathlib import Path

from grasp_ctrl.config.objects import load_objects
from grasp_ctrl.errors import UsageError

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
            nl = lines[i][len(lines[i].rstrip("\r\n")):]
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
    unchanged). A symlink is followed and its target replaced (the link stays); the file keeps
    its mode and, where this process may set it, its owner and group. The new text is written to
    a temporary file beside the target, loaded and checked, fsynced, then renamed over it."""
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
    st = target.stat()
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(new)
            fh.flush()
            os.fsync(fh.fileno())
        profiles = load_objects(tmp)  # refuse to write a file that would not load
        for obj, obj_values in values.items():
            for key, value in obj_values.items():
                if abs(float(getattr(profiles[obj], key)) - float(value)) > 1e-12:
                    raise UsageError(f"{path}: {key} of {obj} did not read back as {value}")
        os.chmod(tmp, stat.S_IMODE(st.st_mode))
        if hasattr(os, "chown"):
            try:
                os.chown(tmp, st.st_uid, st.st_gid)
            except PermissionError:   # not ours to give away: the file keeps this user's ownership
                pass
        os.replace(tmp, target)
        os.chmod(target, stat.S_IMODE(st.st_mode))
        _fsync_dir(target.parent)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return "".join(difflib.unified_diff(old.splitlines(keepends=True), new.splitlines(keepends=True),
                                        fromfile=f"{path} (before)", tofile=f"{path} (after)"))


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
