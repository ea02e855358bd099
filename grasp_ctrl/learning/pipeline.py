"""Glue shared by the train / evaluate / export commands: data in, splits, one training
run with its test metrics, the Fig. 3 experiment."""

from __future__ import annotations

import contextlib
import json
import time
from collections.abc import Callable, Generator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl.estimators.analytic import electrode_normal_sums, fit_gains
from grasp_ctrl.learning.dataset import SOURCES, Dataset, read_datasets
from grasp_ctrl.learning.metrics import METRICS, by_source
from grasp_ctrl.learning.splits import Split

COMBOS = {"rigid-ft": ("rigid-ft",), "planar-pushing": ("planar-pushing",), "ball-ft": ("ball-ft",), "mixed": SOURCES}
# model name -> (arch, beta); beta None = no alpha weight
FIG3_MODELS = {"analytic": ("analytic", None), "su": ("su", None), "voxel+alpha": ("voxel", 1.0)}
FIG4_MODELS = {"voxel": ("voxel", None), "novoxel+alpha": ("novoxel", 1.0), "novoxel": ("novoxel", None)}


def experiment_models(experiment: str) -> dict[str, tuple[str, float | None]]:
    """The models of ``train --experiment``: fig3 (analytic, Su, voxel+alpha), fig4 (voxel+alpha
    and its ablations: no alpha, no voxels, neither) or both."""
    if experiment == "fig3":
        return dict(FIG3_MODELS)
    if experiment == "fig4":
        return {"voxel+alpha": FIG3_MODELS["voxel+alpha"], **FIG4_MODELS}
    if experiment == "fig3+fig4":
        return {**FIG3_MODELS, **FIG4_MODELS}
    raise ValueError(f"experiment must be fig3, fig4 or fig3+fig4, not {experiment!r}")


@dataclass
class DataSpec:
    files: Sequence[str] = ()
    synthetic_per_source: int = 0
    seed: int = 0
    tare_frames: int = 10
    skip_bad: bool = False
    grasp_contacts: str | None = None  # a grasp-contacts CSV for the synthetic ball-ft source


def load_data(spec: DataSpec, report: Callable[[str], None] = print) -> tuple[Dataset, dict[str, Any]]:
    if spec.files:
        ds, notes = read_datasets(spec.files, spec.tare_frames, "skip" if spec.skip_bad else "raise")
        for note in notes:
            report(f"skipped bad row: {note}")
        return ds, {"files": [str(f) for f in spec.files], "skipped_rows": len(notes)}
    from grasp_ctrl.learning.synthetic import generate
    from grasp_ctrl.sim.biotac.grasp_contacts import load_contacts

    contacts = load_contacts(spec.grasp_contacts, skip_bad_rows=spec.skip_bad)
    t0 = time.perf_counter()
    ds = generate(spec.synthetic_per_source, seed=spec.seed, contacts=contacts)
    report(
        f"synthetic data: {len(ds)} force samples ({spec.synthetic_per_source}+ per source, seed {spec.seed}) "
        f"in {time.perf_counter() - t0:.1f} s"
    )
    info: dict[str, Any] = {
        "synthetic_per_source": spec.synthetic_per_source,
        "seed": spec.seed,
        "forward_model": "grasp_ctrl.sim.biotac.model (mock world)",
    }
    if contacts is not None:
        assert spec.grasp_contacts is not None  # contacts come only from a given file
        info["ball_ft_grasp_contacts"] = {"file": Path(spec.grasp_contacts).name, "contacts": contacts.summary()}
    return ds, info


def source_mask(ds: Dataset, sources: Sequence[str]) -> np.ndarray:
    return np.isin(ds.source, list(sources))


def train_indices(ds: Dataset, split: Split, sources: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    m = source_mask(ds, sources)
    return split.train[m[split.train]], split.val[m[split.val]]


def fit_analytic(ds: Dataset, idx: np.ndarray) -> np.ndarray:
    return fit_gains(ds.tared[idx], ds.f_sensor[idx])


def predict_analytic(gains: np.ndarray, ds: Dataset) -> np.ndarray:
    return electrode_normal_sums(ds.tared) * gains


def test_metrics(test: Dataset, f_pred: np.ndarray) -> dict[str, Any]:
    return by_source(test.f_sensor, f_pred, test.source)


def train_one(
    ds: Dataset,
    split: Split,
    sources: Sequence[str],
    arch: str,
    beta: float | None,
    epochs: int,
    seed: int,
    batch_size: int = 512,
    patience: int | None = None,
    init_state: dict | None = None,
    threads: int = 1,
    lr0: float = 1e-4,
    progress: Callable[[str], None] | None = print,
) -> dict[str, Any]:
    """Train one model on ``sources``; evaluate on the test samples of every source."""
    tr_idx, va_idx = train_indices(ds, split, sources)
    test = ds.subset(split.test)
    info: dict[str, Any] = {
        "arch": arch,
        "beta": beta,
        "sources": list(sources),
        "n_train": int(len(tr_idx)),
        "n_val": int(len(va_idx)),
        "n_test": int(len(test)),
    }
    if arch == "analytic":
        t0 = time.perf_counter()
        gains = fit_analytic(ds, tr_idx)
        info.update(
            gains=gains, seconds=time.perf_counter() - t0, metrics=test_metrics(test, predict_analytic(gains, test))
        )
        return info
    from grasp_ctrl.learning.train import TensorData, TrainConfig, predict_data, train

    cfg = TrainConfig(
        arch=arch,
        beta=beta,
        epochs=epochs,
        batch_size=batch_size,
        seed=seed,
        patience=patience,
        threads=threads,
        lr0=lr0,
    )
    t0 = time.perf_counter()
    result = train(ds.subset(tr_idx), ds.subset(va_idx), cfg, init_state=init_state, progress=progress)
    f_pred, _ = predict_data(result.model, TensorData(test))
    info.update(
        result=result,
        seconds=time.perf_counter() - t0,
        seconds_per_epoch=result.seconds_per_epoch,
        metrics=test_metrics(test, f_pred),
    )
    return info


def metrics_table(results: dict[str, dict[str, dict[str, Any]]], test_source: str = "mixed") -> str:
    """Markdown: rows = training sources x models, columns = median [q1, q3] of each metric."""
    head = "| trained on | model | " + " | ".join(f"{m} median [q1, q3]" for m in METRICS) + " |"
    lines = [head, "|" + "---|" * (2 + len(METRICS))]
    for combo, models in results.items():
        for model, info in models.items():
            s = info["metrics"][test_source]
            cells = [f"{s[m]['median']:.2f} [{s[m]['q1']:.2f}, {s[m]['q3']:.2f}]" for m in METRICS]
            lines.append(f"| {combo} | {model} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def run_experiment(
    ds: Dataset,
    split: Split,
    models: dict[str, tuple[str, float | None]],
    out_dir: Path,
    epochs: int,
    seed: int,
    data_info: dict[str, Any],
    threads: int = 1,
    progress: Callable[[str], None] = print,
    lr0: float = 1e-4,
    patience: int | None = None,
    report: Callable[[str], None] | None = None,
    executor: str = "local",
    address: str | None = None,
    jobs: int | None = None,
) -> dict[str, Any]:
    """Every model on every training-source combination; checkpoints, JSON and tables in out_dir.
    ``progress``: per-epoch status; ``report``: each model's result line (default: ``progress``).
    ``executor="ray"``: the models train as Ray tasks (``threads`` CPUs each; ``address``: a
    running cluster, else a local instance of ``jobs`` CPUs); same files."""
    report = report or progress
    plan = [
        (combo, sources, name, arch, beta) for combo, sources in COMBOS.items() for name, (arch, beta) in models.items()
    ]
    if executor == "ray":
        from grasp_ctrl.trials.runs.ray_executor import ray_map

        args = [
            (sources, arch, beta, epochs, seed, 512, patience, None, threads, lr0, None)
            for _, sources, _, arch, beta in plan
        ]
        trained = ray_map(address, jobs, train_one, args, shared=(ds, split), cpus_per_task=threads)
    else:

        def one_by_one() -> Generator[tuple[int, dict[str, Any]], None, None]:
            for i, (combo, sources, name, arch, beta) in enumerate(plan):
                progress(f"== {name} on {combo}")
                yield (
                    i,
                    train_one(
                        ds,
                        split,
                        sources,
                        arch,
                        beta,
                        epochs,
                        seed,
                        threads=threads,
                        progress=progress,
                        lr0=lr0,
                        patience=patience,
                    ),
                )

        trained = one_by_one()
    from grasp_ctrl.learning.train import save_checkpoint

    out_dir.mkdir(parents=True, exist_ok=True)
    done: dict[int, dict[str, Any]] = {}
    # closing: Ray's processes end at once on Ctrl-C or an error, not when the generator is collected
    with contextlib.closing(trained):
        for i, info in trained:
            combo, sources, model_name, arch, _beta = plan[i]
            stem = f"{combo}__{model_name.replace('+', '_')}"
            if arch == "analytic":
                from grasp_ctrl.learning.export import analytic_policy

                (out_dir / f"{stem}.json").write_text(
                    json.dumps(
                        analytic_policy(stem, info["gains"], {**data_info, "sources": list(sources)}, info["metrics"]),
                        indent=2,
                    )
                    + "\n"
                )
                info["gains"] = [float(g) for g in info["gains"]]
            else:
                result = info.pop("result")
                save_checkpoint(
                    str(out_dir / f"{stem}.pt"),
                    result,
                    {
                        "data": {**data_info, "sources": list(sources), "n_train": info["n_train"]},
                        "metrics": info["metrics"],
                    },
                )
                info["best_epoch"] = result.best_epoch
            m = info["metrics"]["mixed"]
            done[i] = info
            report(
                f"{model_name} on {combo} ({len(done)}/{len(plan)}): angle "
                f"{m['angle_deg']['median']:.1f} deg, magnitude {m['magnitude_error_n']['median']:.3f} N "
                f"(median on the mixed test set), {info['seconds']:.0f} s"
            )
    results: dict[str, dict[str, dict[str, Any]]] = {combo: {} for combo in COMBOS}
    for i, (combo, _, model_name, _, _) in enumerate(plan):  # the table's order, whatever finished first
        results[combo][model_name] = done[i]
    doc = {"data": data_info, "epochs": epochs, "seed": seed, "lr0": lr0, "patience": patience, "results": results}
    (out_dir / "results.json").write_text(json.dumps(doc, indent=2, default=float) + "\n")
    tables = ["## Test set: all sources (mixed)", metrics_table(results, "mixed")]
    for s in SOURCES:
        tables += [f"## Test set: {s}", metrics_table(results, s)]
    (out_dir / "results.md").write_text("\n\n".join(tables) + "\n")
    return doc
