"""BioTac forward-model parameters from a JSON file: overrides of ``BioTacParams``.

A file holds one object, ``{"field": value, ...}`` (or ``{"params": {...}}``), naming
only the fields that differ from the defaults; docs/mock_world.md lists every field.
"""

from __future__ import annotations

import math
from dataclasses import fields, replace
from pathlib import Path
from typing import Any, cast

from grasp_ctrl.config.toml_reader import finite_number
from grasp_ctrl.sim.biotac.model import DEFAULT_PARAMS, BioTacParams, rise_weights_of

MAX_MAGNITUDE = 1e9  # no parameter of the model (m, N/m, counts, ratios) comes near it


def _number(path: Path, name: str, value: object) -> float:
    number = float(cast(float, value)) if finite_number(value) else math.nan
    if not abs(number) <= MAX_MAGNITUDE:
        shown = repr(value) if len(repr(value)) <= 40 else f"{repr(value)[:20]}..."
        raise ValueError(
            f"{path}: {name}: need a finite number from {-MAX_MAGNITUDE:g} to {MAX_MAGNITUDE:g}, got {shown}"
        )
    return number


def load_biotac_params(path: str | Path) -> BioTacParams:
    """The defaults with the file's overrides; ValueError naming the file and field on bad input."""
    path = Path(path)
    from grasp_ctrl.files.json_limits import JsonFileError, read_json

    try:
        doc = read_json(path)
    except JsonFileError as exc:
        raise ValueError(f"{path}: {exc}") from None
    if isinstance(doc, dict) and isinstance(doc.get("params"), dict):
        doc = doc["params"]
    if not isinstance(doc, dict):
        raise ValueError(f"{path}: need a JSON object of BioTacParams fields")
    known = {f.name: f for f in fields(BioTacParams)}
    overrides: dict[str, Any] = {}  # a field's parsed value: a float, a tuple of floats or None
    for name, value in doc.items():
        if name not in known:
            raise ValueError(f"{path}: {name}: not a BioTacParams field")
        default = getattr(DEFAULT_PARAMS, name)
        if name == "rise_weights":
            if value is not None:
                if not isinstance(value, list):
                    raise ValueError(f"{path}: rise_weights: need a list of 19 numbers or null")
                value = tuple(_number(path, name, v) for v in value)
        elif isinstance(default, tuple):
            if not isinstance(value, list) or len(value) != len(default):
                raise ValueError(f"{path}: {name}: need a list of {len(default)} numbers")
            value = tuple(_number(path, name, v) for v in value)
        else:
            value = _number(path, name, value)
        overrides[name] = value
    params = replace(DEFAULT_PARAMS, **overrides)
    try:
        rise_weights_of(params)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    return params
