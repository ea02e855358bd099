"""``fit-mock-policies``: fit the analytic (Lin et al.), linear-regression and small
MLP policies on simulated presses of the mock world's BioTac model.

The analytic and linear ones are fitted on pad-centre presses (the shipped files).
``--linear-presses mixed`` fits the linear policy on those and as many presses again
anywhere a grasp's contact lands (``sim/presses.skin_presses``: the whole pad, its sides
and the tip cap, shear up to the normal force). ``mlp_mock`` (the default policy) is
fitted on the pad-centre presses and twice as many skin presses, and with
``--grasp-contacts FILE`` (the ``grasp-contacts`` command) twice as many again at the
contacts the hand's grasps make in MuJoCo; it needs torch (the ``train`` extra) and is
left as it is, with a note, without it.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from grasp_ctrl.files.safe_write import check_output, write_output  # noqa: F401

if TYPE_CHECKING:
    from grasp_ctrl.sim.biotac.grasp_contacts import GraspContacts

NAME = "fit-mock-policies"
HELP = "fit the analytic, linear and MLP policies on simulated presses and write their JSON into policies/"
ORDER = 80


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.files.paths import policies_dir

    p.add_argument("--samples", type=int, default=20000, help="simulated presses (default 20000)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--linear-presses",
        choices=("pad", "mixed"),
        default="pad",
        help="linear policy's training presses: pad (pad centre, the shipped fit) or mixed "
        "(as many again anywhere on the skin where grasp contacts land; docs/mujoco.md)",
    )
    p.add_argument(
        "--grasp-contacts",
        metavar="FILE",
        help="mlp_mock: also fit presses at these recorded grasp contacts (a grasp-contacts CSV), twice "
        "--samples of them, each contact's force scaled by 0.25-1.75, half with the shear reversed",
    )
    p.add_argument(
        "--out-dir",
        default=str(policies_dir()),
        help="directory for analytic_mock.json, linear_mock.json and mlp_mock.json",
    )


def _metrics(pred: np.ndarray, f: np.ndarray) -> dict[str, float]:
    cos = np.sum(pred * f, axis=1) / (np.linalg.norm(pred, axis=1) * np.linalg.norm(f, axis=1) + 1e-12)
    angle = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    mag_err = np.abs(np.linalg.norm(pred, axis=1) - np.linalg.norm(f, axis=1))
    return {
        "test_samples": int(len(f)),
        "median_angle_deg": round(float(np.median(angle)), 3),
        "median_magnitude_error_n": round(float(np.median(mag_err)), 4),
    }


def _common(name: str, kind: str, description: str, n_train: int, seed: int) -> dict[str, Any]:
    return {
        "name": name,
        "kind": kind,
        "sensor_type": "biotac",
        "description": description,
        "input": {"kind": "tared_frame", "channels": 44, "tare": "raw - baseline (pressed electrodes negative)"},
        "preprocessing": {"contact_gate": "tared pdc > threshold for N frames (hand config)"},
        "output": {
            "quantity": "f_sensor",
            "units": "N",
            "frame": "sensor",
            "meaning": "force the environment exerts on the sensor skin",
        },
        "has_variance": False,
        "training_data": f"{n_train} simulated pad presses from the mock BioTac model (seed {seed})",
        "provenance": "fitted by `python launch.py fit-mock-policies`",
        "licence": "BSD-3-Clause (this project)",
    }


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.estimators.analytic import AnalyticEstimator, fit_gains
    from grasp_ctrl.estimators.linear import LinearEstimator, fit_linear
    from grasp_ctrl.sim.biotac.presses import pad_presses, skin_presses

    if args.samples < 100:
        raise UsageError("--samples: at least 100")
    out_dir = Path(args.out_dir)
    if not out_dir.is_dir():
        raise UsageError(f"--out-dir: {out_dir} is not a directory")
    from grasp_ctrl.sim.biotac.grasp_contacts import load_contacts

    contacts = load_contacts(args.grasp_contacts)
    tared, f = pad_presses(args.samples, args.seed)
    n_test = max(50, args.samples // 5)
    train, test = slice(n_test, None), slice(0, n_test)
    n_train = args.samples - n_test

    gains = fit_gains(tared[train], f[train])
    analytic = _common(
        "analytic_mock",
        "analytic",
        "Lin et al. (2013) analytic linear model, f = S * sum_i e_i n_i (paper eq. 15)",
        n_train,
        args.seed,
    )
    analytic["gains_n_per_count"] = [float(g) for g in gains]
    analytic["metrics"] = _metrics(AnalyticEstimator(gains).estimate(tared[test], []).f_sensor, f[test])

    linear = _common(
        "linear_mock",
        "linear",
        "linear regression on the 19 tared electrodes, f = W e + b (ridge least squares)",
        n_train,
        args.seed,
    )
    if args.linear_presses == "mixed":
        skin_tared, skin_f = skin_presses(args.samples, args.seed + 1)
        W, b = fit_linear(np.vstack([tared[train], skin_tared[train]]), np.vstack([f[train], skin_f[train]]))
        linear["training_data"] = (
            f"{n_train} simulated pad-centre presses and {n_train} presses anywhere a grasp's "
            f"contact lands (pad, sides, tip cap; shear up to the normal force) from the mock "
            f"BioTac model (seeds {args.seed}, {args.seed + 1})"
        )
        linear["provenance"] = "fitted by `python launch.py fit-mock-policies --linear-presses mixed`"
    else:
        W, b = fit_linear(tared[train], f[train])
    linear["weights_n_per_count"] = W.tolist()
    linear["bias_n"] = b.tolist()
    linear["metrics"] = _metrics(LinearEstimator(W, b).estimate(tared[test], []).f_sensor, f[test])
    if args.linear_presses == "mixed":
        linear["metrics_skin_presses"] = _metrics(
            LinearEstimator(W, b).estimate(skin_tared[test], []).f_sensor, skin_f[test]
        )

    metas = [analytic, linear]
    mlp = _fit_mlp(tared[train], f[train], args.samples, args.seed, n_train, n_test, contacts, args.grasp_contacts)
    if mlp is not None:
        metas.append(mlp)
    for meta in metas:
        path = out_dir / f"{meta['name']}.json"
        write_output(path, json.dumps(meta, indent=2) + "\n")
        m = meta["metrics"]
        print(
            f"{meta['name']}: median angle {m['median_angle_deg']} deg, "
            f"median magnitude error {m['median_magnitude_error_n']} N -> {path}"
        )
    return 0


MLP_CHANNELS = list(range(20))  # the 19 tared electrodes and the tared pdc (config/sensor_layout.py)


def _fit_mlp(
    pad_tared: np.ndarray,
    pad_f: np.ndarray,
    samples: int,
    seed: int,
    n_train: int,
    n_test: int,
    contacts: GraspContacts | None = None,
    contacts_file: str | None = None,
) -> dict[str, Any] | None:
    """``mlp_mock``, or None (with a note) where torch is not installed. The first ``n_test``
    skin presses (and grasp-contact presses) are held out, as many as the pad presses' test split."""
    import sys

    from grasp_ctrl.estimators.mlp import MlpEstimator
    from grasp_ctrl.sim.biotac.presses import skin_presses

    try:
        from grasp_ctrl.learning.mlp_fit import fit_mlp
    except ImportError:
        print("mlp_mock: not refitted (needs torch: pip install -e '.[train]')", file=sys.stderr)
        return None
    skin_tared, skin_f = skin_presses(2 * samples, seed + 2)
    parts_x, parts_f = [pad_tared, skin_tared[n_test:]], [pad_f, skin_f[n_test:]]
    if contacts is not None:
        from grasp_ctrl.sim.biotac.presses import contact_presses

        grasp_tared, grasp_f = contact_presses(contacts, 2 * samples, seed + 3)
        parts_x.append(grasp_tared[n_test:])
        parts_f.append(grasp_f[n_test:])
    x = np.vstack(parts_x)[:, MLP_CHANNELS]
    labels = np.vstack(parts_f)
    meta = _common(
        "mlp_mock", "mlp", "a small MLP (20-64-64-3, tanh) on the 19 tared electrodes and the tared pdc", n_train, seed
    )
    meta["training_data"] = (
        f"{n_train} simulated pad-centre presses and {len(skin_f) - n_test} presses anywhere a "
        f"grasp's contact lands (pad, sides, tip cap; shear up to the normal force) from the mock "
        f"BioTac model (seeds {seed}, {seed + 2})"
    )
    if contacts is not None:
        meta["training_data"] += (
            f", and {2 * samples - n_test} presses at contacts of oracle grasps in MuJoCo "
            f"({contacts.summary()}; forces x 0.25-1.75, half with the shear reversed, seed {seed + 3})"
        )
        meta["provenance"] = (
            "recorded by `python launch.py grasp-contacts --out FILE`, fitted by "
            "`python launch.py fit-mock-policies --grasp-contacts FILE`"
        )
    meta["input_channels"] = MLP_CHANNELS
    meta.update(fit_mlp(x, labels, seed=seed))
    est = MlpEstimator(MLP_CHANNELS, meta["input_mean"], meta["input_scale"], meta["layers"])
    meta["metrics"] = _metrics(est.estimate(skin_tared[:n_test], []).f_sensor, skin_f[:n_test])
    meta["metrics"]["test_presses"] = "skin presses (pad, sides, tip cap)"
    if contacts is not None:
        meta["metrics_grasp_contacts"] = _metrics(est.estimate(grasp_tared[:n_test], []).f_sensor, grasp_f[:n_test])
        meta["metrics_grasp_contacts"]["test_presses"] = (
            f"presses at recorded grasp contacts ({Path(contacts_file or '').name})"
        )
    return meta
