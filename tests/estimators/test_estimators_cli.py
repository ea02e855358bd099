"""Command line: policies, evaluate-direction, convert-icra19 (one-line errors, outputs)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from grasp_ctrl.cli import main
from grasp_ctrl.tactile.features import contact_points, surface_normals


def _write_synthetic_csv(path: Path, rotation: Rotation) -> None:
    """Two trials: 60 free frames, then presses; labels = -R * (force direction of a normal press)."""
    rng = np.random.default_rng(5)
    cols = ["trial_id", "sample_idx", "pdc"] + [f"e{i}" for i in range(1, 20)] + ["nx", "ny", "nz", "in_paper_trial"]
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for trial in ("A", "B"):
            base = np.rint(rng.uniform(2500, 3500, 19))
            for k in range(400):
                press = k >= 60
                depth = rng.uniform(0, 250, 19) * (rng.random(19) < 0.5) if press else np.zeros(19)
                e = np.rint(base - depth)
                pdc = 2400 + (150 if press else 0)
                n = surface_normals(contact_points((e - base)[None]))[0] if press else np.array([0, 0, -1.0])
                label = -rotation.apply(-n)  # label sign -1, as in the real recordings
                w.writerow([trial, k, pdc, *e.astype(int), *label, 1])


def test_evaluate_direction_on_synthetic_recordings(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    csv_path = tmp_path / "rec.csv"
    _write_synthetic_csv(csv_path, Rotation.from_rotvec([0.4, -0.2, 0.9]))
    out = tmp_path / "res.json"
    rc = main(
        [
            "evaluate-direction",
            "--data",
            str(csv_path),
            "--estimators",
            "surface-normal,analytic-unit",
            "--json",
            str(out),
        ]
    )
    assert rc == 0
    doc = json.loads(out.read_text())
    res = {(r["estimator"], r["train"]): r for r in doc["results"]}
    assert len(res) == 4
    for fold in ("A", "B"):
        sn = res[("surface-normal", fold)]
        assert sn["median_deg"] < 1e-3 and sn["p90_deg"] < 1e-3 and sn["label_sign"] == -1.0
        assert sn["n_test"] == 400 - 60 - 9  # the gate needs 10 frames above threshold
        assert res[("analytic-unit", fold)]["median_deg"] > 1.0  # a different estimator, not the labels
    assert "surface-normal" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv,message",
    [
        (["evaluate-direction", "--data", "/nonexistent.csv"], "cannot read"),
        (["evaluate-direction", "--data", "{csv}", "--estimators", "bogus"], "unknown estimator 'bogus'"),
        (["evaluate-direction", "--data", "{csv}", "--trials", "A"], "at least two trials"),
        (["evaluate-direction", "--data", "{csv}", "--estimators", "policy:nope"], "policy 'nope'"),
        (["convert-icra19", "{csv}", "--out", "{tmp}"], "not a .npz weight file"),
    ],
)
def test_bad_input_gives_one_line_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    csv_path = tmp_path / "rec.csv"
    _write_synthetic_csv(csv_path, Rotation.identity())
    argv = [a.format(csv=csv_path, tmp=tmp_path) for a in argv]
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc != 0
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_policies_lists_the_official_networks(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "p.json"
    assert main(["policies", "--check", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "icra19_official" in text and "[loads]" in text
    doc = json.loads(out.read_text())
    meta = doc["icra19_official"]
    assert meta["output"]["to_f_sensor"] == -1.0 and meta["licence"].startswith("BSD")
    assert meta["provenance"]["source"].endswith("balakumar-s/biotac_force_net")
    assert doc["icra19_dropout_official"]["has_variance"] is True


def test_evaluate_direction_prints_the_pooled_two_fold_figure(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from grasp_ctrl.evaluation.direction import evaluate, gate_trial, pooled_percentiles
    from grasp_ctrl.evaluation.robotic_finger import read_trials

    csv_path = tmp_path / "rec.csv"
    _write_synthetic_csv(csv_path, Rotation.from_rotvec([0.4, -0.2, 0.9]))
    out = tmp_path / "res.json"
    assert (
        main(["evaluate-direction", "--data", str(csv_path), "--estimators", "analytic-unit", "--json", str(out)]) == 0
    )
    doc = json.loads(out.read_text())
    folds = [r for r in doc["results"] if r["estimator"] == "analytic-unit"]
    pooled = doc["pooled"]["analytic-unit"]
    assert pooled["n_test"] == sum(r["n_test"] for r in folds)
    assert min(r["median_deg"] for r in folds) <= pooled["median_deg"] <= max(r["median_deg"] for r in folds)
    assert pooled["median_deg"] <= pooled["p75_deg"] <= pooled["p90_deg"]
    line = next(ln for ln in capsys.readouterr().out.splitlines() if "pooled, both folds" in ln)
    assert f"{pooled['median_deg']:.1f}" in line and str(pooled["n_test"]) in line
    # pooled = percentiles of both folds' test angles together
    from grasp_ctrl.estimators.analytic import electrode_normal_sums

    samples = [gate_trial(t) for t in read_trials(csv_path)]
    results = evaluate("analytic-unit", samples, electrode_normal_sums)
    angles = np.concatenate([r.angles for r in results])
    n, pc = pooled_percentiles(results)
    assert n == len(angles) and pc[75] == pytest.approx(np.percentile(angles, 75))
    assert results[0].percentiles[50] == pytest.approx(np.median(results[0].angles))
