"""``convert-icra19``: build the official ONNX policies from the authors' weights."""

from __future__ import annotations

import argparse
from pathlib import Path

from grasp_ctrl.errors import UsageError

NAME = "convert-icra19"
HELP = "convert the ICRA 2019 authors' weights (.npz) into policies/NAME.onnx + NAME.json"
DESCRIPTION = (
    "Reads the authors' pretrained weights (icra19_weights.npz or ll4ma_lab_dropout_weights.npz), "
    "builds the network as an ONNX graph, checks it against a numpy forward pass on random inputs "
    "and writes OUT/NAME.onnx and OUT/NAME.json (policy metadata with provenance and licence)."
)
ORDER = 80

_DEFAULT_NAMES = {"icra19_weights": "icra19_official", "ll4ma_lab_dropout_weights": "icra19_dropout_official"}


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("npz", nargs="+", help="weight files (.npz), e.g. ../shared/data/official_icra19/*.npz")
    p.add_argument("--out", default=None, help="output folder (default: the policies folder)")
    p.add_argument("--name", default=None, help="policy name (only with one weight file; default from the file name)")
    p.add_argument("--seed", type=int, default=0, help="seed of the frozen dropout masks (dropout variant)")
    p.add_argument("--tol", type=float, default=1e-5, help="largest accepted ONNX/numpy error (scaled, see docs)")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.config.identifiers import check_identifier_arg
    from grasp_ctrl.files.paths import policies_dir

    try:
        from grasp_ctrl.policy_tools.convert_icra19 import convert
    except ImportError as exc:
        raise UsageError(f"convert-icra19 needs the onnx package (pip install 'grasp-ctrl[train]'): {exc}") from None
    if args.name and len(args.npz) != 1:
        raise UsageError("--name: only with a single weight file")
    out = Path(args.out) if args.out else policies_dir()
    for npz in args.npz:
        path = Path(npz)
        if not path.is_file():
            raise UsageError(f"{npz}: no such weight file")
        name = check_identifier_arg(args.name or _DEFAULT_NAMES.get(path.stem, path.stem), "--name")
        try:
            onnx_path, json_path, err = convert(path, out, name, seed=args.seed, tol=args.tol)
        except (ValueError, KeyError, OSError) as exc:
            msg = str(exc)
            raise UsageError(msg if msg.startswith(str(path)) else f"{npz}: {msg}") from None
        print(f"{name}: wrote {onnx_path} and {json_path} (ONNX vs numpy error {err:.2g})")
    return 0
