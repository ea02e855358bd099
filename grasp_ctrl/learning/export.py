"""Export a trained network to ``policies/NAME.onnx`` + ``NAME.json`` (docs/design.md 5.5).

The ONNX graph takes the model's named inputs (see ``models.input_shapes``) and returns
``f_sensor`` (n, 3) [N, sensor frame, force on the skin] and, for the dropout model,
``variance`` (n, 3) [N^2]. The export is checked against torch (max abs difference
<= 1e-5 relative to max(1 N, max |output|), on realistic inputs) before anything is written. The torch weights ride along
inside the ONNX file (metadata_props) so a policy can be fine-tuned later.
"""

from __future__ import annotations

import base64
import hashlib
import io
import json
import tempfile
import warnings
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import torch

from grasp_ctrl.files.safe_write import output_file, write_output
from grasp_ctrl.learning.features import model_inputs
from grasp_ctrl.learning.models import ARCHS, build_model, input_shapes

STATE_DICT_KEY = "grasp_ctrl.torch_state_dict"
ARCH_KEY = "grasp_ctrl.arch"
PARITY_TOL_N = 1e-5

INPUT_KIND = {
    "voxel": "voxel_grids",
    "voxel-dropout": "voxel_grids",
    "novoxel": "electrodes_contact_point",
    "su": "electrodes_pdc",
}
PREPROCESSING = {
    "tare": "value - baseline; baseline = mean of a no-contact window (counts, unscaled)",
    "contact_gate": {"pdc_threshold_counts": 10, "frames": 10},
    "contact_point_rule": (
        "centroid of the electrode positions weighted by the squared tared electrode values, "
        "projected onto the sensor surface of radius 5.5 mm (sphere for x > 0, cylinder about x "
        "otherwise); sensor frame, metres"
    ),
    "voxel_grid": (
        "icra19: (16, 16, 8) cells, edges = numpy.histogramdd(electrode positions, bins=(15, 15, 7)), "
        "index = digitize - 1 with -1 wrapping to the last cell; electrode grid = tared electrode counts, "
        "contact grid = 1 at the contact point"
    ),
}


class ExportError(ValueError):
    pass


def example_inputs(arch: str, n: int = 64, seed: int = 0) -> dict[str, np.ndarray]:
    """Realistic inputs: random pressed frames through the same feature code."""
    rng = np.random.default_rng(seed)
    tared = np.zeros((n, 44))
    centre = rng.integers(0, 19, n)
    tared[np.arange(n), centre] = -rng.uniform(50, 1500, n)
    tared[:, :19] += -np.abs(rng.normal(0, 100, (n, 19)))
    tared[:, 19] = rng.uniform(10, 600, n)
    feats = model_inputs(tared)
    return {name: feats[name] for name in ARCHS[arch]["inputs"]}


def state_dict_bytes(model: torch.nn.Module) -> bytes:
    buf = io.BytesIO()
    torch.save(model.state_dict(), buf)
    return buf.getvalue()


def export_onnx(model: torch.nn.Module, arch: str, onnx_path: Path) -> float:
    """Write the ONNX file; return the worst torch/onnxruntime difference, max |onnx - torch| /
    max(1, max |torch|) per output (i.e. N for outputs up to 1 N)."""
    import onnx
    import onnxruntime as ort

    model = model.eval()
    names = list(ARCHS[arch]["inputs"])
    outputs = ["f_sensor", "variance"] if arch == "voxel-dropout" else ["f_sensor"]
    ex = example_inputs(arch)
    args = tuple(torch.as_tensor(ex[n]) for n in names)
    dyn = {n: {0: "n"} for n in names + outputs}
    with tempfile.TemporaryDirectory() as tmp:
        raw_path = Path(tmp) / "model.onnx"
        # the TorchScript exporter: the newer one needs onnxscript, which the train extra does not pull in
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            torch.onnx.export(
                model,
                args,
                str(raw_path),
                input_names=names,
                output_names=outputs,
                dynamic_axes=dyn,
                opset_version=17,
                dynamo=False,
            )
        proto = onnx.load(str(raw_path))
    for key, value in ((STATE_DICT_KEY, base64.b64encode(state_dict_bytes(model)).decode("ascii")), (ARCH_KEY, arch)):
        entry = proto.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.checker.check_model(proto)
    onnx_path.parent.mkdir(parents=True, exist_ok=True)
    with output_file(onnx_path) as tmp:  # a symlink at onnx_path is replaced, not followed
        onnx.save(proto, str(tmp))
    # parity on other inputs than the tracing ones, including a batch of one
    sess = ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
    worst = 0.0
    for n, seed in ((200, 1), (1, 2)):
        ex = example_inputs(arch, n, seed)
        got = sess.run(None, {k: ex[k] for k in names})
        with torch.no_grad():
            ref = model(*(torch.as_tensor(ex[k]) for k in names))
        ref_list = list(ref) if isinstance(ref, tuple) else [ref]
        for g, r in zip(got, ref_list):
            # float32 rounding grows with the output: compare relative to max(1 N, |output|)
            scale = max(1.0, float(np.max(np.abs(r.numpy()))))
            worst = max(worst, float(np.max(np.abs(g - r.numpy()))) / scale)
    if worst > PARITY_TOL_N:
        onnx_path.unlink()
        raise ExportError(f"ONNX output differs from torch by {worst:.3g} (> {PARITY_TOL_N})")
    return worst


def load_onnx_weights(onnx_path: str | Path) -> tuple[str, dict[str, Any]]:
    """(arch, state_dict) stored by ``export_onnx``: the start point for fine-tuning."""
    import onnx

    proto = onnx.load(str(onnx_path), load_external_data=False)
    props = {p.key: p.value for p in proto.metadata_props}
    if STATE_DICT_KEY not in props or ARCH_KEY not in props:
        raise ExportError(
            f"{onnx_path}: has no grasp_ctrl training weights (only policies exported by `export` can be fine-tuned)"
        )
    state = torch.load(io.BytesIO(base64.b64decode(props[STATE_DICT_KEY])), map_location="cpu", weights_only=True)
    return props[ARCH_KEY], state


_MEANING = {
    "electrode_voxels": "tared electrode value (counts) in each electrode's cell",
    "contact_voxels": "1.0 in the contact point's cell",
    "electrodes": "tared electrode values e1..e19 (counts)",
    "pdc": "tared pdc (counts)",
    "contact_point": "contact point on the sensor surface, sensor frame (m)",
}


def policy_metadata(
    name: str, arch: str, ckpt: dict[str, Any], parity: float, sha256: str, description: str | None = None
) -> dict[str, Any]:
    """Metadata in the layout read by grasp_ctrl.estimators.onnx_estimator (docs/design.md 5.5);
    ``description`` replaces the generic one (say what the policy is: base, data, seed...)."""
    has_var = arch == "voxel-dropout"
    out_tensors = {
        "f_sensor": {
            "shape": ["batch", 3],
            "dtype": "float32",
            "units": "N",
            "meaning": "force ON the sensor skin (docs/design.md 4); a pad press gives +z",
        }
    }
    if has_var:
        out_tensors["variance"] = {
            "shape": ["batch", 3],
            "dtype": "float32",
            "units": "N^2",
            "meaning": "per-axis variance over the 10 heads",
        }
    preprocessing: dict[str, Any] = {
        "tare": "value - baseline",
        "tare_note": PREPROCESSING["tare"],
        "electrode_scaling": "none (raw tared counts; the network scales internally)",
        "contact_gate": {
            "signal": "tared pdc",
            "threshold_counts": 10,
            "frames": 10,
            "outside_contact": "zero force, the network is not run",
        },
    }
    if arch in ("voxel", "voxel-dropout", "novoxel"):
        preprocessing["contact_point"] = "squared_signal_centroid_projected"
        preprocessing["contact_point_note"] = PREPROCESSING["contact_point_rule"]
    if arch in ("voxel", "voxel-dropout"):
        preprocessing["voxel_grid"] = "icra19"
        preprocessing["voxel_grid_note"] = PREPROCESSING["voxel_grid"]
    cfg = ckpt.get("config") or {}
    return {
        "name": name,
        "kind": "onnx",
        "model_file": f"{name}.onnx",
        "model_sha256": sha256,
        "sensor_type": "biotac",
        "description": description
        or (
            DESCRIPTIONS[arch]
            + (" with the alpha loss weight" if cfg.get("beta") is not None else "")
            + (f", fine-tuned from {ckpt['init_from']}" if ckpt.get("init_from") else "")
        ),
        "arch": arch,
        "input": {
            "kind": INPUT_KIND[arch],
            "tensors": {
                k: {"shape": ["batch", *v[1:]], "dtype": "float32", "meaning": _MEANING[k]}
                for k, v in input_shapes(arch).items()
            },
        },
        "preprocessing": preprocessing,
        "output": {
            "tensors": out_tensors,
            "units": "N",
            "frame": "sensor",
            "to_f_sensor": 1.0,
            "estimator_returns": "f_sensor",
        },
        "has_variance": has_var,
        "dropout": {"heads": 10, "keep_prob": 0.7, "at_inference": "off (heads differ by their layer norms)"}
        if has_var
        else None,
        "training": {
            "config": cfg,
            "data": ckpt.get("data"),
            "best_epoch": ckpt.get("best_epoch"),
            "best_val_loss": ckpt.get("best_val_loss"),
            "seconds_per_epoch": ckpt.get("seconds_per_epoch"),
            "init_from": ckpt.get("init_from"),
        },
        "metrics": ckpt.get("metrics"),
        "metrics_note": "test split (whole trials) of the training data; median, q1, q3 per source and mixed (paper eqs. 14-15)",
        "provenance": {
            "trained_with": "grasp_ctrl train (docs/learning.md)",
            "exported": datetime.now(UTC).isoformat(timespec="seconds"),
            "onnx_opset": 17,
            "onnx_vs_torch_max_error": parity,
            "onnx_vs_torch_error_definition": "max |onnx - torch| / max(1, max |torch|) on 200 + 1 realistic inputs",
        },
        "licence": "BSD-3-Clause (grasp_ctrl)",
        "citation": "Architecture and losses after B. Sundaralingam et al., Robust Learning of Tactile Force "
        "Estimation through Robot Interaction, IEEE ICRA 2019",
    }


DESCRIPTIONS = {
    "voxel": "voxel force network (paper Fig. 2), trained by grasp_ctrl",
    "voxel-dropout": "multi-head dropout voxel force network, trained by grasp_ctrl",
    "novoxel": "force network without voxels (FC on e and s_c), trained by grasp_ctrl",
    "su": "feed-forward baseline after Su et al. 2015 (electrodes + pdc), trained by grasp_ctrl",
}


def export_checkpoint(
    ckpt: dict[str, Any], name: str, out_dir: Path, description: str | None = None
) -> tuple[Path, Path, float]:
    model = build_model(ckpt["arch"])
    model.load_state_dict(ckpt["state_dict"])
    onnx_path = out_dir / f"{name}.onnx"
    parity = export_onnx(model, ckpt["arch"], onnx_path)
    json_path = out_dir / f"{name}.json"
    sha = hashlib.sha256(onnx_path.read_bytes()).hexdigest()
    write_output(
        json_path, json.dumps(policy_metadata(name, ckpt["arch"], ckpt, parity, sha, description), indent=2) + "\n"
    )
    return onnx_path, json_path, parity


def analytic_policy(
    name: str, gains: np.ndarray, data: dict[str, Any] | None, metrics: dict[str, Any] | None
) -> dict[str, Any]:
    """Metadata of the analytic model (kind "analytic", loaded by the registry)."""
    return {
        "name": name,
        "kind": "analytic",
        "sensor_type": "biotac",
        "gains_n_per_count": [float(g) for g in gains],
        "output_quantity": "f_sensor: force ON the sensor skin (docs/design.md 4)",
        "output_units": "N",
        "output_frame": "sensor",
        "has_variance": False,
        "preprocessing": {
            "tare": "value - baseline",
            "tare_note": PREPROCESSING["tare"],
            "contact_gate": PREPROCESSING["contact_gate"],
        },
        "training": {"method": "per-axis least squares (Lin et al. 2013, paper eq. 15)", "data": data},
        "metrics": metrics,
        "provenance": "fitted with grasp_ctrl (`train --arch analytic`)",
        "licence": "BSD-3-Clause (grasp_ctrl)",
    }
