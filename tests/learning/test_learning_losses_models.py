"""Losses (alpha weight, Q_3d, Q_proj) and the networks."""

from __future__ import annotations

import math

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from grasp_ctrl.learning.features import _cell_index, contact_point_and_normal, voxel_grids  # noqa: E402
from grasp_ctrl.learning.losses import alpha_weight, q_3d, q_proj, sample_losses  # noqa: E402
from grasp_ctrl.learning.models import build_model  # noqa: E402
from grasp_ctrl.learning.train import TrainConfig, learning_rate  # noqa: E402


@pytest.mark.parametrize("beta", [0.5, 1.0, 3.0])
def test_alpha_matches_the_formula(beta: float) -> None:
    rng = np.random.default_rng(0)
    s_n = rng.normal(size=(50, 3))
    s_n /= np.linalg.norm(s_n, axis=1, keepdims=True)
    f = rng.normal(size=(50, 3)) * 3
    got = alpha_weight(torch.tensor(s_n), torch.tensor(f), beta).numpy()
    # paper eqs. 12-13 with the force the finger applies (-f_sensor) against the outward normal
    f_hat = -f / np.linalg.norm(f, axis=1, keepdims=True)
    d = np.arccos(np.clip(np.sum(s_n * f_hat, axis=1), -1, 1)) / math.pi
    np.testing.assert_allclose(got, 2.0 ** (beta * (1 - d)), rtol=1e-10)
    # a press straight into the skin gets the largest weight, a pull the smallest
    n = torch.tensor([[0.0, 0.0, -1.0]])
    assert float(alpha_weight(n, torch.tensor([[0.0, 0.0, 2.0]]), beta)) == pytest.approx(2.0**beta)
    assert float(alpha_weight(n, torch.tensor([[0.0, 0.0, -2.0]]), beta)) == pytest.approx(1.0)


def test_q3d_and_qproj() -> None:
    f = torch.tensor([[0.0, 0.0, 2.0], [3.0, 4.0, 0.0]])
    p = torch.tensor([[0.0, 0.0, 1.0], [3.0, 4.0, 0.0]])
    np.testing.assert_allclose(q_3d(f, p).numpy(), [0.5, 0.0])
    r = torch.eye(3).repeat(2, 1, 1)
    # vertical (world z) disagreement is ignored, planar error is squared over ||f||
    np.testing.assert_allclose(q_proj(f, p, r).numpy(), [0.0, 0.0])
    p2 = torch.tensor([[1.0, 0.0, 2.0], [3.0, 4.0, 9.0]])
    np.testing.assert_allclose(q_proj(f, p2, r).numpy(), [0.5, 0.0])
    # the plane follows the sensor orientation
    r_tilt = torch.tensor([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]).repeat(2, 1, 1)  # sensor z -> world -y
    assert float(q_proj(f, p, r_tilt)[0]) == pytest.approx(0.5)
    proj = torch.tensor([True, False])
    s_n = torch.tensor([[0.0, 0.0, -1.0], [0.0, -1.0, 0.0]])
    out = sample_losses(f, p2, proj, r, s_n, beta=None)
    np.testing.assert_allclose(out.numpy(), [0.5, float(q_3d(f, p2)[1])], rtol=1e-6)


def test_learning_rate_schedule() -> None:
    cfg = TrainConfig(lr0=1e-4, warmup_epochs=2, decay=0.95)
    assert learning_rate(cfg, 0, 0, 100) == pytest.approx(1e-4)
    assert learning_rate(cfg, 0, 1, 100) == pytest.approx(2e-4)
    assert learning_rate(cfg, 1, 51, 100) == pytest.approx(4e-4)
    peak = 1e-4 * 2.0 ** math.ceil(99 / 50)
    assert learning_rate(cfg, 2, 100, 100) == pytest.approx(peak * 0.95)
    assert learning_rate(cfg, 5, 500, 100) == pytest.approx(peak * 0.95**4)


def _frames(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    tared = np.zeros((n, 44))
    tared[:, :19] = -np.abs(rng.normal(0, 400, (n, 19)))
    tared[:, 19] = rng.uniform(10, 500, n)
    return tared


@pytest.mark.parametrize("arch", ["voxel", "voxel-dropout"])
def test_sparse_training_path_equals_the_voxel_grids(arch: str) -> None:
    torch.manual_seed(0)
    model = build_model(arch).eval()
    for p in model.parameters():
        torch.nn.init.normal_(p, std=0.2)
    tared = _frames(32, 1)
    s_c, _ = contact_point_and_normal(tared)
    e_vox, c_vox = voxel_grids(tared, s_c)
    e = torch.tensor(tared[:, :19], dtype=torch.float32)
    cell = torch.tensor(_cell_index(s_c))
    with torch.no_grad():
        if arch == "voxel":
            dense = model(torch.tensor(e_vox), torch.tensor(c_vox))
            sparse = model.forward_compact(e, cell)
        else:
            dense = model.heads_forward(torch.tensor(e_vox), torch.tensor(c_vox))
            sparse = model.heads_forward(e, cell, compact=True)
    torch.testing.assert_close(sparse, dense, atol=1e-4, rtol=1e-4)


def test_voxel_net_layer_shapes_match_the_authors() -> None:
    m = build_model("voxel")
    shapes = {k: tuple(v.shape) for k, v in m.state_dict().items()}
    assert shapes["trunk.conv_e.linear.weight"] == (64, 8)  # Conv 1 -> 64, kernel 2^3
    assert shapes["trunk.conv2.linear.weight"] == (64, 128 * 8)  # 128 -> 64
    assert shapes["trunk.conv3.linear.weight"] == (64, 64 * 8)
    assert shapes["trunk.conv4.linear.weight"] == (128, 64 * 4)  # 2D 64 -> 128
    assert (
        shapes["fc1.0.weight"] == (64, 128) and shapes["fc2.0.weight"] == (32, 64) and shapes["out.weight"] == (3, 32)
    )


def test_dropout_model_reports_variance_and_other_models_shapes() -> None:
    m = build_model("voxel-dropout").eval()
    x = torch.zeros(4, 16, 16, 8)
    x[:, 3, 3, 3] = -500.0
    f, var = m(x, x.clone())
    assert f.shape == (4, 3) and var.shape == (4, 3) and bool(torch.all(var >= 0))
    assert build_model("novoxel")(torch.zeros(2, 19), torch.zeros(2, 3)).shape == (2, 3)
    assert build_model("su")(torch.zeros(2, 19), torch.zeros(2, 1)).shape == (2, 3)
    with pytest.raises(ValueError):
        build_model("resnet")
