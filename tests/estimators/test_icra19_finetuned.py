"""The authors' network fine-tuned for the simulated BioTac (``icra19_finetuned_mock``,
docs/learning.md "Fine-tuning the authors' network for the simulated sensor"), and
``train --init-from icra19_official`` reading the authors' weights back from the converted policy.

Skipped where onnxruntime (or, for the weights test, torch) or the policy files are absent.
"""

from __future__ import annotations

import numpy as np
import pytest

from grasp_ctrl.files.paths import REPO_ROOT

ort = pytest.importorskip("onnxruntime")

POLICIES = REPO_ROOT / "policies"
FINETUNED = "icra19_finetuned_mock"
OFFICIAL = "icra19_official"
FRESH_SEED = 11  # the fine-tuning data used seed 3; voxel_alpha_mixed_mock seed 0; the anchors seed 7


def _need(*names: str) -> None:
    for name in names:
        if not (POLICIES / f"{name}.json").is_file() or not (POLICIES / f"{name}.onnx").is_file():
            pytest.skip(f"policies/{name}.json/.onnx not present")


def _angle_and_log_ratio(f_est: np.ndarray, f_true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n_est, n_true = np.linalg.norm(f_est, axis=1), np.linalg.norm(f_true, axis=1)
    cos = np.sum(f_est * f_true, axis=1) / (n_est * n_true)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))), np.log(n_est / n_true)


def test_finetuned_policy_reads_fresh_rigid_ft_presses_better_than_the_authors_network() -> None:
    """300+ simulated rigid-ft presses from a seed used by no training (11), both policies
    through the registry. Measured 2026-11-23 (315 samples): median angle error
    icra19_official 14.5 deg, icra19_finetuned_mock 4.6 deg; spread of the magnitude ratio
    |f_est| / |f| as the interquartile range of its log: 1.11 (the ratio's 10th to 90th
    percentile 0.53 to 4.56) against 0.069 (0.92 to 1.07); median ratio 0.97 and 1.00.
    Asserted with margin: the fine-tuned angle below half the official one, the spread
    below a third, the median ratio within 0.8 to 1.25."""
    _need(FINETUNED, OFFICIAL)
    from grasp_ctrl.estimators.registry import load_policy
    from grasp_ctrl.learning.synthetic import generate_source, mock_biotac_forward

    ds = generate_source("rigid-ft", 300, mock_biotac_forward(), np.random.default_rng(FRESH_SEED))
    fingers = ["index"] * len(ds.f_sensor)
    figures = {}
    for name in (OFFICIAL, FINETUNED):
        angle, log_ratio = _angle_and_log_ratio(load_policy(name).estimate(ds.tared, fingers).f_sensor, ds.f_sensor)
        q1, q3 = np.percentile(log_ratio, [25, 75])
        figures[name] = (float(np.median(angle)), float(q3 - q1), float(np.exp(np.median(log_ratio))))
    (off_angle, off_spread, _), (ft_angle, ft_spread, ft_ratio) = figures[OFFICIAL], figures[FINETUNED]
    assert off_angle > 10.0 and off_spread > 0.8  # the problem it fixes is still there
    assert ft_angle < 0.5 * off_angle, figures
    assert ft_spread < off_spread / 3.0, figures
    assert 0.8 < ft_ratio < 1.25, figures  # and it reads the scale right


def test_finetuned_policy_metadata_says_what_it_is() -> None:
    _need(FINETUNED)
    import json

    meta = json.loads((POLICIES / f"{FINETUNED}.json").read_text())
    text = meta["description"]
    for words in (OFFICIAL, "simulated", "seed 3", "epochs"):
        assert words in text, (words, text)
    assert meta["training"]["init_from"] == OFFICIAL


def test_init_from_the_converted_policy_gives_the_authors_network() -> None:
    """The weights read back from icra19_official.onnx (what ``train --init-from icra19_official``
    starts from) reproduce that policy's own onnxruntime output."""
    torch = pytest.importorskip("torch")
    _need(OFFICIAL)
    from grasp_ctrl.learning.features import model_inputs
    from grasp_ctrl.learning.models import ForceNet
    from grasp_ctrl.learning.official import official_arrays_from_onnx, official_state_dict

    onnx_path = POLICIES / f"{OFFICIAL}.onnx"
    model = ForceNet("voxel")
    model.load_state_dict(official_state_dict(official_arrays_from_onnx(onnx_path)))
    model.eval()
    rng = np.random.default_rng(0)
    tared = np.zeros((40, 44))
    tared[:, :19] = -np.abs(rng.normal(0, 300, (40, 19)))
    x = model_inputs(tared)
    with torch.no_grad():
        ours = model(torch.tensor(x["electrode_voxels"]), torch.tensor(x["contact_voxels"])).numpy()
    sess = ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
    force = sess.run(["force"], {k: x[k].astype(np.float32) for k in ("electrode_voxels", "contact_voxels")})[0]
    np.testing.assert_allclose(ours, -force, atol=1e-4 * max(1.0, float(np.abs(force).max())))  # ours: f_sensor


def test_init_from_refuses_the_dropout_network() -> None:
    _need("icra19_dropout_official")
    pytest.importorskip("torch")
    from grasp_ctrl.learning.official import official_arrays_from_onnx

    with pytest.raises(ValueError, match="dropout"):
        official_arrays_from_onnx(POLICIES / "icra19_dropout_official.onnx")


def test_train_init_from_icra19_official_runs(tmp_path) -> None:
    pytest.importorskip("torch")
    _need(OFFICIAL)
    from grasp_ctrl.cli import main

    ckpt = tmp_path / "ft.pt"
    assert (
        main(
            [
                "train",
                "--synthetic",
                "150",
                "--seed",
                "5",
                "--test-per-source",
                "60",
                "--arch",
                "voxel",
                "--epochs",
                "1",
                "--init-from",
                OFFICIAL,
                "--out",
                str(ckpt),
                "--quiet",
            ]
        )
        == 0
    )
    import torch

    assert torch.load(ckpt, weights_only=True)["init_from"] == OFFICIAL
    assert (
        main(
            [
                "train",
                "--synthetic",
                "150",
                "--seed",
                "5",
                "--arch",
                "su",
                "--epochs",
                "1",
                "--init-from",
                OFFICIAL,
                "--quiet",
            ]
        )
        == 2
    )
