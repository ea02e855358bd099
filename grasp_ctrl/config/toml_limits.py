"""TOML files read with limits: the file's size before a byte is read, and the tables and arrays.

``read_toml_limited(path)`` returns the parsed document or raises :class:`TomlFileError` whose
message says what was expected, in words (no path: ``config/toml_reader.py`` names the file and
the ``<file>`` key the way every configuration error does). Every TOML file the program reads
(hand files, object files, pushed-object files) comes through here, as every JSON file comes
through ``files/json_limits.py``: a huge or sparse file is refused from its size at once instead
of being read whole and parsed for a minute. It lives in ``config/``, beside its one caller, not in
``files/`` beside ``json_limits.py``: ``files/`` imports ``config/`` (identifiers), and the layering
allows no import back (tests/test_architecture.py).
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any

from grasp_ctrl.errors import GraspCtrlError

#: The largest TOML file read (the shipped hand files are about 17 kB, the object file 7 kB; tomllib
#: parses about 1 MB/s, so this also bounds the parse to a few seconds).
MAX_BYTES = 2 * 1024 * 1024
#: The most tables and arrays one file may hold (the LEAP hand file has about 320).
MAX_CONTAINERS = 50_000


class TomlFileError(GraspCtrlError):
    """A TOML file that is missing, too big, not UTF-8 or not TOML."""

    exit_status = 2


def shown_size(n_bytes: int) -> str:
    """``n_bytes`` in the largest binary unit that keeps it above 1 (``1.0 GiB``, ``2 MiB``)."""
    for unit, scale in (("GiB", 1024**3), ("MiB", 1024**2), ("kiB", 1024)):
        if n_bytes >= scale:
            value = n_bytes / scale
            return f"{value:.0f} {unit}" if value == int(value) else f"{value:.1f} {unit}"
    return f"{n_bytes} bytes"


def containers(doc: Any) -> int:
    """The number of tables and arrays in a parsed document (the root table counts), without recursion."""
    count = 0
    stack = [doc]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            count += 1
            stack.extend(v for v in node.values() if isinstance(v, (dict, list)))
        elif isinstance(node, list):
            count += 1
            stack.extend(v for v in node if isinstance(v, (dict, list)))
    return count


def _too_big(n_bytes: int, max_bytes: int, at_least: bool = False) -> TomlFileError:
    got = f"at least {shown_size(n_bytes)}" if at_least else f"{shown_size(n_bytes)}, {n_bytes} bytes"
    return TomlFileError(f"a TOML file of at most {shown_size(max_bytes)} (got {got})")


def read_bytes_limited(path: Path, max_bytes: int) -> bytes:
    """The file's bytes; refused from its size before reading, and again while reading for files
    whose size says nothing (a pipe, /dev/zero)."""
    try:
        with path.open("rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            if size > max_bytes:
                raise _too_big(size, max_bytes)
            raw = fh.read(max_bytes + 1)
    except FileNotFoundError:
        raise TomlFileError("file not found") from None
    except IsADirectoryError:
        raise TomlFileError("a TOML file, got a directory") from None
    except OSError as exc:
        raise TomlFileError(f"a readable file ({exc.strerror or exc.__class__.__name__})") from None
    if len(raw) > max_bytes:
        raise _too_big(len(raw), max_bytes, at_least=True)
    return raw


def read_toml_limited(
    path: str | Path, max_bytes: int = MAX_BYTES, max_containers: int = MAX_CONTAINERS
) -> dict[str, Any]:
    """The parsed TOML document of ``path`` within the limits (see the module docstring)."""
    raw = read_bytes_limited(Path(path), max_bytes)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise TomlFileError(f"UTF-8 text (byte {exc.start} is not)") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise TomlFileError(f"valid TOML ({exc})") from None
    except RecursionError:
        raise TomlFileError("valid TOML (nested too deeply)") from None
    n = containers(doc)
    if n > max_containers:
        raise TomlFileError(f"a TOML file of at most {max_containers} tables and arrays (got {n})")
    return doc
