"""Numbers from flags and text, checked for type and range with one line saying which.

``parse_float("nan", "--fps", lo=0, hi=100, lo_open=True)`` raises UsageError
``--fps: a finite number > 0 and <= 100 (got 'nan')``. ``float_type``/``int_type`` give the
same checks as argparse ``type=`` callables (argparse prints the line and exits 2).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import TypeVar

from grasp_ctrl.errors import UsageError

_Number = TypeVar("_Number", int, float)


def _span(lo: float | None, hi: float | None, lo_open: bool = False, integer: bool = False) -> str:
    kind = "an integer" if integer else "a finite number"
    parts = []
    if lo is not None:
        parts.append(f"{'>' if lo_open else '>='} {lo:g}")
    if hi is not None:
        parts.append(f"<= {hi:g}")
    return kind + (" " + " and ".join(parts) if parts else "")


def _shown(text: str) -> str:
    return repr(text if len(text) <= 40 else text[:20] + "...")


def check_float(
    value: float, what: str, lo: float | None = None, hi: float | None = None, lo_open: bool = False
) -> float:
    """``value`` if finite and in range, else UsageError naming ``what`` and the range."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    if ok:
        try:
            value = float(value)
        except OverflowError:
            ok = False
    if (
        not ok
        or not math.isfinite(value)
        or (lo is not None and (value < lo or (lo_open and value == lo)))
        or (hi is not None and value > hi)
    ):
        raise UsageError(f"{what}: {_span(lo, hi, lo_open)} (got {_shown(str(value))})")
    return value


def parse_float(text: str, what: str, lo: float | None = None, hi: float | None = None, lo_open: bool = False) -> float:
    """``text`` as a float checked by :func:`check_float` (``1e999``, ``nan``, ``inf`` refused)."""
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise UsageError(f"{what}: {_span(lo, hi, lo_open)} (got {_shown(str(text))})") from None
    return check_float(value, what, lo, hi, lo_open)


def parse_int(text: str, what: str, lo: int | None = None, hi: int | None = None) -> int:
    text = str(text).strip()
    if len(text) > 30:  # no count or seed here has more digits; int() of thousands is slow
        raise UsageError(f"{what}: {_span(lo, hi, integer=True)} (got {_shown(text)})")
    try:
        value = int(text)
    except ValueError:
        raise UsageError(f"{what}: {_span(lo, hi, integer=True)} (got {_shown(text)})") from None
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise UsageError(f"{what}: {_span(lo, hi, integer=True)} (got {value})")
    return value


def _argparse_type(parse: Callable[[str], _Number], name: str) -> Callable[[str], _Number]:
    def convert(text: str) -> _Number:
        try:
            return parse(text)
        except UsageError as exc:
            raise argparse.ArgumentTypeError(str(exc).split(": ", 1)[-1]) from None

    convert.__name__ = name
    return convert


def float_type(lo: float | None = None, hi: float | None = None, lo_open: bool = False) -> Callable[[str], float]:
    """An argparse ``type=``: a finite float in range."""
    return _argparse_type(lambda t: parse_float(t, "value", lo, hi, lo_open), "float")


def int_type(lo: int | None = None, hi: int | None = None) -> Callable[[str], int]:
    """An argparse ``type=``: an integer in range."""
    return _argparse_type(lambda t: parse_int(t, "value", lo, hi), "int")


def parse_values(
    text: str, what: str, lo: float, hi: float, integer: bool = False, max_count: int = 1000
) -> list[float | int]:
    """A sweep's values: ``START:STOP:STEP`` (STOP included), ``A,B,C`` or one value, each
    checked by :func:`parse_float` (or :func:`parse_int`) against [lo, hi]; the count of a
    range is checked before the list is built, so ``1:1e300:1e-300`` costs nothing."""
    one = (lambda t: parse_int(t, what, int(lo), int(hi))) if integer else (lambda t: parse_float(t, what, lo, hi))
    text = str(text).strip()
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise UsageError(f"{what}: START:STOP:STEP (got {_shown(text)})")
        start, stop = one(parts[0]), one(parts[1])
        step = parse_float(parts[2], f"{what} step", 0.0, hi - lo if hi > lo else 1.0, lo_open=True)
        if stop < start:
            raise UsageError(f"{what}: STOP below START (got {_shown(text)})")
        span = (stop - start) / step
        if not span < max_count:  # also catches inf (a step of 1e-320)
            raise UsageError(f"{what}: at most {max_count} values (got {_shown(text)})")
        count = math.floor(span + 1e-9) + 1
        values = [start + i * step for i in range(count)]
        return [round(v) for v in values] if integer else [round(v, 12) for v in values]
    values = [one(v) for v in text.split(",") if v.strip()]
    if not values or len(values) > max_count:
        raise UsageError(f"{what}: 1 to {max_count} values (got {_shown(text)})")
    return values
