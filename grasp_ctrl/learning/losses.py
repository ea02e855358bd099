"""The paper's losses (eqs. 10-13), in torch.

Sign convention: labels and predictions are f_sensor, the force ON the skin, which points
INTO the sensor for a press, while s_n is the OUTWARD surface normal. The paper's alpha
weights a force along the normal highest; with f_sensor that is the inward normal -s_n, so
D = acos(-s_n . f_hat) / pi here (identical to the paper's D with its opposite force sign).
"""

from __future__ import annotations

import torch

MIN_LABEL_N = 0.05  # guards the 1/||f_3d|| scaling against near-zero labels
WORLD_UP = torch.tensor([0.0, 0.0, 1.0])


def normalized_cosine_distance(s_n_out: torch.Tensor, f_3d: torch.Tensor) -> torch.Tensor:
    f_hat = f_3d / f_3d.norm(dim=1, keepdim=True).clamp_min(1e-12)
    cos = (-s_n_out * f_hat).sum(dim=1).clamp(-1.0, 1.0)
    return torch.arccos(cos) / torch.pi


def alpha_weight(s_n_out: torch.Tensor, f_3d: torch.Tensor, beta: float) -> torch.Tensor:
    """alpha = 2^(beta (1 - D(s_n, f_3d)))."""
    return torch.pow(2.0, beta * (1.0 - normalized_cosine_distance(s_n_out, f_3d)))


def q_3d(f_3d: torch.Tensor, f_p: torch.Tensor) -> torch.Tensor:
    return (f_3d - f_p).norm(dim=1) / f_3d.norm(dim=1).clamp_min(MIN_LABEL_N)


def q_proj(f_3d: torch.Tensor, f_p: torch.Tensor, r_world_sensor: torch.Tensor) -> torch.Tensor:
    """||P (R f_3d - R f_p)||^2 / ||f_3d||, P the projection onto the support plane
    (world z is the plane normal): only the planar components are trusted."""
    diff_world = torch.einsum("nij,nj->ni", r_world_sensor, f_3d - f_p)
    planar = diff_world[:, :2]
    return (planar * planar).sum(dim=1) / f_3d.norm(dim=1).clamp_min(MIN_LABEL_N)


def sample_losses(
    f_3d: torch.Tensor,
    f_p: torch.Tensor,
    projected: torch.Tensor,
    r_world_sensor: torch.Tensor,
    s_n_out: torch.Tensor,
    beta: float | None,
) -> torch.Tensor:
    """Q per sample: alpha * (Q_proj if planar pushing else Q_3d); beta=None -> alpha = 1."""
    q = torch.where(projected, q_proj(f_3d, f_p, r_world_sensor), q_3d(f_3d, f_p))
    if beta is None:
        return q
    return alpha_weight(s_n_out, f_3d, beta) * q
