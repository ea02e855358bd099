"""``evaluate``: test metrics (paper eqs. 14-15) of a checkpoint or policy, per source and mixed."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from grasp_ctrl.cli._learning_args import add_data_arguments, data_spec
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import check_output, write_output  # noqa: F401

if TYPE_CHECKING:
    from grasp_ctrl.estimators.base import ForceEstimator

NAME = "evaluate"
HELP = "force-estimation metrics of a checkpoint or policy on a test set"
ORDER = 71


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "model",
        nargs="+",
        metavar="MODEL",
        help="a .pt checkpoint, a policy name, or a policy .onnx/.json file (several: compared)",
    )
    add_data_arguments(p)
    p.add_argument(
        "--split",
        choices=("test", "all"),
        default="test",
        help="test: the trial-wise test split (same seed as training); all: every sample",
    )
    p.add_argument("--json", metavar="FILE", help="write the metrics as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="box plots of angle and magnitude error (plot extra)")
    p.add_argument("--quiet", action="store_true", help="no progress line (shown only on a terminal anyway)")


def _predict(spec: str, tared: np.ndarray, bar: Any = None) -> np.ndarray:
    """Forces for every sample; ``bar`` (tqdm) advances by the samples done."""
    path = Path(spec)
    if path.suffix == ".pt":
        from grasp_ctrl.cli._learning_args import require_torch

        require_torch()
        from grasp_ctrl.learning.dataset import Dataset
        from grasp_ctrl.learning.train import TensorData, load_checkpoint, model_from_checkpoint, predict_data

        try:
            model = model_from_checkpoint(load_checkpoint(str(path)))
        except (OSError, ValueError) as exc:
            raise UsageError(f"{path}: {exc}") from None
        n = len(tared)
        ds = Dataset(
            np.zeros(n, str),
            np.zeros(n, str),
            np.zeros(n),
            tared,
            np.ones((n, 3)),
            np.zeros(n, bool),
            np.repeat(np.eye(3)[None], n, axis=0),
        )
        out = predict_data(model, TensorData(ds))[0]
        if bar is not None:
            bar.update(n)
        return out
    from grasp_ctrl.estimators.feature_onnx_estimator import FEATURE_KINDS, load_feature_onnx_policy
    from grasp_ctrl.estimators.registry import load_policy, read_metadata, resolve_policy_path

    json_path = resolve_policy_path(spec)
    meta = read_metadata(json_path)
    est: ForceEstimator
    if meta["kind"] == "onnx" and (meta.get("input") or {}).get("kind") in FEATURE_KINDS:
        est = load_feature_onnx_policy(meta, json_path, None, 1)
    else:
        est = load_policy(str(json_path))  # the controller's own estimator for this policy
    forces: list[np.ndarray] = []
    for i in range(0, len(tared), 4096):
        chunk = tared[i : i + 4096]
        forces.append(est.estimate(chunk, [""] * len(chunk)).f_sensor)
        if bar is not None:
            bar.update(len(chunk))
    return np.concatenate(forces)


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.learning.metrics import METRICS, by_source, per_sample
    from grasp_ctrl.learning.pipeline import load_data
    from grasp_ctrl.learning.splits import split_by_trials

    check_output(args.json, "--json")
    if args.plot:
        from grasp_ctrl.files.safe_write import IMAGE_FORMATS

        check_output(args.plot, "--plot", formats=IMAGE_FORMATS)
    ds, _ = load_data(data_spec(args), report=print)
    if args.split == "test":
        ds = ds.subset(split_by_trials(ds, seed=args.seed, test_per_source=args.test_per_source).test)
    if len(ds) == 0:
        raise UsageError("no samples to evaluate (use --split all for a small recording)")
    from grasp_ctrl.display.progress_bar import progress_bar

    doc, per_model = {}, {}
    for spec in args.model:
        with progress_bar(len(ds), f"evaluate {Path(spec).stem}", not args.quiet, unit="sample") as bar:
            f_pred = _predict(spec, ds.tared, bar)
        doc[spec] = by_source(ds.f_sensor, f_pred, ds.source)
        values = per_sample(ds.f_sensor, f_pred)
        for src in ds.sources():
            per_model[f"{Path(spec).stem} / {src}"] = {k: v[ds.source == src] for k, v in values.items()}
        print(f"{spec}: median [q1, q3] on {len(ds)} samples")
        print(f"  {'test set':16s} " + " ".join(f"{m:>24s}" for m in METRICS))
        for src, s in doc[spec].items():
            cells = " ".join(f"{s[m]['median']:8.3f} [{s[m]['q1']:6.2f},{s[m]['q3']:6.2f}]" for m in METRICS)
            print(f"  {src:16s} {cells}")
    if args.json:
        write_output(check_output(args.json, "--json"), json.dumps(doc, indent=2) + "\n")
    if args.plot:
        from grasp_ctrl.learning.plots import box_plots

        box_plots(per_model, args.plot)
        print(f"wrote {args.plot}")
    return 0
