"""``train``: fit a force model (or run the paper's Fig. 3 experiment)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from grasp_ctrl.cli._learning_args import add_data_arguments, data_spec, parse_sources, require_torch
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import check_output, write_output  # noqa: F401

NAME = "train"
HELP = "train a force model on recorded or synthetic data (needs the train extra)"
DESCRIPTION = (
    "Train one force model (voxel network, no-voxel variant, Su et al. baseline, multi-head dropout variant, "
    "or the analytic linear model) on some of the three sources, keep the best validation checkpoint and "
    "report test metrics; or, with --experiment fig3, every model on every source combination (paper Fig. 3). "
    "--init-from fine-tunes from a policy exported by `export` or a checkpoint."
)
ORDER = 70
ARCH_CHOICES = ("voxel", "novoxel", "su", "voxel-dropout", "analytic")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.cli._common_options import add_jobs_options

    add_data_arguments(p)
    p.add_argument("--sources", default="mixed", help="mixed, or a comma list of rigid-ft, ball-ft, planar-pushing")
    p.add_argument("--arch", choices=ARCH_CHOICES, default="voxel")
    p.add_argument("--beta", type=float, default=1.0, help="alpha weight exponent beta (paper eq. 12)")
    p.add_argument("--no-alpha", action="store_true", help="train without the alpha weight")
    p.add_argument("--epochs", type=int, default=200, help="maximum epochs (paper: 200)")
    p.add_argument("--batch-size", type=int, default=512)
    p.add_argument("--lr", type=float, default=1e-4, help="initial learning rate (paper: 1e-4)")
    p.add_argument("--patience", type=int, default=None, help="stop after N epochs without validation improvement")
    p.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    p.add_argument(
        "--init-from",
        metavar="POLICY|FILE",
        help="fine-tune: start from an exported policy (NAME or .onnx), a .pt checkpoint, or the "
        "authors' ICRA 2019 weights (.npz or the converted policy icra19_official, --arch voxel)",
    )
    p.add_argument("--out", metavar="FILE", help="checkpoint to write (.pt; .json for --arch analytic)")
    p.add_argument(
        "--experiment",
        choices=("fig3", "fig4", "fig3+fig4"),
        help="run the paper's comparison instead of one model (fig4: the voxel network and its "
        "ablations without alpha and without voxels)",
    )
    p.add_argument("--out-dir", metavar="DIR", default="runs/fig3", help="experiment output folder")
    add_jobs_options(
        p,
        jobs_default=None,
        jobs_help="with --executor ray and no --address: CPUs of the local Ray instance (default: all)",
        executor_help="with --experiment: ray trains the models as Ray tasks (the ray extra; --threads CPUs each)",
    )
    p.add_argument(
        "--quiet",
        action="store_true",
        help="no progress line (the current model and epoch; shown only on a terminal anyway)",
    )


def _init_state(spec: str, arch: str):
    from grasp_ctrl.learning.export import ExportError, load_onnx_weights
    from grasp_ctrl.learning.train import load_checkpoint

    path = Path(spec)
    if path.suffix == ".npz":
        from grasp_ctrl.learning.official import official_state_dict

        if arch != "voxel":
            raise UsageError("--init-from: the authors' ICRA 2019 weights are a 'voxel' model (use --arch voxel)")
        try:
            return official_state_dict(path)
        except (OSError, KeyError, ValueError) as exc:
            raise UsageError(f"--init-from: {path}: not the authors' ICRA 2019 weights ({exc})") from None
    if path.suffix == ".pt":
        try:
            ckpt = load_checkpoint(str(path))
        except (OSError, ValueError) as exc:
            raise UsageError(f"--init-from: {exc}") from None
        init_arch, state = ckpt["arch"], ckpt["state_dict"]
    else:
        from grasp_ctrl.files.paths import policies_dir

        onnx_path = path.with_suffix(".onnx") if path.suffix in (".onnx", ".json") else policies_dir() / f"{spec}.onnx"
        if not onnx_path.is_file():
            raise UsageError(f"--init-from: {onnx_path}: no such policy file")
        from grasp_ctrl.learning.official import is_converted_policy, official_arrays_from_onnx, official_state_dict

        try:
            if is_converted_policy(onnx_path):  # e.g. icra19_official: the authors' weights, read from the graph
                init_arch, state = "voxel", official_state_dict(official_arrays_from_onnx(onnx_path))
            else:
                init_arch, state = load_onnx_weights(onnx_path)
        except (ExportError, ValueError) as exc:
            raise UsageError(f"--init-from: {exc}") from None
    if init_arch != arch:
        raise UsageError(f"--init-from: the policy is a {init_arch!r} model, --arch is {arch!r}")
    return state


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.display.progress_bar import StatusLine

    require_torch()
    spec = data_spec(args)
    if args.epochs < 1 or args.batch_size < 1 or args.threads < 1:
        raise UsageError("--epochs, --batch-size and --threads must be positive")
    if args.experiment:
        from grasp_ctrl.files.safe_write import check_output_dir

        check_output_dir(args.out_dir, "--out-dir")
    from grasp_ctrl.trials.runs.ray_executor import check_executor

    check_executor(args.executor, args.address)
    if args.executor != "local" and not args.experiment:
        raise UsageError("--executor ray: only with --experiment (one model trains here)")
    status = StatusLine(enabled=not args.quiet)
    try:
        return _train(args, spec, status)
    finally:
        status.close()


def _train(args: argparse.Namespace, spec: Any, status: Any) -> int:
    from grasp_ctrl.learning.pipeline import experiment_models, load_data, run_experiment, train_one
    from grasp_ctrl.learning.splits import split_by_trials

    progress = status.update
    ds, data_info = load_data(spec, report=status.note)
    split = split_by_trials(ds, seed=args.seed, test_per_source=args.test_per_source)
    status.note(
        f"split by trials: {len(split.train)} train, {len(split.val)} validation, {len(split.test)} test samples"
    )

    if args.experiment:
        models = experiment_models(args.experiment)
        doc = run_experiment(
            ds,
            split,
            models,
            Path(args.out_dir),
            args.epochs,
            args.seed,
            data_info,
            threads=args.threads,
            progress=progress,
            lr0=args.lr,
            patience=args.patience,
            report=status.note,
            executor=args.executor,
            address=args.address,
            jobs=args.jobs,
        )
        status.note((Path(args.out_dir) / "results.md").read_text())
        status.note(f"results: {Path(args.out_dir) / 'results.json'}; checkpoints in {args.out_dir}")
        return 0 if doc else 1

    sources = parse_sources(args.sources)
    beta = None if args.no_alpha else args.beta
    init = _init_state(args.init_from, args.arch) if args.init_from else None
    if args.init_from and args.arch == "analytic":
        raise UsageError("--init-from: the analytic model is refitted, not fine-tuned")
    info = train_one(
        ds,
        split,
        sources,
        args.arch,
        beta,
        args.epochs,
        args.seed,
        args.batch_size,
        args.patience,
        init,
        args.threads,
        args.lr,
        progress,
    )
    if info["n_train"] == 0:
        raise UsageError(f"no training samples for --sources {args.sources}")
    out = args.out or (
        f"{args.arch}_{'-'.join(sources) if len(sources) < 3 else 'mixed'}.{'json' if args.arch == 'analytic' else 'pt'}"
    )
    data = {**data_info, "sources": list(sources), "n_train": info["n_train"]}
    if args.arch == "analytic":
        from grasp_ctrl.learning.export import analytic_policy

        write_output(
            check_output(out, "--out"),
            json.dumps(analytic_policy(Path(out).stem, info["gains"], data, info["metrics"]), indent=2) + "\n",
        )
    else:
        from grasp_ctrl.learning.train import save_checkpoint

        save_checkpoint(out, info["result"], {"data": data, "metrics": info["metrics"], "init_from": args.init_from})
        status.note(f"best epoch {info['result'].best_epoch}, {info['seconds_per_epoch']:.2f} s per epoch")
    status.close()  # the table below is printed as it is
    _print_metrics(info["metrics"])
    status.note(f"wrote {out}")
    return 0


def _print_metrics(metrics: dict) -> None:
    from grasp_ctrl.learning.metrics import METRICS

    print(f"{'test set':16s} " + " ".join(f"{m:>22s}" for m in METRICS) + "   (median)")
    for src, s in metrics.items():
        print(f"{src:16s} " + " ".join(f"{s[m]['median']:22.3f}" for m in METRICS) + f"   n={s[METRICS[0]]['n']}")
