"""Numeric CSV recordings read row by row: a bad row is reported by its line, or skipped.

``read_rows(path, spec)`` returns the text columns and a float array of the numeric
columns for every good row. A row is bad when it has fewer fields than the header,
a field that is not a number (binary junk included), a non-finite number, or one
outside its column's range; the first bad row raises UsageError
``FILE: line N: COLUMN: what was expected (got ...)``, or with ``skip_bad_rows``
every bad row is left out and one warning names how many and the first.
"""

from __future__ import annotations

import csv
import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from grasp_ctrl.errors import UsageError

MAX_FIELD = 1 << 16  # characters in one field: a recording's numbers are short


@dataclass(frozen=True)
class Column:
    name: str
    lo: float = -math.inf
    hi: float = math.inf


@dataclass
class Rows:
    text: list[list[str]] = field(default_factory=list)  # the text columns of each good row
    values: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    lines: list[int] = field(default_factory=list)  # each good row's line number
    skipped: list[str] = field(default_factory=list)  # why each bad row was left out


def _warn(msg: str) -> None:
    print(f"warning: {msg}", file=sys.stderr, flush=True)


def _shown(text: str) -> str:
    return repr(text if len(text) <= 24 else text[:24] + "...")


def read_rows(
    path: str | Path,
    numeric: Sequence[Column],
    text: Sequence[str] = (),
    *,
    skip_bad_rows: bool = False,
    what: str = "recording",
    row_check: Callable[[np.ndarray], str | None] | None = None,
    warn: Callable[[str], None] = _warn,
) -> Rows:
    """See the module's doc. ``row_check(values)`` may refuse a row whose numbers are each
    fine but not together (a zero normal vector); it returns why, or None."""
    p = Path(path)
    try:
        fh = p.open(newline="", encoding="utf-8", errors="replace")  # junk bytes fail as numbers, by line
    except OSError as exc:
        raise UsageError(f"{p}: cannot read the {what} ({exc.strerror or exc})") from None
    out = Rows()
    good: list[list[float]] = []
    old_limit = csv.field_size_limit(MAX_FIELD)
    try:
        with fh:
            reader = csv.reader(fh)
            try:
                header = next(reader, None)
            except csv.Error as exc:
                raise UsageError(f"{p}: line 1: not a CSV header ({exc})") from None
            if not header:
                raise UsageError(
                    f"{p}: empty file, expected a header with {', '.join([*text, *(c.name for c in numeric)])}"
                )
            header = [h.strip() for h in header]
            missing = [c for c in [*text, *(c.name for c in numeric)] if c not in header]
            if missing:
                raise UsageError(f"{p}: line 1: missing column(s) {', '.join(missing)}")
            t_idx = [header.index(c) for c in text]
            n_idx = [header.index(c.name) for c in numeric]
            while True:
                try:
                    row = next(reader)
                except StopIteration:
                    break
                except csv.Error as exc:
                    bad = f"line {reader.line_num}: not a CSV row ({exc})"
                    if not skip_bad_rows:
                        raise UsageError(f"{p}: {bad}") from None
                    out.skipped.append(bad)
                    continue
                line = reader.line_num
                if not row or all(not v.strip() for v in row):
                    continue
                why = _check_row(row, len(header), numeric, n_idx, line)
                values: list[float] = []
                if why is None:
                    values = [float(row[i]) for i in n_idx]
                    extra = row_check(np.asarray(values)) if row_check else None
                    why = f"line {line}: {extra}" if extra else None
                if why is not None:
                    if not skip_bad_rows:
                        raise UsageError(f"{p}: {why} (or --skip-bad-rows)")
                    out.skipped.append(why)
                    continue
                out.text.append([row[i] for i in t_idx])
                out.lines.append(line)
                good.append(values)
    finally:
        csv.field_size_limit(old_limit)
    out.values = np.asarray(good, dtype=float).reshape(len(good), len(numeric))
    if out.skipped:
        warn(f"{p}: skipped {len(out.skipped)} bad row(s); first: {out.skipped[0]}")
    return out


def _check_row(row: list[str], width: int, numeric: Sequence[Column], idx: list[int], line: int) -> str | None:
    if len(row) < width:
        return f"line {line}: {len(row)} field(s), the header has {width}"
    for col, i in zip(numeric, idx):
        raw = row[i].strip()
        try:
            v = float(raw)
        except ValueError:
            return f"line {line}: {col.name}: a number (got {_shown(raw)})"
        if not math.isfinite(v):
            return f"line {line}: {col.name}: a finite number (got {_shown(raw)})"
        if not col.lo <= v <= col.hi:
            return f"line {line}: {col.name}: a number from {col.lo:g} to {col.hi:g} (got {v:g})"
    return None
