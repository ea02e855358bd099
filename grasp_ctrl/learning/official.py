"""Start fine-tuning from the authors' pretrained ICRA 2019 weights (.npz of the TF1
checkpoint, official_icra19 README) by mapping them onto the ``voxel`` model.

- Kernel-2 stride-2 convolutions: TF kernels [kd, kh, kw, c_in, c_out] flatten to
  (kd, kh, kw, c_in) rows, the patch order of ``PatchConv``; dense [in, out] -> Linear.weight.T.
- The network takes raw tared counts (input scale 1) and predicts the force the finger applies
  (-f_sensor); the last layer is negated so the model returns f_sensor like ours.
- Branch order: ``Conv`` is the electrode branch, ``Conv_1`` the contact branch (checked:
  the mapped model reproduces the converted official ONNX policy).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from grasp_ctrl.learning.models import ForceNet


def _conv(w: np.ndarray) -> torch.Tensor:
    return torch.as_tensor(w.reshape(-1, w.shape[-1]).T.copy(), dtype=torch.float32)


def official_state_dict(npz_path: str | Path) -> dict[str, torch.Tensor]:
    d = np.load(npz_path)
    t = lambda a: torch.as_tensor(np.asarray(a, dtype=np.float32).copy())  # noqa: E731
    sd: dict[str, torch.Tensor] = {"trunk.input_scale": torch.tensor(1.0)}
    convs = {"conv_e": ("Conv", "LayerNorm"), "conv_c": ("Conv_1", "LayerNorm_1"), "conv2": ("Conv_2", "LayerNorm_2"),
             "conv3": ("Conv_3", "LayerNorm_3"), "conv4": ("Conv_4", "LayerNorm_4")}
    ln_names = {"conv_e": "ln_e", "conv_c": "ln_c", "conv2": "ln2", "conv3": "ln3", "conv4": "ln4"}
    for ours, (conv, ln) in convs.items():
        sd[f"trunk.{ours}.linear.weight"] = _conv(d[f"{conv}/weights"])
        sd[f"trunk.{ours}.linear.bias"] = t(d[f"{conv}/biases"])
        sd[f"trunk.{ln_names[ours]}.weight"] = t(d[f"{ln}/gamma"])
        sd[f"trunk.{ln_names[ours]}.bias"] = t(d[f"{ln}/beta"])
    for ours, (fc, ln) in {"fc1": ("fully_connected", "LayerNorm_5"), "fc2": ("fully_connected_1", "LayerNorm_6")}.items():
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
