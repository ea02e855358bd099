"""``calibrate``: fit a per-sensor correction on top of a policy and write it as a new policy."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from grasp_ctrl.errors import UsageError

NAME = "calibrate"
HELP = "fit a per-sensor correction on top of a policy from labelled presses; writes a new policy"
DESCRIPTION = (
    "Runs the base policy on the in-contact frames of a labelled recording and fits a small correction of "
    "its output by least squares (gains: rotation + per-axis gains; linear: 3x3 matrix; affine: + bias; "
    "residual: + a ridge-regularised linear term in the 19 electrodes). Accepts a dataset file "
    "(docs/learning.md: force labels in the sensor frame; raw files are tared on their 0 0 0 rows) or a "
    "plate-normal recording like robotic_finger_tidy.csv (direction-only labels in an unknown mount frame: "
    "the frame is estimated first, the magnitude stays the base policy's). Writes policies/NAME.json "
    "(kind 'calibrated', loaded through the registry like any policy) with the base policy's file hashes, "
    "the data file's hash, the fitted numbers and the errors before and after."
)
ORDER = 73
MODELS = ("gains", "linear", "affine", "residual")  # grasp_ctrl.evaluation.calibration.MODELS (not imported: scipy)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--data", required=True, metavar="REC.csv", help="labelled recording (dataset CSV/Parquet, or plate normals)"
    )
    p.add_argument(
        "--skip-bad-rows",
        action="store_true",
        help="plate-normal recordings: leave out rows that are short, not numbers, out of range or "
        "with a non-unit normal (counted on stderr) instead of stopping at the first",
    )
    p.add_argument("--policy", required=True, metavar="NAME", help="base policy (name in policies/, or a .json path)")
    p.add_argument(
        "--out",
        required=True,
        metavar="NAME",
        help="new policy: a name (writes policies/NAME.json) or a path ending in .json",
    )
    p.add_argument("--model", choices=MODELS, default="residual", help="correction model (default residual)")
    p.add_argument("--ridge", type=float, default=1e-3, help="residual model: ridge strength on the electrode term")
    p.add_argument("--trials", metavar="ID,...", help="fit on these trials only (default: all)")
    p.add_argument("--test-trials", metavar="ID,...", help="held-out trials: report the error before/after on them")
    p.add_argument(
        "--tare-frames",
        type=int,
        default=None,
        help="dataset raw files: minimum 0 0 0 tare rows per trial (default 10); plate recordings: "
        "frames at each trial's start used as its baseline (default 50)",
    )
    p.add_argument(
        "--min-pdc",
        type=float,
        default=50.0,
        help="plate recordings: also require tared pdc >= this (default 50; drops release drift)",
    )
    p.add_argument("--threads", type=int, default=1, help="onnxruntime threads")
    p.add_argument("--force", action="store_true", help="overwrite an existing policy of that name")
    p.add_argument(
        "--allow-worse",
        action="store_true",
        help="write the calibration even when it makes the error worse or collapses an axis "
        "(refused otherwise; a warning is printed)",
    )


def _ids(text: str | None) -> list[str]:
    return [s.strip() for s in (text or "").split(",") if s.strip()]


def _out_path(spec: str) -> Path:
    from grasp_ctrl.config.identifiers import check_identifier_arg
    from grasp_ctrl.files.paths import policies_dir

    if spec.endswith(".json"):
        return Path(spec)
    return policies_dir() / f"{check_identifier_arg(spec, '--out (a policy name, or a path ending in .json)')}.json"


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from grasp_ctrl.config.identifiers import check_identifier_arg
    from grasp_ctrl.estimators.calibrated import policy_files, sha256_of
    from grasp_ctrl.estimators.registry import load_policy, read_metadata, resolve_policy_path
    from grasp_ctrl.evaluation.calibration import calibrate, load_data
    from grasp_ctrl.evaluation.calibration_checks import fit_problems
    from grasp_ctrl.evaluation.direction import policy_directions
    from grasp_ctrl.files.paths import policies_dir
    from grasp_ctrl.files.safe_write import check_new_file, check_output, write_output

    if args.ridge < 0 or args.threads < 1 or (args.tare_frames is not None and args.tare_frames < 1):
        raise UsageError("--ridge must be >= 0, --threads and --tare-frames >= 1")
    data_path = Path(args.data)
    if not data_path.is_file():
        raise UsageError(f"--data: {data_path}: no such file")
    base_json = resolve_policy_path(args.policy)
    base_meta = read_metadata(base_json)
    if base_meta.get("kind") == "calibrated":
        raise UsageError(
            f"--policy: {base_json} is itself calibrated; calibrate its base policy "
            f"{(base_meta.get('base_policy') or {}).get('name')!r} instead"
        )
    out = _out_path(args.out)
    check_output(out, "--out")
    # the new policy's name is its file's stem, and its base is named by the base's stem
    check_identifier_arg(out.stem, "--out: policy name")
    check_identifier_arg(base_json.stem, "--policy: base policy name")
    if out.resolve() == base_json.resolve():
        raise UsageError("--out: that is the base policy itself; choose a new name")
    check_new_file(out, "--out", args.force)
    base = load_policy(str(base_json), None, args.threads)

    data = load_data(data_path, args.tare_frames, args.min_pdc, skip_bad_rows=args.skip_bad_rows)
    fit_ids, test_ids = _ids(args.trials), _ids(args.test_trials)
    if set(fit_ids) & set(test_ids):
        raise UsageError("--trials and --test-trials overlap")
    fit = data.select(fit_ids, "--trials") if fit_ids else data
    if not fit_ids and test_ids:
        fit = data.select([t for t in dict.fromkeys(data.trial_id.tolist()) if t not in test_ids], "--trials")
    test = data.select(test_ids, "--test-trials") if test_ids else None
    need = 6 if args.model == "gains" else 30
    if len(fit) < need:
        raise UsageError(f"--data: only {len(fit)} labelled frames in contact to fit on (at least {need} needed)")
    for note in data.notes:
        print(note)

    result = calibrate(policy_directions(base), fit, test, args.model, args.ridge)
    problems = fit_problems(result.correction.matrix, result.metrics)
    if problems and not args.allow_worse:
        raise UsageError(f"calibrate: {'; '.join(problems)}; nothing written (--allow-worse writes it anyway)")
    for problem in problems:
        print(f"WARNING: {problem}; written because of --allow-worse", file=sys.stderr)
    name = out.stem
    labels = (
        "direction only: plate normals in a frame fixed to the mount (unknown rotation and sign); the "
        "mount frame was estimated from the base policy's directions; magnitudes stay the base policy's"
        if data.direction_only
        else "force labels, N, sensor frame"
    )
    calib = {
        "data": {
            "file": str(data_path),
            "sha256": sha256_of(data_path),
            "format": "plate-normal recording" if data.direction_only else "dataset",
            "labels": labels,
            "fit_trials": sorted(set(fit.trial_id.tolist())),
            "n_fit": len(fit),
            "test_trials": sorted(set(test.trial_id.tolist())) if test is not None else [],
            "tare_frames": args.tare_frames,
            "min_pdc": args.min_pdc if data.direction_only else None,
        },
        "ridge": args.ridge if args.model == "residual" else None,
        "metrics": result.metrics,
        "command": "launch.py calibrate " + " ".join(sys.argv[2:]) if len(sys.argv) > 2 else "launch.py calibrate",
    }
    if result.frame is not None:
        calib["label_frame"] = {
            "rotation_sensor_to_mount_rotvec_rad": result.frame.rotation.as_rotvec().tolist(),
            "label_sign": result.frame.sign,
        }
    meta = {
        "name": name,
        "kind": "calibrated",
        "sensor_type": base_meta.get("sensor_type"),
        "description": f"{base_meta.get('name', base_json.stem)} with a per-sensor '{args.model}' correction "
        f"fitted on {data_path.name}",
        "base_policy": {
            "name": base_json.stem,
            # outside the policies folder: remember where it was
            **({} if base_json.parent.resolve() == policies_dir().resolve() else {"path": str(base_json.resolve())}),
            "sha256": {f.name: sha256_of(f) for f in policy_files(base_json, base_meta)},
        },
        "correction": result.correction.describe(),
        "output": {
            "quantity": "f_sensor",
            "units": "N",
            "frame": "sensor",
            "meaning": "force the environment exerts on the sensor skin",
        },
        "has_variance": bool(base.has_variance),
        "calibration": calib,
        "provenance": "fitted by `launch.py calibrate` (grasp_ctrl/evaluation/calibration.py)",
        "licence": "BSD-3-Clause (grasp_ctrl); the base policy's licence applies to it",
    }
    try:
        write_output(out, json.dumps(meta, indent=2) + "\n")  # replaces a symlink there, never writes through
    except OSError as exc:
        raise UsageError(f"--out: {out}: cannot write ({exc.strerror or exc})") from None
    load_policy(str(out), None, args.threads)  # the registry must load what we wrote

    print(
        f"{'set':5s} {'n':>6s} {'':7s} {'median':>7s} {'p75':>7s} {'p90':>7s}  deg"
        + ("   |f_est|/|f| median" if not data.direction_only else "")
    )
    for part, m in result.metrics.items():
        for when in ("before", "after"):
            s = m[when]
            ratio = f"   {s['magnitude_ratio_median']:.2f}" if "magnitude_ratio_median" in s else ""
            print(
                f"{part:5s} {s['n']:6d} {when:7s} {s['median_deg']:7.1f} {s['p75_deg']:7.1f} {s['p90_deg']:7.1f}{ratio}"
            )
    c = result.correction.describe()
    print(
        f"correction '{args.model}': rotation {c['polar_rotation_deg']:.1f} deg, stretch diagonal "
        f"{np.round(np.diag(np.asarray(c['polar_stretch'])), 3).tolist()}"
    )
    in_registry = out.parent.resolve() == policies_dir().resolve()
    print(f"wrote {out} (base {base_json.stem}); use it with --policy {name if in_registry else out}")
    return 0
