"""``biotac-anchors``: how real the simulated BioTac looks (docs/mock_world.md)."""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict

from grasp_ctrl.files.safe_write import check_output, write_output  # noqa: F401

NAME = "biotac-anchors"
HELP = "measure the simulated BioTac against real recordings and the authors' real-data network"
ORDER = 75


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--data",
        required=True,
        metavar="CSV",
        help="real recordings, robotic_finger_tidy.csv (long trials A and B are used)",
    )
    p.add_argument(
        "--n",
        type=int,
        default=20000,
        help="synthetic force samples per source (default 20000, about 200 presses: with a few "
        "dozen presses the median angle moves by several degrees from seed to seed)",
    )
    p.add_argument("--seed", type=int, default=7, help="seed of the synthetic presses (default 7)")
    p.add_argument(
        "--params",
        metavar="JSON",
        help="BioTac model parameters to measure instead of the defaults: a JSON object of "
        "BioTacParams fields that differ (docs/mock_world.md), e.g. docs/biotac_params_rise_fit.json",
    )
    p.add_argument("--json", metavar="FILE", help="also write the figures as JSON")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.evaluation.biotac_anchors import (
        PAD_SCAN_FORCES_N,
        PAD_SCAN_X_M,
        anchor_report,
        format_location_shares,
        format_pad_scan,
        format_report,
        pad_press_ratios,
    )
    from grasp_ctrl.sim.biotac.params_file import load_biotac_params

    if args.n < 50:
        raise UsageError("--n: at least 50 samples per source")
    if args.seed < 0:
        raise UsageError("--seed: must be >= 0")
    try:
        params = load_biotac_params(args.params) if args.params else None
    except ValueError as exc:
        raise UsageError(f"--params: {exc}") from None
    try:
        report = anchor_report(args.data, n_per_source=args.n, seed=args.seed, params=params)
    except KeyError as exc:
        raise UsageError(str(exc.args[0])) from None
    print(format_report(report))
    ratios = pad_press_ratios(params)
    print()
    print(format_pad_scan(ratios))
    print()
    print(format_location_shares(report.location_share))
    if args.json:
        figures = asdict(report) | {
            "pad_scan": {"x_m": list(PAD_SCAN_X_M), "forces_n": list(PAD_SCAN_FORCES_N), "ratio": ratios.tolist()}
        }
        write_output(check_output(args.json, "--json"), json.dumps(figures, indent=2) + "\n")
    return 0
