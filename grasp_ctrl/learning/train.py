"""Training loop: Adam, batch 512, up to 200 epochs, the paper's learning-rate schedule,
best-validation checkpoint, a progress line per epoch."""

from __future__ import annotations

import math
import pickle
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import torch

from grasp_ctrl.config.sensor_layout import ELECTRODES, PDC
from grasp_ctrl.errors import reraise_interrupt
from grasp_ctrl.learning.dataset import Dataset
from grasp_ctrl.learning.features import _ELECTRODE_CELLS, GRID_SHAPE, _cell_index, contact_point_and_normal
from grasp_ctrl.learning.losses import sample_losses
from grasp_ctrl.learning.models import ForceModel, ForceNet, MultiHeadDropoutNet, build_model

CHECKPOINT_FORMAT = "grasp_ctrl-force-checkpoint-1"


@dataclass
class TrainConfig:
    arch: str = "voxel"
    beta: float | None = 1.0  # None: no alpha weight
    epochs: int = 200
    batch_size: int = 512
    lr0: float = 1e-4
    warmup_epochs: int = 2
    decay: float = 0.95
    seed: int = 0
    patience: int | None = None  # stop after this many epochs without improvement
    threads: int = 1  # torch CPU threads (more threads are slower on a busy 2-core box)


def learning_rate(cfg: TrainConfig, epoch: int, iteration: int, warmup_iterations: int) -> float:
    """Paper III-B: start at lr0, multiply by 2^ceil(i/50) during the first two epochs
    (i = iteration), then decay by 0.95 per epoch (we read "each iteration" of the
    remaining phase as each epoch; per batch the rate would vanish within a few epochs)."""
    if epoch < cfg.warmup_epochs:
        return cfg.lr0 * 2.0 ** math.ceil(iteration / 50)
    peak = cfg.lr0 * 2.0 ** math.ceil(max(warmup_iterations - 1, 0) / 50)
    return peak * cfg.decay ** (epoch - cfg.warmup_epochs + 1)


class TensorData:
    """Compact per-sample tensors; voxel grids are built per batch (memory: 2 x 8 kB per sample)."""

    def __init__(self, ds: Dataset) -> None:
        s_c, s_n = contact_point_and_normal(ds.tared)
        f32 = lambda a: torch.as_tensor(np.asarray(a, dtype=np.float32))  # noqa: E731
        self.n = len(ds)
        self.electrodes = f32(ds.tared[:, ELECTRODES])
        self.pdc = f32(ds.tared[:, PDC : PDC + 1])
        self.contact_point = f32(s_c)
        self.contact_cell = torch.as_tensor(_cell_index(s_c), dtype=torch.long)
        self.surface_normal = f32(s_n)
        self.f = f32(ds.f_sensor)
        self.projected = torch.as_tensor(ds.projected, dtype=torch.bool)
        self.rot = f32(ds.r_world_sensor)
        self.source = ds.source

    def inputs(self, idx: torch.Tensor, names: tuple[str, ...]) -> dict[str, torch.Tensor]:
        out: dict[str, torch.Tensor] = {}
        b = len(idx)
        if "electrode_voxels" in names:
            g = torch.zeros((b,) + GRID_SHAPE)
            ci = _ELECTRODE_CELLS
            g[:, ci[:, 0], ci[:, 1], ci[:, 2]] = self.electrodes[idx]
            out["electrode_voxels"] = g
        if "contact_voxels" in names:
            g = torch.zeros((b,) + GRID_SHAPE)
            cc = self.contact_cell[idx]
            g[torch.arange(b), cc[:, 0], cc[:, 1], cc[:, 2]] = 1.0
            out["contact_voxels"] = g
        for name in ("electrodes", "pdc", "contact_point"):
            if name in names:
                out[name] = getattr(self, name)[idx]
        return out


def _uses_voxels(model: ForceModel) -> bool:
    return "electrode_voxels" in model.input_names


def _forward_heads(model: ForceModel, data: TensorData, idx: torch.Tensor) -> torch.Tensor:
    """(b, heads, 3) for the dropout model, (b, 1, 3) otherwise. Voxel models run on the
    compact inputs (the sparse path, identical to the grids)."""
    if _uses_voxels(model):
        electrodes, contact_cell = data.electrodes[idx], data.contact_cell[idx]
        if isinstance(model, MultiHeadDropoutNet):
            return model.heads_forward(electrodes, contact_cell, compact=True)
        assert isinstance(model, ForceNet)  # the other model on voxels
        return model.forward_compact(electrodes, contact_cell).unsqueeze(1)
    x = data.inputs(idx, model.input_names)
    return model(*(x[n] for n in model.input_names)).unsqueeze(1)


def _batch_loss(model: ForceModel, data: TensorData, idx: torch.Tensor, beta: float | None) -> torch.Tensor:
    heads = _forward_heads(model, data, idx)
    losses = [
        sample_losses(data.f[idx], heads[:, h], data.projected[idx], data.rot[idx], data.surface_normal[idx], beta)
        for h in range(heads.shape[1])
    ]
    return torch.stack(losses).mean()


@torch.no_grad()
def predict_data(model: ForceModel, data: TensorData, batch_size: int = 2048) -> tuple[np.ndarray, np.ndarray | None]:
    """f_sensor (n, 3) and, for the dropout model, the per-axis variance over the heads."""
    model.eval()
    means, variances = [], []
    for start in range(0, data.n, batch_size):
        idx = torch.arange(start, min(start + batch_size, data.n))
        heads = _forward_heads(model, data, idx)
        means.append(heads.mean(dim=1))
        if isinstance(model, MultiHeadDropoutNet):
            variances.append(heads.var(dim=1, unbiased=False))
    f = torch.cat(means).numpy().astype(float) if means else np.zeros((0, 3))
    var = torch.cat(variances).numpy().astype(float) if variances else None
    return f, var


@torch.no_grad()
def evaluate_loss(model: ForceModel, data: TensorData, beta: float | None, batch_size: int = 2048) -> float:
    model.eval()
    total = 0.0
    for start in range(0, data.n, batch_size):
        idx = torch.arange(start, min(start + batch_size, data.n))
        total += float(_batch_loss(model, data, idx, beta)) * len(idx)
    return total / max(data.n, 1)


@dataclass
class TrainResult:
    model: ForceModel
    config: TrainConfig
    best_epoch: int
    best_val_loss: float
    history: list[dict[str, float]] = field(default_factory=list)
    seconds_per_epoch: float = 0.0


def train(
    train_ds: Dataset,
    val_ds: Dataset,
    cfg: TrainConfig,
    init_state: dict[str, Any] | None = None,
    progress: Callable[[str], None] | None = print,
) -> TrainResult:
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    gen = torch.Generator().manual_seed(cfg.seed)
    model = build_model(cfg.arch)
    if init_state is not None:
        model.load_state_dict(init_state)
    tr, va = TensorData(train_ds), TensorData(val_ds)
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr0)
    iters_per_epoch = max(1, math.ceil(tr.n / cfg.batch_size))
    warmup_iterations = cfg.warmup_epochs * iters_per_epoch
    best: tuple[float, int, dict[str, Any] | None] = (math.inf, -1, None)  # val loss, epoch, weights
    history = []
    iteration = 0
    epoch_times = []
    for epoch in range(cfg.epochs):
        t0 = time.perf_counter()
        model.train()
        perm = torch.randperm(tr.n, generator=gen)
        total = 0.0
        for start in range(0, tr.n, cfg.batch_size):
            # An interrupt whose exception torch swallowed (raised inside one of its own calls) is
            # still noted by the command's handler: stop at the next batch, not after every epoch.
            reraise_interrupt()
            idx = perm[start : start + cfg.batch_size]
            lr = learning_rate(cfg, epoch, iteration, warmup_iterations)
            for group in opt.param_groups:
                group["lr"] = lr
            loss = _batch_loss(model, tr, idx, cfg.beta)
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += float(loss.detach()) * len(idx)
            iteration += 1
        train_loss = total / tr.n
        val_loss = evaluate_loss(model, va, cfg.beta) if va.n else train_loss
        dt = time.perf_counter() - t0
        epoch_times.append(dt)
        improved = val_loss < best[0]
        if improved:
            best = (val_loss, epoch, {k: v.detach().clone() for k, v in model.state_dict().items()})
        history.append({"epoch": epoch + 1, "train_loss": train_loss, "val_loss": val_loss, "lr": lr, "seconds": dt})
        if progress:
            progress(
                f"[{cfg.arch}{'' if cfg.beta is None else f' alpha b={cfg.beta:g}'}] epoch {epoch + 1:3d}/{cfg.epochs}"
                f"  train {train_loss:.4f}  val {val_loss:.4f}  lr {lr:.2e}  {dt:.1f} s{'  *' if improved else ''}"
            )
        if cfg.patience is not None and epoch - best[1] >= cfg.patience:
            break
    assert best[2] is not None
    model.load_state_dict(best[2])
    model.eval()
    return TrainResult(model, cfg, best[1] + 1, best[0], history, float(np.median(epoch_times)))


def save_checkpoint(path: str, result: TrainResult, extra: dict[str, Any] | None = None) -> None:
    from grasp_ctrl.files.safe_write import output_file

    with output_file(path) as tmp:  # a symlink at ``path`` is replaced, never written through
        _save(tmp, result, extra)


def _save(path: Any, result: TrainResult, extra: dict[str, Any] | None) -> None:
    torch.save(
        {
            "format": CHECKPOINT_FORMAT,
            "arch": result.config.arch,
            "config": asdict(result.config),
            "state_dict": result.model.state_dict(),
            "best_epoch": result.best_epoch,
            "best_val_loss": result.best_val_loss,
            "seconds_per_epoch": result.seconds_per_epoch,
            "history": result.history,
            **(extra or {}),
        },
        path,
    )


def load_checkpoint(path: str) -> dict[str, Any]:
    # weights_only: a checkpoint holds tensors and plain containers; never unpickle code from it
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, RuntimeError, EOFError, OSError) as exc:
        raise ValueError(
            f"{path}: not a loadable weights-only checkpoint ({str(exc).splitlines()[0][:200] if str(exc) else type(exc).__name__})"
        ) from None
    if not isinstance(ckpt, dict) or ckpt.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(f"{path}: not a grasp_ctrl force checkpoint")
    return ckpt


def model_from_checkpoint(ckpt: dict[str, Any]) -> ForceModel:
    model = build_model(ckpt["arch"])
    model.load_state_dict(ckpt["state_dict"])
    model.eval()
    return model
