"""Start fine-tuning from the authors' pretrained ICRA 2019 weights (.npz of the TF1
checkpoint, official_icra19 README, or the policy converted from it by ``convert-icra19``)
by mapping them onto the ``voxel`` model.

- Kernel-2 stride-2 convolutions: TF kernels [kd, kh, kw, c_in, c_out] flatten to
  (kd, kh, kw, c_in) rows, the patch order of ``PatchConv``; dense [in, out] -> Linear.weight.T.
- The network takes raw tared counts (input scale 1) and predicts the force the finger applies
  (-f_sensor); the last layer is negated so the model returns f_sensor like ours.
- Branch order: ``Conv`` is the electrode branch, ``Conv_1`` the contact branch (checked:
  the mapped model reproduces the converted official ONNX policy).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import torch

from grasp_ctrl.learning.models import ForceNet


def _conv(w: np.ndarray) -> torch.Tensor:
    return torch.as_tensor(w.reshape(-1, w.shape[-1]).T.copy(), dtype=torch.float32)


CONVERTER = "grasp_ctrl.policy_tools.convert_icra19"

# initializer name prefix in the converted ONNX graph -> the authors' variable scope
_ONNX_SCOPES = {
    "conv_el": "Conv",
    "ln_el": "LayerNorm",
    "conv_cp": "Conv_1",
    "ln_cp": "LayerNorm_1",
    "ln2": "LayerNorm_2",
    "conv3": "Conv_3",
    "ln3": "LayerNorm_3",
    "conv4": "Conv_4",
    "ln4": "LayerNorm_4",
    "fc": "fully_connected",
    "ln5": "LayerNorm_5",
    "fc1": "fully_connected_1",
    "ln6": "LayerNorm_6",
    "fc2": "fully_connected_2",
}


def is_converted_policy(onnx_path: str | Path) -> bool:
    """True for an ONNX file written by ``convert-icra19`` (the authors' weights, no torch state inside)."""
    import onnx

    return onnx.load(str(onnx_path), load_external_data=False).producer_name == CONVERTER


def official_arrays_from_onnx(onnx_path: str | Path) -> dict[str, np.ndarray]:
    """The authors' variables (npz names) read back from the single-head policy ``convert-icra19`` wrote.

    The converter stores kernels flattened to (patch, c_out) rows, which is all the mapping
    below needs; Conv_2 is split by input branch (electrode channels 0-63, contact 64-127) and
    layer-norm parameters are broadcast over the cells (row 0 is the original).
    """
    import onnx
    from onnx import numpy_helper

    proto = onnx.load(str(onnx_path), load_external_data=False)
    if proto.producer_name != CONVERTER:
        raise ValueError(f"{onnx_path}: not written by convert-icra19")
    inits = {i.name.rsplit("_", 1)[0]: numpy_helper.to_array(i) for i in proto.graph.initializer}
    if "dropout_masks" in inits:
        raise ValueError(f"{onnx_path}: the multi-head dropout network cannot start a 'voxel' model")
    out: dict[str, np.ndarray] = {}
    try:
        for prefix, scope in _ONNX_SCOPES.items():
            if scope.startswith("LayerNorm"):
                g, b = inits[prefix + "_g"], inits[prefix + "_b"]
                out[f"{scope}/gamma"], out[f"{scope}/beta"] = (g[0], b[0]) if g.ndim == 2 else (g, b)
            else:
                out[f"{scope}/weights"], out[f"{scope}/biases"] = inits[prefix + "_w"], inits[prefix + "_b"]
        w_el, w_cp = inits["conv2_el_w"], inits["conv2_cp_w"]
        out["Conv_2/weights"] = np.concatenate([w_el.reshape(2, 2, 2, 64, 64), w_cp.reshape(2, 2, 2, 64, 64)], axis=3)
        out["Conv_2/biases"] = inits["conv2_el_b"]
    except KeyError as exc:
        raise ValueError(f"{onnx_path}: no initializer {exc} of the authors' network") from None
    return out


def official_state_dict(source: str | Path | Mapping[str, np.ndarray]) -> dict[str, torch.Tensor]:
    """``source``: the authors' .npz, or its arrays (e.g. from ``official_arrays_from_onnx``)."""
    d = source if isinstance(source, Mapping) else np.load(source)
    t = lambda a: torch.as_tensor(np.asarray(a, dtype=np.float32).copy())  # noqa: E731
    sd: dict[str, torch.Tensor] = {"trunk.input_scale": torch.tensor(1.0)}
    convs = {
        "conv_e": ("Conv", "LayerNorm"),
        "conv_c": ("Conv_1", "LayerNorm_1"),
        "conv2": ("Conv_2", "LayerNorm_2"),
        "conv3": ("Conv_3", "LayerNorm_3"),
        "conv4": ("Conv_4", "LayerNorm_4"),
    }
    ln_names = {"conv_e": "ln_e", "conv_c": "ln_c", "conv2": "ln2", "conv3": "ln3", "conv4": "ln4"}
    for ours, (conv, ln) in convs.items():
        sd[f"trunk.{ours}.linear.weight"] = _conv(d[f"{conv}/weights"])
        sd[f"trunk.{ours}.linear.bias"] = t(d[f"{conv}/biases"])
        sd[f"trunk.{ln_names[ours]}.weight"] = t(d[f"{ln}/gamma"])
        sd[f"trunk.{ln_names[ours]}.bias"] = t(d[f"{ln}/beta"])
    for ours, (fc, ln) in {
        "fc1": ("fully_connected", "LayerNorm_5"),
        "fc2": ("fully_connected_1", "LayerNorm_6"),
    }.items():
        sd[f"{ours}.0.weight"] = t(d[f"{fc}/weights"].T)
        sd[f"{ours}.0.bias"] = t(d[f"{fc}/biases"])
        sd[f"{ours}.1.weight"] = t(d[f"{ln}/gamma"])
        sd[f"{ours}.1.bias"] = t(d[f"{ln}/beta"])
    sd["out.weight"] = -t(d["fully_connected_2/weights"].T)
    sd["out.bias"] = -t(d["fully_connected_2/biases"])
    return sd


def official_model(npz_path: str | Path) -> ForceNet:
    model = ForceNet("voxel")
    model.load_state_dict(official_state_dict(npz_path))
    return model.eval()
