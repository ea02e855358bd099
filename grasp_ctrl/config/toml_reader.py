"""Typed access to a parsed TOML table that reports errors as ConfigError.

Every error names the file, the dotted key and what was expected, so the
command line can print one line and exit with status 2.
"""

from __future__ import annotations

import builtins
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal, overload

from grasp_ctrl.config.toml_limits import TomlFileError, read_toml_limited
from grasp_ctrl.errors import ConfigError

_MISSING = object()
# A vector's components beyond this are refused (no length or angle in a hand or object file
# comes near it; 1e308 would overflow the norm and "normalise" to zero).
MAX_VECTOR_COMPONENT = 1e3


def finite_number(value: Any) -> bool:
    """An int or float (not a bool) that is finite as a float: a 400-digit integer is not."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def read_toml(path: str | Path) -> dict[str, Any]:
    """The parsed file, read within config/toml_limits.py's size and table limits."""
    try:
        return read_toml_limited(path)
    except TomlFileError as exc:
        raise ConfigError(str(Path(path)), "<file>", str(exc)) from None


class Table:
    """A TOML table plus where it came from, for error messages."""

    def __init__(self, path: str | Path, data: dict[str, Any], prefix: str = "") -> None:
        self.path = str(path)
        self.data = data
        self.prefix = prefix

    def key(self, name: str) -> str:
        return f"{self.prefix}{name}"

    def fail(self, name: str, expected: str) -> ConfigError:
        return ConfigError(self.path, self.key(name), expected)

    def has(self, name: str) -> bool:
        return name in self.data

    def _get(self, name: str, default: Any) -> Any:
        if name in self.data:
            return self.data[name]
        if default is _MISSING:
            raise self.fail(name, "required key is missing")
        return default

    def table(self, name: str, default: Any = _MISSING) -> Table:
        value = self._get(name, {} if default is not _MISSING else _MISSING)
        if not isinstance(value, dict):
            raise self.fail(name, "a table")
        return Table(self.path, value, f"{self.key(name)}.")

    def tables(self, name: str, min_len: int = 0) -> list[Table]:
        value = self._get(name, _MISSING if min_len else [])
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise self.fail(name, "an array of tables")
        if len(value) < min_len:
            raise self.fail(name, f"at least {min_len} entries")
        return [Table(self.path, v, f"{self.key(name)}[{i}].") for i, v in enumerate(value)]

    def str(self, name: str, default: Any = _MISSING, choices: Sequence[str] | None = None) -> str:
        value = self._get(name, default)
        if not isinstance(value, str) or not value:
            raise self.fail(name, "a non-empty string")
        if choices is not None and value not in choices:
            raise self.fail(name, f"one of {', '.join(choices)} (got {value!r})")
        return value

    # The accessors below are named after the types they return and shadow those builtins
    # inside the class body: annotations after this point spell them builtins.str etc.

    def bool(self, name: builtins.str, default: Any = _MISSING) -> builtins.bool:
        value = self._get(name, default)
        if not isinstance(value, bool):
            raise self.fail(name, "true or false")
        return value

    def int(
        self,
        name: builtins.str,
        default: Any = _MISSING,
        lo: builtins.int | None = None,
        hi: builtins.int | None = None,
    ) -> builtins.int:
        value = self._get(name, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(name, "an integer")
        _check_range(self, name, value, lo, hi)
        return value

    def float(
        self,
        name: builtins.str,
        default: Any = _MISSING,
        lo: builtins.float | None = None,
        hi: builtins.float | None = None,
        lo_open: builtins.bool = False,
    ) -> builtins.float:
        value = self._get(name, default)
        if not finite_number(value):
            span = (
                ""
                if lo is None and hi is None
                else f" from {lo if lo is not None else '-inf'} to {hi if hi is not None else 'inf'}"
            )
            raise self.fail(name, f"a finite number{span} (got {_shown(value)})")
        if lo_open and lo is not None and value <= lo:
            raise self.fail(name, f"a number > {lo} (got {value})")
        _check_range(self, name, float(value), lo, hi)
        return float(value)

    @overload
    def vector(
        self,
        name: builtins.str,
        n: Literal[2],
        default: Any = ...,
        unit: builtins.bool = ...,
        bound: builtins.float = ...,
    ) -> tuple[builtins.float, builtins.float]: ...

    @overload
    def vector(
        self,
        name: builtins.str,
        n: Literal[3],
        default: Any = ...,
        unit: builtins.bool = ...,
        bound: builtins.float = ...,
    ) -> tuple[builtins.float, builtins.float, builtins.float]: ...

    @overload
    def vector(
        self,
        name: builtins.str,
        n: builtins.int,
        default: Any = ...,
        unit: builtins.bool = ...,
        bound: builtins.float = ...,
    ) -> tuple[builtins.float, ...]: ...

    def vector(
        self,
        name: builtins.str,
        n: builtins.int,
        default: Any = _MISSING,
        unit: builtins.bool = False,
        bound: builtins.float = MAX_VECTOR_COMPONENT,
    ) -> tuple[builtins.float, ...]:
        """A list of ``n`` finite numbers; ``n`` of 2 or 3 types the result as a pair or triple."""
        value = self._get(name, default)
        if not isinstance(value, (list, tuple)) or len(value) != n or not all(finite_number(v) for v in value):
            raise self.fail(name, f"a list of {n} finite numbers")
        vec = tuple(float(v) for v in value)
        if any(abs(v) > bound for v in vec):
            raise self.fail(name, f"a list of {n} numbers from {-bound:g} to {bound:g} (got {list(vec)})")
        if unit:
            norm = math.hypot(*vec)
            if norm < 1e-9:
                raise self.fail(name, "a non-zero vector")
            vec = tuple(v / norm for v in vec)
        return vec

    def unknown_keys(self, allowed: set[builtins.str]) -> None:
        """Reject typos: a misspelt safety limit must not silently fall back to a default."""
        for k in self.data:
            if k not in allowed:
                raise self.fail(k, f"a known key (allowed: {', '.join(sorted(allowed))})")


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:20]}... ({len(text)} characters)"


def _check_range(t: Table, name: str, value: float, lo: float | None, hi: float | None) -> None:
    if lo is not None and value < lo:
        raise t.fail(name, f"a value >= {lo} (got {_shown(value)})")
    if hi is not None and value > hi:
        raise t.fail(name, f"a value <= {hi} (got {_shown(value)})")
