"""ONNX force estimators (voxel-grid networks such as the ICRA 2019 model).

One ``onnxruntime.InferenceSession`` per policy; all fingertips in contact go
through one batched ``run``. The policy JSON (docs/design.md 5.5) is checked on load
against the hand's sensors and against the ONNX file's own inputs/outputs, so a
mismatch fails with a :class:`PolicyError` naming the file and the field.

The network's output is converted explicitly to ``f_sensor`` (force ON the
skin, sensor frame) with ``output.to_f_sensor`` from the metadata: the ICRA 2019
network predicts the force the finger applies (-f_sensor), so that is -1.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.sensor_layout import ELECTRODES, FRAME_LEN
from grasp_ctrl.errors import PolicyError
from grasp_ctrl.estimators.base import Estimate
from grasp_ctrl.estimators.onnx_checks import check_graph_io, verify_model_hash
from grasp_ctrl.tactile.features import contact_points
from grasp_ctrl.tactile.voxel import GRID_SHAPE, VARIANTS, VoxelGrid

if TYPE_CHECKING:
    from grasp_ctrl.estimators.feature_onnx_estimator import FeatureOnnxEstimator

SUPPORTED_INPUT_KINDS = ("voxel_grids",)
SUPPORTED_CONTACT_POINTS = ("squared_signal_centroid_projected",)
SUPPORTED_TARE = ("value - baseline",)


def _get(meta: dict[str, Any], json_path: Path, dotted: str, expected: str) -> Any:
    node: Any = meta
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            raise PolicyError(f"{json_path}: {dotted}: required key is missing ({expected})")
        node = node[part]
    return node


class OnnxEstimator:
    """Voxel-grid ONNX network -> f_sensor (and variance when the policy has one)."""

    def __init__(
        self,
        session: Any,
        name: str,
        electrode_input: str,
        contact_input: str,
        force_output: str,
        variance_output: str | None,
        to_f_sensor: float,
        voxel_variant: str,
    ) -> None:
        self.session = session
        self.name = name
        self.has_variance = variance_output is not None
        self._inputs = (electrode_input, contact_input)
        self._outputs = [force_output] + ([variance_output] if variance_output else [])
        self._sign = float(to_f_sensor)
        self.voxels = VoxelGrid(voxel_variant)

    def features(self, tared: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n, 44) tared frames -> electrode and contact grids, float32 (n, 16, 16, 8)."""
        e = tared[:, ELECTRODES]
        return self.voxels.electrode_grids(e), self.voxels.contact_grids(contact_points(e))

    def estimate(self, tared: np.ndarray, fingers: Sequence[str]) -> Estimate:
        tared = np.asarray(tared, dtype=float)
        if tared.ndim != 2 or tared.shape[1] != FRAME_LEN:
            raise ValueError(f"{self.name}: expected tared frames of shape (n, {FRAME_LEN}), got {tared.shape}")
        n = tared.shape[0]
        if n == 0:
            empty = np.zeros((0, 3))
            return Estimate(f_sensor=empty, variance=empty.copy() if self.has_variance else None)
        el, cp = self.features(tared)
        outs = self.session.run(self._outputs, {self._inputs[0]: el, self._inputs[1]: cp})
        f_sensor = self._sign * np.asarray(outs[0], dtype=float)
        variance = np.asarray(outs[1], dtype=float) if self.has_variance else None
        return Estimate(f_sensor=f_sensor, variance=variance)


def _check_onnx_interface(session: Any, json_path: Path, tensors_in: dict[str, Any], needed_out: list[str]) -> None:
    got_in = {i.name: i for i in session.get_inputs()}
    for name, spec in tensors_in.items():
        if name not in got_in:
            raise PolicyError(
                f"{json_path}: input.tensors: {name!r} is not an input of the ONNX model (it has {sorted(got_in)})"
            )
        shape = list(got_in[name].shape)[1:]
        want = list(spec.get("shape", []))[1:]
        if want and shape != want:
            raise PolicyError(f"{json_path}: input.tensors.{name}.shape: metadata says {want}, ONNX model has {shape}")
    got_out = {o.name for o in session.get_outputs()}
    for name in needed_out:
        if name not in got_out:
            raise PolicyError(
                f"{json_path}: output.tensors: {name!r} is not an output of the ONNX model (it has {sorted(got_out)})"
            )


def load_onnx_policy(
    meta: dict[str, Any], json_path: Path, hand: HandConfig | None, threads: int
) -> OnnxEstimator | FeatureOnnxEstimator:
    """Registry loader for kind "onnx" (see :mod:`grasp_ctrl.estimators.registry`)."""
    json_path = Path(json_path)
    name = meta.get("name", json_path.stem)
    if meta.get("sensor_type") != "biotac":
        raise PolicyError(
            f"{json_path}: sensor_type: this estimator reads BioTac frames, policy says {meta.get('sensor_type')!r}"
        )
    if hand is not None and hand.tactile.sensor_type != meta["sensor_type"]:
        raise PolicyError(
            f"{json_path}: sensor_type: policy is for {meta['sensor_type']!r}, the hand "
            f"{hand.name!r} has {hand.tactile.sensor_type!r}"
        )
    if (meta.get("input") or {}).get("kind") in ("electrodes_pdc", "electrodes_contact_point"):
        # Networks on signal vectors (Su et al., the no-voxel model) rather than voxel grids.
        from grasp_ctrl.estimators.feature_onnx_estimator import load_feature_onnx_policy

        return load_feature_onnx_policy(meta, json_path, hand, threads)
    kind = _get(meta, json_path, "input.kind", "one of " + ", ".join(SUPPORTED_INPUT_KINDS))
    if kind not in SUPPORTED_INPUT_KINDS:
        raise PolicyError(f"{json_path}: input.kind: one of {SUPPORTED_INPUT_KINDS} (got {kind!r})")
    tensors_in = _get(meta, json_path, "input.tensors", "electrode and contact grid tensors")
    if not isinstance(tensors_in, dict) or len(tensors_in) != 2:
        raise PolicyError(f"{json_path}: input.tensors: two tensors (electrode and contact grids) expected")
    el_name, cp_name = list(tensors_in)
    for tname, spec in tensors_in.items():
        if list(spec.get("shape", []))[1:] != list(GRID_SHAPE):
            raise PolicyError(
                f"{json_path}: input.tensors.{tname}.shape: [batch, {', '.join(map(str, GRID_SHAPE))}] "
                f"expected, got {spec.get('shape')}"
            )
    tare = _get(meta, json_path, "preprocessing.tare", "'value - baseline'")
    if tare not in SUPPORTED_TARE:
        raise PolicyError(f"{json_path}: preprocessing.tare: one of {SUPPORTED_TARE} (got {tare!r})")
    variant = _get(meta, json_path, "preprocessing.voxel_grid", "one of " + ", ".join(VARIANTS))
    if variant not in VARIANTS:
        raise PolicyError(f"{json_path}: preprocessing.voxel_grid: one of {VARIANTS} (got {variant!r})")
    cpt = _get(meta, json_path, "preprocessing.contact_point", SUPPORTED_CONTACT_POINTS[0])
    if cpt not in SUPPORTED_CONTACT_POINTS:
        raise PolicyError(f"{json_path}: preprocessing.contact_point: one of {SUPPORTED_CONTACT_POINTS} (got {cpt!r})")
    if _get(meta, json_path, "output.units", "N") != "N":
        raise PolicyError(f"{json_path}: output.units: 'N' expected (got {meta['output']['units']!r})")
    if _get(meta, json_path, "output.frame", "sensor") != "sensor":
        raise PolicyError(f"{json_path}: output.frame: 'sensor' expected (got {meta['output']['frame']!r})")
    sign = _get(meta, json_path, "output.to_f_sensor", "1 or -1")
    if sign not in (1, -1, 1.0, -1.0):
        raise PolicyError(f"{json_path}: output.to_f_sensor: 1 or -1 (got {sign!r})")
    out_tensors = _get(meta, json_path, "output.tensors", "force output tensor names")
    if not isinstance(out_tensors, dict) or not out_tensors:
        raise PolicyError(f"{json_path}: output.tensors: at least the force output expected")
    out_names = list(out_tensors)
    has_variance = _get(meta, json_path, "has_variance", "true or false")
    if has_variance not in (True, False):
        raise PolicyError(f"{json_path}: has_variance: true or false (got {has_variance!r})")
    if has_variance and len(out_names) < 2:
        raise PolicyError(f"{json_path}: output.tensors: has_variance is true but no variance output is listed")
    force_out = out_names[0]
    var_out = out_names[1] if has_variance else None
    if not isinstance(threads, int) or threads < 1:
        raise PolicyError(f"policy {name}: threads: a positive integer (got {threads!r})")

    model_file = json_path.parent / str(meta.get("model_file", json_path.with_suffix(".onnx").name))
    if not model_file.is_file():
        raise PolicyError(f"{json_path}: model_file: {model_file} does not exist")
    try:
        import onnxruntime as ort
    except ImportError as exc:  # pragma: no cover - a run-time dependency
        raise PolicyError(f"{json_path}: onnxruntime is not installed ({exc})") from None
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = threads
    opts.inter_op_num_threads = 1
    opts.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    verify_model_hash(meta, json_path, model_file)  # before onnxruntime parses the file
    try:
        session = ort.InferenceSession(str(model_file), opts, providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime raises its own exception types
        raise PolicyError(
            f"{model_file}: cannot load the ONNX model ({(str(exc).splitlines() or [type(exc).__name__])[0]})"
        ) from None
    _check_onnx_interface(session, json_path, tensors_in, [force_out] + ([var_out] if var_out else []))
    check_graph_io(session, meta, json_path)
    return OnnxEstimator(session, name, el_name, cp_name, force_out, var_out, float(sign), variant)
