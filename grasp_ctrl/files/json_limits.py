"""JSON files read with limits: size, nesting depth, and numbers Python can hold.

``read_json(path)`` returns the parsed document or raises :class:`JsonFileError`
whose message says why in words (no path: the caller names the file the way its
command does). A file larger than ``max_bytes`` is not read; a document nested
deeper than ``max_depth`` is refused after parsing (the parser's own recursion
guard stops far deeper ones first).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from grasp_ctrl.errors import GraspCtrlError

MAX_BYTES = 16 * 1024 * 1024  # run.json, summary.json, policy metadata, trial records
MAX_DEPTH = 32  # the deepest file the program writes is about 6 levels


class JsonFileError(GraspCtrlError):
    """A JSON file that is too big, too deep, not UTF-8 or not JSON."""

    exit_status = 2


def depth(doc: Any) -> int:
    """Nesting depth of lists and objects (a scalar is 0), without recursion."""
    deepest = 0
    stack: list[tuple[Any, int]] = [(doc, 0)]
    while stack:
        node, d = stack.pop()
        if isinstance(node, dict):
            node = list(node.values())
        if isinstance(node, list):
            d += 1
            deepest = max(deepest, d)
            stack.extend((child, d) for child in node if isinstance(child, (dict, list)))
    return deepest


def parse_json(text: str, max_depth: int = MAX_DEPTH) -> Any:
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise JsonFileError(f"not JSON ({exc.msg} at line {exc.lineno}; truncated or corrupt?)") from None
    except RecursionError:
        raise JsonFileError(f"nested deeper than {max_depth} levels") from None
    except ValueError as exc:  # e.g. an integer of more digits than Python converts
        raise JsonFileError(f"not JSON ({str(exc)[:120]})") from None
    if depth(doc) > max_depth:
        raise JsonFileError(f"nested deeper than {max_depth} levels")
    return doc


def read_json(path: str | Path, max_bytes: int = MAX_BYTES, max_depth: int = MAX_DEPTH) -> Any:
    p = Path(path)
    try:
        with p.open("rb") as fh:
            raw = fh.read(max_bytes + 1)
    except IsADirectoryError:
        raise JsonFileError("a directory, not a JSON file") from None
    except OSError as exc:
        raise JsonFileError(f"cannot read ({exc.strerror or exc.__class__.__name__})") from None
    if len(raw) > max_bytes:
        size = f"{max_bytes // (1024 * 1024)} MiB" if max_bytes >= 1024 * 1024 else f"{max_bytes} bytes"
        raise JsonFileError(f"larger than {size}")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise JsonFileError(f"not UTF-8 text (byte {exc.start})") from None
    if not text.strip():
        raise JsonFileError("empty file")
    return parse_json(text, max_depth)
