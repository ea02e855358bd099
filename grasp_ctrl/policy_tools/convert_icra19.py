"""Convert the authors' ICRA 2019 weights (.npz) into an ONNX policy + metadata.

Reads ``icra19_weights.npz`` or ``ll4ma_lab_dropout_weights.npz`` (official_icra19
README), builds the same network as an ONNX graph (opset 17), checks the ONNX
output against the numpy forward pass of :mod:`icra19_net` on random inputs
(max abs difference must stay below ``tol``, 1e-5 N by default), and writes
``NAME.onnx`` and ``NAME.json`` (docs/design.md 5.5).

ONNX inputs ``electrode_voxels`` and ``contact_voxels``: float32 (batch, 16, 16, 8),
the grids of :class:`grasp_ctrl.tactile.voxel.VoxelGrid` (variant ``icra19``).
Outputs: ``force`` (batch, 3), the network's own output, i.e. the force the
fingertip applies to the object in the BioTac frame (= -f_sensor); the dropout
variant adds ``force_variance`` (batch, 3) and ``force_heads`` (batch, 10, 3).
The policy JSON records ``output.to_f_sensor = -1`` and the estimator applies it.

Dropout (variant only): the original code left dropout (keep 0.7) on at
inference, so each call drew new masks. For a deterministic policy we freeze one
inverted-dropout mask per head, drawn from ``numpy.random.default_rng(seed)``
and stored in the graph; mean and variance over the 10 heads then come from one
reproducible forward pass. The seed is recorded in the metadata.

Needs the ``onnx`` package (extra ``train``); the runtime needs only onnxruntime.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl.files.safe_write import write_output
from grasp_ctrl.files.storage import file_sha256
from grasp_ctrl.policy_tools import icra19_net
from grasp_ctrl.tactile.voxel import GRID_SHAPE, VoxelGrid

OPSET = 17
DEFAULT_SEED = 0
INPUT_ELECTRODES = "electrode_voxels"
INPUT_CONTACT = "contact_voxels"
OUTPUT_FORCE = "force"
OUTPUT_VARIANCE = "force_variance"
OUTPUT_HEADS = "force_heads"


class _GraphBuilder:
    """Small helper collecting ONNX nodes and float32 initializers."""

    def __init__(self) -> None:
        import onnx  # noqa: F401  (fail early with a clear ImportError)

        self.nodes: list[Any] = []
        self.inits: list[Any] = []
        self._n = 0

    def name(self, hint: str) -> str:
        self._n += 1
        return f"{hint}_{self._n}"

    def const(self, hint: str, value: np.ndarray, dtype: type = np.float32) -> str:
        from onnx import numpy_helper

        n = self.name(hint)
        self.inits.append(numpy_helper.from_array(np.ascontiguousarray(value, dtype=dtype), n))
        return n

    def op(self, op_type: str, inputs: list[str], hint: str, output: str | None = None, **attrs: Any) -> str:
        from onnx import helper

        out = output or self.name(hint)
        self.nodes.append(helper.make_node(op_type, inputs, [out], name=self.name(op_type), **attrs))
        return out

    # ---- layers (channels-last, like the authors' TF graph) ----
    def patch_conv(
        self, x: str, spatial: tuple[int, ...], c_in: int, w_tf: np.ndarray, b: np.ndarray, hint: str
    ) -> str:
        """Conv with kernel = stride = 2 as non-overlapping patches + one MatMul.

        ``x`` is (n, *spatial, c_in) in memory order; the result is (n, P, c_out)
        with P the output cells in row-major order, i.e. again channels-last.
        ORT's 3D Conv takes ~5x longer for these tiny tensors than this form.
        """
        nd = len(spatial)
        split: list[int] = []
        for s in spatial:
            split += [s // 2, 2]
        x = self.op(
            "Reshape", [x, self.const(hint + "_split", np.array([-1, *split, c_in]), np.int64)], hint + "_split"
        )
        perm = [0] + [1 + 2 * i for i in range(nd)] + [2 + 2 * i for i in range(nd)] + [1 + 2 * nd]
        x = self.op("Transpose", [x], hint + "_patches", perm=perm)
        n_cells = int(np.prod([s // 2 for s in spatial]))
        # 2D rows (n * cells, patch) so the bias folds into one Gemm.
        x = self.op(
            "Reshape", [x, self.const(hint + "_rows", np.array([-1, (2**nd) * c_in]), np.int64)], hint + "_rows"
        )
        # TF kernel [k..., c_in, c_out] flattens in the same (k..., c_in) order as the patches.
        y = self.gemm(x, w_tf.reshape(-1, w_tf.shape[-1]), b, hint)
        return self.op(
            "Reshape",
            [y, self.const(hint + "_cells", np.array([-1, n_cells, w_tf.shape[-1]]), np.int64)],
            hint + "_cells",
        )

    def gemm(self, x: str, w: np.ndarray, b: np.ndarray, hint: str) -> str:
        """(rows, in) @ w + b as one Gemm (2D input only)."""
        return self.op("Gemm", [x, self.const(hint + "_w", w), self.const(hint + "_b", b)], hint)

    def layer_norm_relu(self, x: str, gamma: np.ndarray, beta: np.ndarray, n_cells: int, hint: str) -> str:
        """TF1 contrib LayerNorm on (n, cells, C) or (n, C): statistics over all
        non-batch axes, per-channel affine (expanded to the normalised shape)."""
        shape = (n_cells, gamma.shape[0]) if n_cells else (gamma.shape[0],)
        g = np.broadcast_to(gamma, shape)
        bt = np.broadcast_to(beta, shape)
        y = self.op(
            "LayerNormalization",
            [x, self.const(hint + "_g", g), self.const(hint + "_b", bt)],
            hint,
            axis=1,
            epsilon=icra19_net.LN_EPS,
        )
        return self.op("Relu", [y], hint + "_relu")

    def dense(self, x: str, w: np.ndarray, b: np.ndarray, hint: str) -> str:
        y = self.op("MatMul", [x, self.const(hint + "_w", w)], hint)
        return self.op("Add", [y, self.const(hint + "_b", b)], hint + "_add")


def build_model(weights: icra19_net.Icra19Weights, masks: np.ndarray | None, doc: str) -> Any:
    """The ONNX model of the network (see module docstring for the interface)."""
    from onnx import TensorProto, helper

    w = weights
    g = _GraphBuilder()
    batch = "batch"
    grid_in: list[str | int] = [batch, *GRID_SHAPE]  # a symbolic batch size, then the grid
    inputs = [
        helper.make_tensor_value_info(INPUT_ELECTRODES, TensorProto.FLOAT, grid_in),
        helper.make_tensor_value_info(INPUT_CONTACT, TensorProto.FLOAT, grid_in),
    ]
    el = g.layer_norm_relu(
        g.patch_conv(INPUT_ELECTRODES, GRID_SHAPE, 1, w["Conv/weights"], w["Conv/biases"], "conv_el"),
        w["LayerNorm/gamma"],
        w["LayerNorm/beta"],
        256,
        "ln_el",
    )
    cp = g.layer_norm_relu(
        g.patch_conv(INPUT_CONTACT, GRID_SHAPE, 1, w["Conv_1/weights"], w["Conv_1/biases"], "conv_cp"),
        w["LayerNorm_1/gamma"],
        w["LayerNorm_1/beta"],
        256,
        "ln_cp",
    )
    # Conv_2 on concat(el, cp) along channels == Conv_2[.., :64, :] on el + Conv_2[.., 64:, :] on cp;
    # the split form saves copying the concatenated tensor.
    w2 = w["Conv_2/weights"]
    x = g.op(
        "Add",
        [
            g.patch_conv(el, (8, 8, 4), 64, w2[:, :, :, :64, :], w["Conv_2/biases"], "conv2_el"),
            g.patch_conv(cp, (8, 8, 4), 64, w2[:, :, :, 64:, :], np.zeros(64), "conv2_cp"),
        ],
        "conv2",
    )
    x = g.layer_norm_relu(x, w["LayerNorm_2/gamma"], w["LayerNorm_2/beta"], 32, "ln2")  # (n, 4*4*2, 64)
    x = g.layer_norm_relu(
        g.patch_conv(x, (4, 4, 2), 64, w["Conv_3/weights"], w["Conv_3/biases"], "conv3"),
        w["LayerNorm_3/gamma"],
        w["LayerNorm_3/beta"],
        4,
        "ln3",
    )  # (n, 2*2*1, 64)
    # Dropping the z axis (size 1) leaves (n, 2, 2, 64); Conv_4 (2x2, stride 2) sees it as one patch.
    x = g.op("Reshape", [x, g.const("shape_flat", np.array([-1, 256]), np.int64)], "drop_z")
    x = g.layer_norm_relu(
        g.gemm(x, w["Conv_4/weights"].reshape(256, 128), w["Conv_4/biases"], "conv4"),
        w["LayerNorm_4/gamma"],
        w["LayerNorm_4/beta"],
        0,
        "ln4",
    )  # (n, 128)
    x = g.layer_norm_relu(
        g.gemm(x, w["fully_connected/weights"], w["fully_connected/biases"], "fc"),
        w["LayerNorm_5/gamma"],
        w["LayerNorm_5/beta"],
        0,
        "ln5",
    )
    outputs = [helper.make_tensor_value_info(OUTPUT_FORCE, TensorProto.FLOAT, [batch, 3])]
    if not w.dropout:
        x = g.layer_norm_relu(
            g.gemm(x, w["fully_connected_1/weights"], w["fully_connected_1/biases"], "fc1"),
            w["LayerNorm_6/gamma"],
            w["LayerNorm_6/beta"],
            0,
            "ln6",
        )
        y = g.op("MatMul", [x, g.const("fc2_w", w["fully_connected_2/weights"])], "fc2")
        g.op("Add", [y, g.const("fc2_b", w["fully_connected_2/biases"])], "fc2_add", output=OUTPUT_FORCE)
    else:
        heads = icra19_net.N_DROPOUT_HEADS
        m = np.ones((heads, 64)) if masks is None else masks
        x = g.op("Unsqueeze", [x, g.const("ax1", np.array([1]), np.int64)], "x_heads")  # (n, 1, 64)
        x = g.op("Mul", [x, g.const("dropout_masks", m)], "dropped")  # (n, H, 64)
        x = g.dense(x, w["fcn32/weights"], w["fcn32/biases"], "fcn32")  # (n, H, 32)
        x = g.op(
            "LayerNormalization",
            [x, g.const("ones32", np.ones(32)), g.const("zeros32", np.zeros(32))],
            "ln_heads",
            axis=-1,
            epsilon=icra19_net.LN_EPS,
        )
        gam = np.stack([w[f"LayerNorm_{6 + k}/gamma"] for k in range(heads)])
        bet = np.stack([w[f"LayerNorm_{6 + k}/beta"] for k in range(heads)])
        x = g.op("Add", [g.op("Mul", [x, g.const("head_gamma", gam)], "hg"), g.const("head_beta", bet)], "hb")
        x = g.op("Relu", [x], "head_relu")
        y = g.op("MatMul", [x, g.const("fcn3_w", w["fcn3/weights"])], "fcn3")
        g.op("Add", [y, g.const("fcn3_b", w["fcn3/biases"])], "fcn3_add", output=OUTPUT_HEADS)
        ax = g.const("ax_heads", np.array([1]), np.int64)
        g.op("ReduceMean", [OUTPUT_HEADS], "mean", output=OUTPUT_FORCE, axes=[1], keepdims=0)
        mean_k = g.op("Unsqueeze", [OUTPUT_FORCE, ax], "mean_k")
        dev = g.op("Sub", [OUTPUT_HEADS, mean_k], "dev")
        g.op("ReduceMean", [g.op("Mul", [dev, dev], "dev2")], "var", output=OUTPUT_VARIANCE, axes=[1], keepdims=0)
        outputs += [
            helper.make_tensor_value_info(OUTPUT_VARIANCE, TensorProto.FLOAT, [batch, 3]),
            helper.make_tensor_value_info(OUTPUT_HEADS, TensorProto.FLOAT, [batch, heads, 3]),
        ]
    graph = helper.make_graph(g.nodes, "icra19_force_net", inputs, outputs, g.inits)
    model = helper.make_model(
        graph,
        opset_imports=[helper.make_opsetid("", OPSET)],
        producer_name="grasp_ctrl.policy_tools.convert_icra19",
        doc_string=doc,
    )
    model.ir_version = 8  # readable by onnxruntime >= 1.14
    import onnx

    onnx.checker.check_model(model)
    return model


def random_inputs(n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Plausible random grids: tared electrodes in counts, contact from the same rows."""
    from grasp_ctrl.tactile.features import contact_points

    rng = np.random.default_rng(seed)
    e = rng.normal(0.0, 150.0, size=(n, 19)) - rng.uniform(0, 200, size=(n, 1)) * (rng.random((n, 19)) < 0.4)
    vg = VoxelGrid("icra19")
    return vg.electrode_grids(e), vg.contact_grids(contact_points(e))


def scaled_error(got: np.ndarray, ref: np.ndarray) -> float:
    """max |got - ref| / max(1, max |ref|): error relative to the output range.

    A float32 graph cannot match a float64 reference better than about 1e-5 of
    the output range: on random inputs whose forces reach 8..12 N the ONNX
    error is 2..4e-5 N, and numpy itself in float32 is 1e-5 N off. So the
    parity error is scaled by the batch's largest output, floored at 1 (below
    1e-5 means within 1e-5 N whenever outputs stay under 1 N).
    """
    ref = np.asarray(ref, dtype=float)
    diff = float(np.max(np.abs(np.asarray(got, dtype=float) - ref)))
    return diff / max(1.0, float(np.max(np.abs(ref))))


def max_parity_error(
    model_bytes: bytes, weights: icra19_net.Icra19Weights, masks: np.ndarray | None, n: int = 256, seed: int = 1
) -> float:
    """:func:`scaled_error` of ONNX vs the float64 numpy pass on ``n`` random inputs."""
    import onnxruntime as ort

    el, cp = random_inputs(n, seed)
    sess = ort.InferenceSession(model_bytes, providers=["CPUExecutionProvider"])
    outs = sess.run(None, {INPUT_ELECTRODES: el, INPUT_CONTACT: cp})
    ref_f, ref_v = icra19_net.forward(weights, el, cp, masks)
    err = scaled_error(outs[0], ref_f)
    if ref_v is not None:
        err = max(err, scaled_error(outs[1], ref_v))
    return err


_sha256 = file_sha256


def metadata(
    name: str, weights: icra19_net.Icra19Weights, npz_path: Path, onnx_path: Path, seed: int | None, parity: float
) -> dict[str, Any]:
    dropout = weights.dropout
    outputs: dict[str, Any] = {
        OUTPUT_FORCE: {
            "shape": ["batch", 3],
            "dtype": "float32",
            "units": "N",
            "meaning": "the force the fingertip applies to the object (authors' label convention)",
        },
    }
    if dropout:
        outputs[OUTPUT_FORCE]["meaning"] = (
            "mean over the 10 dropout heads of the force the fingertip "
            "applies to the object (authors' label convention)"
        )
        outputs[OUTPUT_VARIANCE] = {
            "shape": ["batch", 3],
            "dtype": "float32",
            "units": "N^2",
            "meaning": "per-axis population variance over the 10 heads (confidence)",
        }
        outputs[OUTPUT_HEADS] = {"shape": ["batch", 10, 3], "dtype": "float32", "meaning": "each head's force"}
    return {
        "name": name,
        "kind": "onnx",
        "model_file": onnx_path.name,
        "model_sha256": _sha256(onnx_path),
        "sensor_type": "biotac",
        "description": (
            "ICRA 2019 voxel force network, multi-head dropout variant (ll4ma_lab)"
            if dropout
            else "ICRA 2019 voxel force network (the paper's network)"
        ),
        "input": {
            "kind": "voxel_grids",
            "tensors": {
                INPUT_ELECTRODES: {
                    "shape": ["batch", *GRID_SHAPE],
                    "dtype": "float32",
                    "meaning": "tared electrode value (counts) in each electrode's cell",
                },
                INPUT_CONTACT: {
                    "shape": ["batch", *GRID_SHAPE],
                    "dtype": "float32",
                    "meaning": "1.0 in the contact point's cell",
                },
            },
        },
        "preprocessing": {
            "tare": "value - baseline",
            "tare_note": "baseline = mean of a no-contact window; pressed electrodes are negative. Checked on "
            "real BioTac recordings (docs/tactile.md, tests/tactile/test_tactile_real_data.py): with this "
            "sign the predicted direction agrees with the labelled plate normals after one fixed "
            "rotation, with the opposite sign it agrees clearly worse.",
            "electrode_scaling": "none (raw counts)",
            "voxel_grid": "icra19",
            "voxel_grid_note": "edges = numpy.histogramdd(electrode positions in m, bins=(15,15,7)); "
            "index = digitize - 1; index -1 wraps to the last cell",
            "contact_point": "squared_signal_centroid_projected",
            "contact_point_note": "centroid of electrode positions weighted by squared tared values, projected "
            "to radius 5.5 mm: sphere about the origin if x > 0, else cylinder about x",
            "contact_gate": {
                "signal": "tared pdc",
                "threshold_counts": 10,
                "frames": 10,
                "outside_contact": "zero force, the network is not run",
            },
        },
        "output": {
            "tensors": outputs,
            "units": "N",
            "frame": "sensor",
            "network_quantity": "force applied by the fingertip on the environment (= -f_sensor)",
            "to_f_sensor": -1.0,
            "estimator_returns": "f_sensor",
        },
        "has_variance": dropout,
        "dropout": (
            {
                "heads": 10,
                "keep_prob": icra19_net.KEEP_PROB,
                "inference": "fixed_masks",
                "note": "one inverted-dropout mask per head, frozen at conversion "
                "(numpy.random.default_rng(seed)); deterministic mean and variance over heads. "
                "The original code re-drew masks at every call.",
                "mask_seed": seed,
            }
            if dropout
            else None
        ),
        "training": {
            "data": "the authors' real BioTac dataset (rigid-ft, ball-ft, planar-pushing; about 140k samples), "
            "ICRA 2019",
            "metrics": "see the paper (Sundaralingam et al., ICRA 2019), Sec. V; not re-measured here",
            "checked_here": "direction on robotic_finger data: see docs/tactile.md (evaluate-direction)",
        },
        "provenance": {
            "source": "https://github.com/balakumar-s/biotac_force_net",
            "checkpoint": "tf_models/ll4ma_lab_dropout" if dropout else "tf_models/icra19",
            "converted_from": npz_path.name,
            "converted_from_sha256": _sha256(npz_path),
            "converter": "grasp_ctrl.policy_tools.convert_icra19 (python launch.py convert-icra19)",
            "onnx_opset": OPSET,
            "onnx_vs_numpy_max_error": parity,
            "onnx_vs_numpy_error_definition": "max |onnx - numpy64| / max(1, max |numpy64|) over 256 random inputs (float32 vs float64)",
        },
        "licence": "BSD (authors' package.xml)",
        "citation": (
            "B. Sundaralingam, A. Lambert, A. Handa, B. Boots, T. Hermans, S. Birchfield, N. Ratliff, "
            "D. Fox. Robust Learning of Tactile Force Estimation through Robot Interaction. "
            "IEEE ICRA 2019."
        ),
    }


def convert(
    npz_path: str | Path, out_dir: str | Path, name: str, seed: int = DEFAULT_SEED, tol: float = 1e-5
) -> tuple[Path, Path, float]:
    """Write OUT_DIR/NAME.onnx and NAME.json; returns their paths and the parity error."""
    npz_path = Path(npz_path)
    out_dir = Path(out_dir)
    weights = icra19_net.load_weights(npz_path)
    masks = icra19_net.dropout_masks(seed) if weights.dropout else None
    doc = (
        f"ICRA 2019 force network converted from {npz_path.name} "
        "(github.com/balakumar-s/biotac_force_net, BSD). Output: force applied by the fingertip, "
        "BioTac frame, N (= -f_sensor)."
    )
    model = build_model(weights, masks, doc)
    data = model.SerializeToString()
    parity = max_parity_error(data, weights, masks)
    if not parity <= tol:
        raise ValueError(f"ONNX output differs from the numpy forward pass by {parity:.3g} (> {tol:g})")
    out_dir.mkdir(parents=True, exist_ok=True)
    onnx_path = out_dir / f"{name}.onnx"
    json_path = out_dir / f"{name}.json"
    write_output(onnx_path, data)  # a symlink there is replaced, never written through
    meta = metadata(name, weights, npz_path, onnx_path, seed if weights.dropout else None, parity)
    write_output(json_path, json.dumps(meta, indent=2) + "\n")
    return onnx_path, json_path, parity
