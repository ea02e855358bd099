"""The force networks (torch). Every model maps named inputs (see
``features.model_inputs``) to the force on the sensor skin, f_sensor [N], sensor frame.

- ``voxel``: the paper's network (Fig. 2), layer shapes as the authors' weights
  (official_icra19 README): electrode and contact voxel grids -> 3D conv 1->64 each
  (kernel 2, stride 2) -> concat -> 3D conv 128->64 -> 3D conv 64->64 -> drop depth ->
  2D conv 64->128 -> FC 128->64 -> FC 64->32 -> FC 32->3; layer norm + ReLU after every
  layer but the last.
- ``novoxel``: the same head fed by four fully connected layers on e and s_c instead of the
  voxel convolutions (the paper's ablation).
- ``su``: the feed-forward baseline after Su et al. (2015): three hidden layers on the
  electrodes and pdc (our reading of their NN-3; their exact sizes are not in the paper).
- ``voxel-dropout``: the multi-head dropout variant (10 heads after the first FC layer, shared
  FC weights, one layer norm per head); outputs the head mean and per-axis variance.
"""

from __future__ import annotations

from typing import Any

import torch
from torch import nn

GRID = (16, 16, 8)
E_SCALE = 1.0 / 1000.0  # counts -> O(1), for the fully connected input layers
SC_SCALE = 1.0 / 5.5e-3  # metres on the sensor surface -> O(1)
VOXEL_INPUT_SCALE = 0.01  # counts -> first voxel convolution (see VoxelTrunk)


class SampleLayerNorm(nn.Module):
    """Layer norm as in TF1 contrib: statistics over all non-batch axes of a sample,
    learned gain and bias per channel (the LAST axis: tensors are channels-last)."""

    def __init__(self, channels: int, eps: float = 1e-6) -> None:
        super().__init__()
        self.weight = nn.Parameter(torch.ones(channels))
        self.bias = nn.Parameter(torch.zeros(channels))
        self.eps = eps

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        dims = tuple(range(1, x.dim()))
        mean = x.mean(dim=dims, keepdim=True)
        var = ((x - mean) ** 2).mean(dim=dims, keepdim=True)
        return (x - mean) / torch.sqrt(var + self.eps) * self.weight + self.bias


def _fc(n_in: int, n_out: int) -> nn.Sequential:
    return nn.Sequential(nn.Linear(n_in, n_out), SampleLayerNorm(n_out), nn.ReLU())


class PatchConv(nn.Module):
    """A convolution with kernel 2 and stride 2 on a channels-last grid. The patches do
    not overlap, so it is exactly a linear map of each flattened 2x..x2 patch (weight
    layout = a TF kernel [k.., c_in, c_out] reshaped to (2^d c_in, c_out)); far faster
    on a CPU than the generic 3D convolution."""

    def __init__(self, c_in: int, c_out: int, spatial_dims: int) -> None:
        super().__init__()
        self.d = spatial_dims
        self.linear = nn.Linear(c_in * 2**spatial_dims, c_out)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        n, c = x.shape[0], x.shape[-1]
        half = [s // 2 for s in x.shape[1:-1]]
        if self.d == 3:
            x = x.reshape(n, half[0], 2, half[1], 2, half[2], 2, c).permute(0, 1, 3, 5, 2, 4, 6, 7)
        else:
            x = x.reshape(n, half[0], 2, half[1], 2, c).permute(0, 1, 3, 2, 4, 5)
        return self.linear(x.reshape(n, *half, -1))


class VoxelTrunk(nn.Module):
    """Voxel grids (n, 16, 16, 8) x 2 -> the 128-vector that enters the first FC layer.

    ``input_scale`` multiplies the tared counts before the first convolution. The authors'
    network uses raw counts (scale 1); the layer norm after the first convolution then makes
    the branch almost scale invariant (the bias is negligible next to counts in the
    hundreds), which hides the force magnitude, so our trained models use 1/100 (a buffer, saved with the weights)."""

    input_scale: torch.Tensor  # registered as a buffer in __init__

    def __init__(self, input_scale: float = 1.0) -> None:
        super().__init__()
        self.register_buffer("input_scale", torch.tensor(float(input_scale)))
        self.conv_e = PatchConv(1, 64, 3)
        self.ln_e = SampleLayerNorm(64)
        self.conv_c = PatchConv(1, 64, 3)
        self.ln_c = SampleLayerNorm(64)
        self.conv2 = PatchConv(128, 64, 3)
        self.ln2 = SampleLayerNorm(64)
        self.conv3 = PatchConv(64, 64, 3)
        self.ln3 = SampleLayerNorm(64)
        self.conv4 = PatchConv(64, 128, 2)
        self.ln4 = SampleLayerNorm(128)

    def forward(self, electrode_voxels: torch.Tensor, contact_voxels: torch.Tensor) -> torch.Tensor:
        e = torch.relu(self.ln_e(self.conv_e(electrode_voxels.unsqueeze(-1) * self.input_scale)))  # (n, 8, 8, 4, 64)
        c = torch.relu(self.ln_c(self.conv_c(contact_voxels.unsqueeze(-1))))
        x = torch.relu(self.ln2(self.conv2(torch.cat([e, c], dim=-1))))  # (n, 4, 4, 2, 64)
        x = torch.relu(self.ln3(self.conv3(x)))  # (n, 2, 2, 1, 64)
        x = torch.relu(self.ln4(self.conv4(x.squeeze(3))))  # (n, 1, 1, 128)
        return x.flatten(1)


class SparseVoxelTrunk:
    """The same function as ``VoxelTrunk`` evaluated from the compact inputs (19 electrode
    values, the contact cell) without building the grids: all but a few first-layer patches
    see zeros, so their conv output is the bias and after layer norm one shared background
    vector. Layer-norm statistics and the second convolution are assembled from the
    background plus sparse corrections. Exact (tested against the dense path); several
    times faster for training on a CPU."""

    def __init__(self) -> None:
        from grasp_ctrl.learning.features import _ELECTRODE_CELLS

        cells = torch.as_tensor(_ELECTRODE_CELLS, dtype=torch.long)
        patch = cells // 2
        sub = cells % 2
        keys = (patch[:, 0] * 8 + patch[:, 1]) * 4 + patch[:, 2]
        uniq, inverse = torch.unique(keys, return_inverse=True)
        self.k = len(uniq)
        self.e_patch = inverse  # electrode -> special patch
        self.e_sub = sub[:, 0] * 4 + sub[:, 1] * 2 + sub[:, 2]  # position inside the patch
        px, py, pz = uniq // 32, (uniq // 4) % 8, uniq % 4
        self.p_block = ((px // 2) * 4 + py // 2) * 2 + pz // 2  # special patch -> conv2 output cell
        self.p_sub = (px % 2) * 4 + (py % 2) * 2 + pz % 2  # its position inside the conv2 patch

    @staticmethod
    def _ln_background(
        y_special: torch.Tensor, bias: torch.Tensor, n_background: int, ln: SampleLayerNorm
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Layer-norm statistics over special patches + n_background copies of ``bias``."""
        c = bias.shape[0]
        total = y_special.shape[1] + n_background
        s1 = y_special.sum(dim=(1, 2)) + n_background * bias.sum()
        mean = s1 / (total * c)
        d_sp = y_special - mean[:, None, None]
        d_bg = bias[None, :] - mean[:, None]
        var = ((d_sp**2).sum(dim=(1, 2)) + n_background * (d_bg**2).sum(dim=1)) / (total * c)
        inv = 1.0 / torch.sqrt(var + ln.eps)
        z_sp = torch.relu(d_sp * inv[:, None, None] * ln.weight + ln.bias)
        z_bg = torch.relu(d_bg * inv[:, None] * ln.weight + ln.bias)
        return z_sp, z_bg, inv

    def __call__(self, t: VoxelTrunk, electrodes: torch.Tensor, contact_cell: torch.Tensor) -> torch.Tensor:
        n = electrodes.shape[0]
        n_patches = 8 * 8 * 4
        w1e, b1e = t.conv_e.linear.weight, t.conv_e.linear.bias  # (64, 8), (64,)
        w1c, b1c = t.conv_c.linear.weight, t.conv_c.linear.bias
        # electrode branch: the k patches holding electrodes
        x = electrodes.new_zeros(n, self.k, 8)
        x[:, self.e_patch, self.e_sub] = electrodes * t.input_scale
        y_e = x @ w1e.T + b1e  # (n, k, 64)
        z_e, bg_e, _ = self._ln_background(y_e, b1e, n_patches - self.k, t.ln_e)
        # contact branch: one patch with a single 1 at its sub-position
        cpatch = contact_cell // 2
        csub = contact_cell % 2
        csub = csub[:, 0] * 4 + csub[:, 1] * 2 + csub[:, 2]
        y_c = (w1c.T[csub] + b1c)[:, None, :]  # (n, 1, 64)
        z_c, bg_c, _ = self._ln_background(y_c, b1c, n_patches - 1, t.ln_c)
        # conv2 = background everywhere + corrections at the special patches
        w2 = t.conv2.linear.weight.view(64, 8, 128)  # (c_out, sub, c_in)
        base = t.conv2.linear.bias + torch.cat([bg_e, bg_c], dim=1) @ w2.sum(dim=1).T  # (n, 64)
        out = base[:, None, :].repeat(1, 32, 1)  # (n, 4*4*2, 64)
        w2e = w2[:, self.p_sub, :64].permute(1, 2, 0)  # (k, 64 in, 64 out)
        corr_e = torch.einsum("nki,kio->nko", z_e - bg_e[:, None, :], w2e)
        out = out.index_add(1, self.p_block, corr_e)
        cblock = ((cpatch[:, 0] // 2) * 4 + cpatch[:, 1] // 2) * 2 + cpatch[:, 2] // 2
        cs2 = (cpatch[:, 0] % 2) * 4 + (cpatch[:, 1] % 2) * 2 + cpatch[:, 2] % 2
        w2c = w2[:, :, 64:].permute(1, 2, 0)[cs2]  # (n, 64 in, 64 out)
        corr_c = torch.bmm((z_c[:, 0] - bg_c)[:, None, :], w2c)[:, 0]
        onehot = torch.nn.functional.one_hot(cblock, 32).to(out.dtype)  # (n, 32)
        out = out + onehot[:, :, None] * corr_c[:, None, :]
        x = torch.relu(t.ln2(out.view(n, 4, 4, 2, 64)))
        x = torch.relu(t.ln3(t.conv3(x)))
        x = torch.relu(t.ln4(t.conv4(x.squeeze(3))))
        return x.flatten(1)


_SPARSE: SparseVoxelTrunk | None = None


def sparse_trunk() -> SparseVoxelTrunk:
    global _SPARSE
    if _SPARSE is None:
        _SPARSE = SparseVoxelTrunk()
    return _SPARSE


class FeatureTrunk(nn.Module):
    """e (19) and s_c (3) -> four fully connected layers -> 128-vector."""

    def __init__(self) -> None:
        super().__init__()
        self.layers = nn.Sequential(_fc(22, 64), _fc(64, 64), _fc(64, 128), _fc(128, 128))

    def forward(self, electrodes: torch.Tensor, contact_point: torch.Tensor) -> torch.Tensor:
        return self.layers(torch.cat([electrodes * E_SCALE, contact_point * SC_SCALE], dim=1))


class ForceNet(nn.Module):
    """A trunk followed by the paper's head FC 128->64->32->3."""

    def __init__(self, arch: str) -> None:
        super().__init__()
        self.arch = arch
        self.trunk = VoxelTrunk(VOXEL_INPUT_SCALE) if arch == "voxel" else FeatureTrunk()
        self.input_names: tuple[str, ...] = ARCHS[arch]["inputs"]
        self.fc1 = _fc(128, 64)
        self.fc2 = _fc(64, 32)
        self.out = nn.Linear(32, 3)

    def forward(self, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
        return self.out(self.fc2(self.fc1(self.trunk(a, b))))

    def forward_compact(self, electrodes: torch.Tensor, contact_cell: torch.Tensor) -> torch.Tensor:
        """Voxel model from (electrodes, contact cell) without grids (training speed)."""
        assert isinstance(self.trunk, VoxelTrunk)  # compact inputs are for the voxel model only
        return self.out(self.fc2(self.fc1(sparse_trunk()(self.trunk, electrodes, contact_cell))))


class MultiHeadDropoutNet(nn.Module):
    """Voxel trunk + FC 128->64, then ``heads`` dropout heads sharing FC 64->32->3,
    each with its own layer norm. Training uses every head; inference returns the mean
    and the per-axis variance over the heads (dropout inactive in eval mode, so the
    heads differ through their own layer norms)."""

    def __init__(self, heads: int = 10, keep_prob: float = 0.7) -> None:
        super().__init__()
        self.arch = "voxel-dropout"
        self.input_names: tuple[str, ...] = ARCHS["voxel-dropout"]["inputs"]
        self.trunk = VoxelTrunk(VOXEL_INPUT_SCALE)
        self.fc1 = _fc(128, 64)
        self.drop = nn.Dropout(1.0 - keep_prob)
        self.fc32 = nn.Linear(64, 32)
        self.head_ln = nn.ModuleList([SampleLayerNorm(32) for _ in range(heads)])
        self.fc3 = nn.Linear(32, 3)

    def heads_forward(self, a: torch.Tensor, b: torch.Tensor, compact: bool = False) -> torch.Tensor:
        x = self.fc1(sparse_trunk()(self.trunk, a, b) if compact else self.trunk(a, b))
        outs = [self.fc3(torch.relu(ln(self.fc32(self.drop(x))))) for ln in self.head_ln]
        return torch.stack(outs, dim=1)  # (n, heads, 3)

    def forward(self, a: torch.Tensor, b: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        h = self.heads_forward(a, b)
        mean = h.mean(dim=1)
        # written out: the legacy ONNX exporter mistranslates Tensor.var here
        return mean, ((h - mean.unsqueeze(1)) ** 2).mean(dim=1)


class SuNet(nn.Module):
    def __init__(self, hidden: tuple[int, ...] = (64, 64, 64)) -> None:
        super().__init__()
        self.arch = "su"
        self.input_names: tuple[str, ...] = ARCHS["su"]["inputs"]
        layers: list[nn.Module] = []
        n_in = 20
        for h in hidden:
            layers += [nn.Linear(n_in, h), nn.Tanh()]
            n_in = h
        layers.append(nn.Linear(n_in, 3))
        self.net = nn.Sequential(*layers)

    def forward(self, electrodes: torch.Tensor, pdc: torch.Tensor) -> torch.Tensor:
        return self.net(torch.cat([electrodes, pdc], dim=1) * E_SCALE)


ARCHS: dict[str, dict[str, Any]] = {
    "voxel": {"inputs": ("electrode_voxels", "contact_voxels")},
    "novoxel": {"inputs": ("electrodes", "contact_point")},
    "su": {"inputs": ("electrodes", "pdc")},
    "voxel-dropout": {"inputs": ("electrode_voxels", "contact_voxels")},
}


# Every force network: each names its inputs (``input_names``) and its ``arch``.
ForceModel = ForceNet | SuNet | MultiHeadDropoutNet


def build_model(arch: str) -> ForceModel:
    if arch in ("voxel", "novoxel"):
        return ForceNet(arch)
    if arch == "su":
        return SuNet()
    if arch == "voxel-dropout":
        return MultiHeadDropoutNet()
    raise ValueError(f"unknown architecture {arch!r} (one of {', '.join(ARCHS)})")


def input_shapes(arch: str) -> dict[str, list[int | str]]:
    shapes: dict[str, list[int | str]] = {
        "electrode_voxels": ["n", *GRID],
        "contact_voxels": ["n", *GRID],
        "electrodes": ["n", 19],
        "contact_point": ["n", 3],
        "pdc": ["n", 1],
    }
    return {name: shapes[name] for name in ARCHS[arch]["inputs"]}


def predict(model: ForceModel, inputs: dict[str, torch.Tensor]) -> tuple[torch.Tensor, torch.Tensor | None]:
    """(f_sensor, variance or None) for a batch of named inputs."""
    out = model(*(inputs[n] for n in model.input_names))
    if isinstance(out, tuple):
        return out
    return out, None
