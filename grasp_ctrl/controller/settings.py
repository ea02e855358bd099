"""The base of every controller's settings: their flat view and their checks.

Each controller's settings are a frozen dataclass beside it, a subclass of ``ControllerSettings``
(the paper's in controller/paper_settings.py, grip_load's in controller/grip_load_settings.py):
its fields with that controller's defaults, some gathered in nested frozen dataclasses (groups).
Users name a setting by its flat key, the field's own name wherever it sits (``tune --param
setting.KEY``, a hand file's ``[controllers.NAME]`` table, run.json, trial records), so a key is
unique within a class. The controllers by name, and the flat table run.json and the records
keep: controller/registry.py.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, Self

from grasp_ctrl.config.toml_reader import finite_number
from grasp_ctrl.errors import ConfigError, UsageError

MAX_SETTING = 1e6  # no controller setting (seconds, metres, newtons, ratios) comes near it


def after(key: str) -> dict[str, str]:
    """A field's metadata placing its flat keys right after ``key`` in the flat table (by default
    a subclass's fields follow its base's, each after the one before)."""
    return {"after": key}


@dataclass(frozen=True)
class ControllerSettings:
    """Settings of one controller: a subclass names it (``controller``) and holds its fields."""

    #: The registry's name of the controller these settings are for (controller/registry.py).
    controller: ClassVar[str] = ""
    #: The text settings and their values.
    CHOICES: ClassVar[Mapping[str, tuple[str, ...]]] = {}
    #: The number settings that may be zero (every other one is > 0).
    ZERO_ALLOWED: ClassVar[tuple[str, ...]] = ()

    @classmethod
    def flat_keys(cls) -> tuple[str, ...]:
        """Every setting's flat key, in the flat table's order."""
        return _layout(cls)[0]

    def setting(self, key: str) -> Any:
        """The value of the setting whose flat key is ``key``."""
        group = _layout(type(self))[1][key]
        return getattr(getattr(self, group), key) if group else getattr(self, key)

    def as_flat_dict(self) -> dict[str, Any]:
        """``{"controller": name, KEY: value, ...}``, the keys in ``flat_keys`` order."""
        return {"controller": self.controller, **{key: self.setting(key) for key in self.flat_keys()}}

    def replace(self, **values: Any) -> Self:
        """A copy with the settings named by their flat keys changed (``dataclasses.replace`` by
        flat key: a setting in a group is set within it)."""
        homes = _layout(type(self))[1]
        top: dict[str, Any] = {}
        grouped: dict[str, dict[str, Any]] = {}
        for key, value in values.items():
            if key not in homes:
                raise TypeError(f"{type(self).__name__} has no setting {key!r}")
            group = homes[key]
            if group:
                grouped.setdefault(group, {})[key] = value
            else:
                top[key] = value
        for group, own in grouped.items():
            top[group] = dataclasses.replace(getattr(self, group), **own)
        return dataclasses.replace(self, **top) if top else self

    @classmethod
    def check(cls, values: Mapping[str, Any], where: str, table: str | None = None) -> dict[str, Any]:
        """``values`` (flat keys) checked as this controller's settings: known keys, each of its
        default's type, a text setting one of ``CHOICES``, numbers finite, positive and at most
        ``MAX_SETTING`` (those of ``ZERO_ALLOWED`` may be zero). Raises a UsageError naming
        ``where`` and ``settings.KEY``, or with ``table`` (a file's table, ``where`` the file) a
        ConfigError naming the file and ``table.KEY``."""

        def fail(key: str, need: str) -> Exception:
            if table is not None:
                return ConfigError(where, f"{table}.{key}", need)
            return UsageError(f"{where}: settings.{key}: {need}")

        defaults = cls().as_flat_dict()
        del defaults["controller"]
        out: dict[str, Any] = {}
        for key, v in values.items():
            if key not in defaults:
                raise fail(key, f"a known setting (one of {', '.join(sorted(defaults))})")
            default = defaults[key]
            if isinstance(default, bool):
                if not isinstance(v, bool):
                    raise fail(key, f"true or false (got {v!r})")
            elif isinstance(default, str):
                choices = cls.CHOICES.get(key, ())
                if v not in choices:
                    raise fail(key, f"one of {', '.join(choices)} (got {v!r})")
            elif not finite_number(v) or v < 0 or v > MAX_SETTING or (v == 0 and key not in cls.ZERO_ALLOWED):
                zero = key in cls.ZERO_ALLOWED
                need = f"a finite number {'>=' if zero else '>'} 0 and <= {MAX_SETTING:g}"
                shown = repr(v) if len(repr(v)) <= 40 else f"{repr(v)[:20]}..."
                raise fail(key, f"{need} (got {shown})")
            out[key] = v
        return out

    @classmethod
    def from_flat(cls, values: Mapping[str, Any], where: str, table: str | None = None) -> Self:
        """The defaults with ``values`` (flat keys, checked: ``check``)."""
        return cls().replace(**cls.check(values, where, table))


_LAYOUTS: dict[type, tuple[tuple[str, ...], dict[str, str | None]]] = {}


def _layout(cls: type[ControllerSettings]) -> tuple[tuple[str, ...], dict[str, str | None]]:
    """(the flat keys in order, each key's group field or None for a field of its own), made
    once per class."""
    got = _LAYOUTS.get(cls)
    if got is None:
        got = _LAYOUTS[cls] = _make_layout(cls)
    return got


def _make_layout(cls: type[ControllerSettings]) -> tuple[tuple[str, ...], dict[str, str | None]]:
    """A subclass's keys follow its base's: a field inherited (a default changed) stays in place,
    a new one goes after the field before it, or after the key its metadata names (``after``)."""
    base = cls.__bases__[0]
    keys = list(_layout(base)[0]) if base is not ControllerSettings and issubclass(base, ControllerSettings) else []
    inherited = set(keys)
    homes: dict[str, str | None] = {}
    defaults = cls()
    pos = len(keys)
    for f in dataclasses.fields(cls):
        value = getattr(defaults, f.name)
        group = dataclasses.is_dataclass(value)
        leaves = [g.name for g in dataclasses.fields(value)] if group else [f.name]
        for leaf in leaves:
            if leaf in homes or leaf == "controller":
                raise TypeError(f"{cls.__name__}: the setting {leaf!r} twice (flat keys are unique)")
            homes[leaf] = f.name if group else None
        if leaves[0] in inherited:
            continue
        if "after" in f.metadata:
            pos = keys.index(f.metadata["after"]) + 1
        keys[pos:pos] = leaves
        pos += len(leaves)
    return tuple(keys), homes
