"""``export``: a trained checkpoint -> policies/NAME.onnx + NAME.json."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from grasp_ctrl.cli._learning_args import require_torch
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import check_output, write_output  # noqa: F401

NAME = "export"
HELP = "export a trained model as a policy (ONNX + metadata JSON, checked against torch)"
ORDER = 72


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("checkpoint", metavar="CHECKPOINT", help="a .pt file from `train` (or an analytic .json)")
    p.add_argument("--name", required=True, help="policy name: writes NAME.onnx and NAME.json")
    p.add_argument("--out-dir", metavar="DIR", help="default: the policies/ folder")
    p.add_argument("--force", action="store_true", help="overwrite an existing policy of that name")
    p.add_argument(
        "--description",
        metavar="TEXT",
        help="the metadata's description (default: the architecture, and the start point if fine-tuned)",
    )


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.config.identifiers import check_identifier_arg
    from grasp_ctrl.files.paths import policies_dir
    from grasp_ctrl.files.safe_write import check_output_dir

    out_dir = check_output_dir(args.out_dir, "--out-dir") if args.out_dir is not None else policies_dir()
    check_identifier_arg(args.name, "--name")  # it names NAME.json and NAME.onnx
    json_path = out_dir / f"{args.name}.json"
    if json_path.exists() and not args.force:
        raise UsageError(f"{json_path}: exists (use --force to overwrite)")
    src = Path(args.checkpoint)
    if not src.is_file():
        raise UsageError(f"{src}: no such checkpoint")
    if src.suffix == ".json":
        meta = json.loads(src.read_text())
        if meta.get("kind") != "analytic":
            raise UsageError(f"{src}: not an analytic policy")
        meta["name"] = args.name
        out_dir.mkdir(parents=True, exist_ok=True)
        write_output(json_path, json.dumps(meta, indent=2) + "\n")
        print(f"wrote {json_path}")
        return 0
    require_torch()
    from grasp_ctrl.learning.export import ExportError, export_checkpoint
    from grasp_ctrl.learning.train import load_checkpoint

    try:
        ckpt = load_checkpoint(str(src))
        onnx_path, json_path, parity = export_checkpoint(ckpt, args.name, out_dir, args.description)
    except (OSError, ValueError, ExportError) as exc:
        raise UsageError(f"{src}: {exc}") from None
    print(f"wrote {onnx_path} and {json_path} (ONNX vs torch: max difference {parity:.2e} relative to max(1 N, |f|))")
    return 0
