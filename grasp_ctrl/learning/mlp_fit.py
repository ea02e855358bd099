"""Fit the small numpy-run MLP policy (estimators/mlp.py) with torch.

Mean-squared force error, Adam, fixed seed and one thread, so a refit on the same
machine gives the same weights. Used by ``fit-mock-policies`` for ``mlp_mock``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch


def fit_mlp(
    x: np.ndarray, f_sensor: np.ndarray, hidden: int = 64, epochs: int = 60, seed: int = 0, batch: int = 256
) -> dict[str, Any]:
    """Inputs ``x`` (n, c) and labels (n, 3) in N -> mean, scale and layers (JSON-ready lists)."""
    mean = x.mean(axis=0)
    scale = x.std(axis=0) + 1e-6
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        gen = torch.Generator().manual_seed(seed)
        torch.manual_seed(seed)
        net = torch.nn.Sequential(
            torch.nn.Linear(x.shape[1], hidden),
            torch.nn.Tanh(),
            torch.nn.Linear(hidden, hidden),
            torch.nn.Tanh(),
            torch.nn.Linear(hidden, 3),
        ).double()
        opt = torch.optim.Adam(net.parameters(), lr=3e-3)
        xs = torch.tensor((x - mean) / scale)
        fs = torch.tensor(np.asarray(f_sensor, dtype=float))
        for epoch in range(epochs):
            if epoch == (2 * epochs) // 3:  # a finer second stage
                for group in opt.param_groups:
                    group["lr"] = 1e-3
            order = torch.randperm(len(xs), generator=gen)
            for start in range(0, len(xs), batch):
                idx = order[start : start + batch]
                opt.zero_grad()
                loss = ((net(xs[idx]) - fs[idx]) ** 2).mean()
                loss.backward()
                opt.step()
    finally:
        torch.set_num_threads(threads)
    layers = [
        {"weights": m.weight.detach().numpy().tolist(), "bias": m.bias.detach().numpy().tolist()}
        for m in net
        if isinstance(m, torch.nn.Linear)
    ]
    return {"input_mean": mean.tolist(), "input_scale": scale.tolist(), "layers": layers}
