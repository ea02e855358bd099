"""A per-sensor correction on top of another policy (policy kind ``calibrated``).

``f_sensor = A f_base + W e + b``: ``f_base`` the base policy's estimate, ``e`` the 19 tared
electrodes, ``A`` (3, 3), ``W`` (3, 19) N/count (zero unless the ``residual`` model was fitted),
``b`` (3,) N. Written by ``launch.py calibrate`` (grasp_ctrl/evaluation/calibration.py).

The base policy is found beside the calibrated policy's JSON first, then at the path recorded
at calibration, then in the registry's folder; its files must hash as when it was calibrated (a retrained base would silently
invalidate the correction).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.identifiers import check_policy_identifier
from grasp_ctrl.config.sensor_layout import ELECTRODES, FRAME_LEN
from grasp_ctrl.errors import PolicyError
from grasp_ctrl.estimators.base import Estimate, ForceEstimator
from grasp_ctrl.files.storage import file_sha256


class CalibratedEstimator:
    def __init__(
        self,
        base: ForceEstimator,
        matrix: npt.ArrayLike,
        electrode_weights: npt.ArrayLike | None,
        bias: npt.ArrayLike,
        name: str,
    ) -> None:
        self.base = base
        self.A = np.asarray(matrix, dtype=float).reshape(3, 3)
        self.W = np.zeros((3, 19)) if electrode_weights is None else np.asarray(electrode_weights, dtype=float)
        self.b = np.asarray(bias, dtype=float).reshape(3)
        if self.W.shape != (3, 19) or not all(np.isfinite(x).all() for x in (self.A, self.W, self.b)):
            raise ValueError("correction: matrix (3, 3), electrode_weights (3, 19) and bias (3,), all finite")
        self.name = name
        self.has_variance = bool(base.has_variance)

    def correct(self, f_base: np.ndarray, tared: np.ndarray) -> np.ndarray:
        return f_base @ self.A.T + np.asarray(tared, dtype=float)[:, ELECTRODES] @ self.W.T + self.b

    def estimate(self, tared: np.ndarray, fingers: Sequence[str]) -> Estimate:
        tared = np.asarray(tared, dtype=float)
        if tared.ndim != 2 or tared.shape[1] != FRAME_LEN:
            raise ValueError(f"{self.name}: expected tared frames of shape (n, {FRAME_LEN}), got {tared.shape}")
        est = self.base.estimate(tared, fingers)
        # per-axis variance through the linear map, axes taken as independent
        variance = None if est.variance is None else est.variance @ (self.A**2).T
        return Estimate(f_sensor=self.correct(est.f_sensor, tared), variance=variance)


def policy_files(json_path: Path, meta: dict[str, Any]) -> list[Path]:
    """The files a policy consists of: its JSON and, if any, its model file."""
    files = [json_path]
    model = json_path.parent / str(meta.get("model_file", json_path.with_suffix(".onnx").name))
    if model.is_file():
        files.append(model)
    return files


sha256_of = file_sha256  # the policy files' hashes (storage.file_sha256)


def _base_path(meta: dict[str, Any], json_path: Path) -> Path:
    from grasp_ctrl.estimators.registry import resolve_policy_path

    base = meta.get("base_policy")
    if not isinstance(base, dict) or not isinstance(base.get("name"), str) or not base["name"]:
        raise PolicyError(f"{json_path}: base_policy.name: required (the policy the correction applies to)")
    check_policy_identifier(base["name"], json_path, "base_policy.name")  # it names a file beside this one
    beside = json_path.parent / f"{base['name']}.json"
    if beside.is_file():
        return beside
    if isinstance(base.get("path"), str) and Path(base["path"]).is_file():
        return Path(base["path"])
    return resolve_policy_path(base["name"])


def load_calibrated_policy(
    meta: dict[str, Any], json_path: Path, hand: HandConfig | None, threads: int
) -> CalibratedEstimator:
    """Registry loader for kind "calibrated"."""
    from grasp_ctrl.estimators.registry import load_policy, read_metadata

    json_path = Path(json_path)
    base_json = _base_path(meta, json_path)
    base_meta = read_metadata(base_json)
    if base_meta.get("kind") == "calibrated":
        raise PolicyError(f"{json_path}: base_policy: {base_json} is itself calibrated (calibrate its base instead)")
    want = meta["base_policy"].get("sha256") or {}
    for f in policy_files(base_json, base_meta):
        if f.name in want and sha256_of(f) != want[f.name]:
            raise PolicyError(
                f"{json_path}: base_policy: {f} changed since the calibration (sha256 differs); "
                f"re-run `launch.py calibrate`"
            )
    base = load_policy(str(base_json), hand, threads)
    corr = meta.get("correction")
    if not isinstance(corr, dict):
        raise PolicyError(f"{json_path}: correction: required (matrix, electrode_weights_n_per_count, bias_n)")
    try:
        # JSON values, checked by CalibratedEstimator (a missing one fails there too)
        matrix: Any = corr.get("matrix")
        bias: Any = corr.get("bias_n")
        return CalibratedEstimator(
            base, matrix, corr.get("electrode_weights_n_per_count"), bias, name=str(meta.get("name", json_path.stem))
        )
    except (TypeError, ValueError) as exc:
        raise PolicyError(f"{json_path}: correction: {exc}") from None
