"""Run-time estimator for exported policies whose ONNX inputs are features rather than
voxel grids (the Su et al. baseline: electrodes + pdc; the no-voxel ablation: electrodes +
contact point). numpy + onnxruntime only, no torch.

Voxel-grid policies (``input.kind == "voxel_grids"``) are served by
``grasp_ctrl.estimators.onnx_estimator``; this module handles the other two input kinds
with the same metadata layout (docs/design.md 5.5).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.sensor_layout import ELECTRODES, FRAME_LEN, PDC
from grasp_ctrl.errors import PolicyError
from grasp_ctrl.estimators.base import Estimate
from grasp_ctrl.estimators.onnx_checks import check_graph_io, verify_model_hash
from grasp_ctrl.tactile.features import contact_points

FEATURE_KINDS = {
    "electrodes_pdc": ("electrodes", "pdc"),
    "electrodes_contact_point": ("electrodes", "contact_point"),
}


def feature_tensors(kind: str, tared: np.ndarray) -> dict[str, np.ndarray]:
    tared = np.asarray(tared, dtype=float)
    out = {"electrodes": tared[:, ELECTRODES].astype(np.float32)}
    if kind == "electrodes_pdc":
        out["pdc"] = tared[:, PDC : PDC + 1].astype(np.float32)
    else:
        out["contact_point"] = contact_points(tared).astype(np.float32)
    return out


class FeatureOnnxEstimator:
    def __init__(self, session: Any, name: str, kind: str, force_output: str, to_f_sensor: float) -> None:
        self.session = session
        self.name = name
        self.kind = kind
        self.has_variance = False
        self._out = force_output
        self._sign = to_f_sensor

    def estimate(self, tared: np.ndarray, fingers: Sequence[str]) -> Estimate:
        tared = np.asarray(tared, dtype=float)
        if tared.ndim != 2 or tared.shape[1] != FRAME_LEN:
            raise ValueError(f"{self.name}: expected tared frames of shape (n, {FRAME_LEN}), got {tared.shape}")
        if len(tared) == 0:
            return Estimate(f_sensor=np.zeros((0, 3)))
        (f,) = self.session.run([self._out], feature_tensors(self.kind, tared))
        return Estimate(f_sensor=self._sign * np.asarray(f, dtype=float))


def load_feature_onnx_policy(
    meta: dict[str, Any], json_path: Path, hand: HandConfig | None, threads: int
) -> FeatureOnnxEstimator:
    json_path = Path(json_path)
    name = meta.get("name", json_path.stem)
    if meta.get("sensor_type") != "biotac":
        raise PolicyError(f"{json_path}: sensor_type: 'biotac' expected (got {meta.get('sensor_type')!r})")
    if hand is not None and hand.tactile.sensor_type != "biotac":
        raise PolicyError(
            f"{json_path}: sensor_type: policy is for 'biotac', the hand {hand.name!r} has {hand.tactile.sensor_type!r}"
        )
    kind = (meta.get("input") or {}).get("kind")
    if kind not in FEATURE_KINDS:
        raise PolicyError(f"{json_path}: input.kind: one of {', '.join(FEATURE_KINDS)} (got {kind!r})")
    if (meta.get("preprocessing") or {}).get("tare") != "value - baseline":
        raise PolicyError(f"{json_path}: preprocessing.tare: 'value - baseline' expected")
    out = meta.get("output") or {}
    if out.get("units") != "N" or out.get("frame") != "sensor" or out.get("to_f_sensor") not in (1, -1, 1.0, -1.0):
        raise PolicyError(f"{json_path}: output: units 'N', frame 'sensor' and to_f_sensor 1 or -1 expected")
    force_out = next(iter(out.get("tensors") or {"f_sensor": None}))
    model_file = json_path.parent / str(meta.get("model_file", json_path.with_suffix(".onnx").name))
    if not model_file.is_file():
        raise PolicyError(f"{json_path}: model_file: {model_file} does not exist")
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = max(1, int(threads))
    opts.inter_op_num_threads = 1
    verify_model_hash(meta, json_path, model_file)  # before onnxruntime parses the file
    try:
        session = ort.InferenceSession(str(model_file), opts, providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime raises its own types
        raise PolicyError(
            f"{model_file}: cannot load the ONNX model ({(str(exc).splitlines() or [type(exc).__name__])[0]})"
        ) from None
    check_graph_io(session, meta, json_path)
    have = {i.name for i in session.get_inputs()}
    if have != set(FEATURE_KINDS[kind]):
        raise PolicyError(
            f"{json_path}: input.tensors: the ONNX model takes {sorted(have)}, {kind} needs {list(FEATURE_KINDS[kind])}"
        )
    return FeatureOnnxEstimator(session, name, kind, force_out, float(out["to_f_sensor"]))
