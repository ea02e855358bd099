"""Load a force-estimator policy by name or path.

A policy is ``policies/NAME.json`` (metadata, docs/design.md 5.5), plus
``policies/NAME.onnx`` for network policies. The metadata's ``kind`` picks the
loader; each loader checks the metadata against the hand's sensors.
``oracle`` and ``oracle:scale=K`` are debugging policies of the mock world and
are built by the trial runner, not here.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.identifiers import check_identifier_arg, check_policy_identifier
from grasp_ctrl.errors import PolicyError
from grasp_ctrl.estimators.analytic import AnalyticEstimator
from grasp_ctrl.estimators.base import ForceEstimator
from grasp_ctrl.files.json_limits import JsonFileError, read_json
from grasp_ctrl.files.paths import policies_dir

DEFAULT_POLICY = "mlp_mock"

# kind -> "module:function" taking (meta, json_path, hand, threads) and returning an estimator.
# Loaders are imported lazily so that e.g. onnxruntime is only loaded when used.
LOADERS: dict[str, str] = {
    "analytic": "grasp_ctrl.estimators.registry:load_analytic",
    "linear": "grasp_ctrl.estimators.registry:load_linear",
    "mlp": "grasp_ctrl.estimators.registry:load_mlp",
    "onnx": "grasp_ctrl.estimators.onnx_estimator:load_onnx_policy",
    "calibrated": "grasp_ctrl.estimators.calibrated:load_calibrated_policy",
}


def resolve_policy_path(spec: str) -> Path:
    """NAME -> policies/NAME.json; PATH (.json or .onnx) -> its .json. A NAME is an identifier
    (config/identifiers.py), else a one-line UsageError."""
    p = Path(spec)
    if p.suffix in (".json", ".onnx") or p.parent != Path("."):
        json_path = p.with_suffix(".json")
    else:
        json_path = policies_dir() / f"{check_identifier_arg(spec, 'policy')}.json"
    if not json_path.is_file():
        known = ", ".join(list_policy_names()) or "none"
        raise PolicyError(f"policy {spec!r}: no metadata file {json_path} (known policies: {known}, oracle)")
    return json_path


def read_metadata(json_path: Path) -> dict[str, Any]:
    try:
        meta = read_json(json_path)
    except JsonFileError as exc:
        raise PolicyError(f"{json_path}: unreadable policy metadata ({exc})") from None
    if not isinstance(meta, dict) or "kind" not in meta:
        raise PolicyError(f"{json_path}: kind: required key is missing")
    if "name" in meta:
        check_policy_identifier(meta["name"], json_path, "name")
    return meta


def check_sensor(meta: dict[str, Any], json_path: Path, hand: HandConfig | None) -> None:
    if hand is None:
        return
    sensor = meta.get("sensor_type")
    if sensor != hand.tactile.sensor_type:
        raise PolicyError(
            f"{json_path}: sensor_type: policy is for {sensor!r}, the hand {hand.name!r} has {hand.tactile.sensor_type!r}"
        )


def load_analytic(meta: dict[str, Any], json_path: Path, hand: HandConfig | None, threads: int) -> ForceEstimator:
    gains: Any = meta.get("gains_n_per_count")  # a JSON value, checked by AnalyticEstimator
    try:
        return AnalyticEstimator(gains, name=meta.get("name", json_path.stem))
    except (TypeError, ValueError) as exc:
        raise PolicyError(f"{json_path}: gains_n_per_count: {exc}") from None


def load_linear(meta: dict[str, Any], json_path: Path, hand: HandConfig | None, threads: int) -> ForceEstimator:
    from grasp_ctrl.estimators.linear import LinearEstimator

    # JSON values, checked by LinearEstimator (a missing one fails there too)
    weights: Any = meta.get("weights_n_per_count")
    bias: Any = meta.get("bias_n")
    try:
        return LinearEstimator(weights, bias, name=meta.get("name", json_path.stem))
    except (TypeError, ValueError) as exc:
        raise PolicyError(f"{json_path}: weights_n_per_count/bias_n: {exc}") from None


def load_mlp(meta: dict[str, Any], json_path: Path, hand: HandConfig | None, threads: int) -> ForceEstimator:
    from grasp_ctrl.estimators.mlp import MlpEstimator

    try:
        return MlpEstimator(
            meta.get("input_channels"),
            meta.get("input_mean"),
            meta.get("input_scale"),
            meta.get("layers"),
            name=meta.get("name", json_path.stem),
        )
    except ValueError as exc:
        raise PolicyError(f"{json_path}: {exc}") from None


def load_policy(spec: str, hand: HandConfig | None = None, threads: int = 1) -> ForceEstimator:
    json_path = resolve_policy_path(spec)
    meta = read_metadata(json_path)
    check_sensor(meta, json_path, hand)
    kind = meta["kind"]
    if not isinstance(kind, str) or kind not in LOADERS:
        raise PolicyError(f"{json_path}: kind: one of {', '.join(LOADERS)} (got {kind!r})")
    module_name, func_name = LOADERS[kind].split(":")
    loader: Callable[..., ForceEstimator] = getattr(importlib.import_module(module_name), func_name)
    try:
        return loader(meta, json_path, hand, threads)
    except (TypeError, AttributeError, KeyError, ValueError, IndexError) as exc:
        # a section of the wrong type (a list where a table belongs, ...) that no field check caught
        raise PolicyError(f"{json_path}: malformed policy metadata ({type(exc).__name__}: {str(exc)[:200]})") from None


def list_policy_names() -> list[str]:
    d = policies_dir()
    return sorted(p.stem for p in d.glob("*.json")) if d.is_dir() else []
