"""``calibrate``: a correction on top of a policy, fitted on a sensor that differs from the
one the policy was made for, loaded back through the registry."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from grasp_ctrl.cli import main
from grasp_ctrl.cli.cmd_calibrate import MODELS as CLI_MODELS
from grasp_ctrl.errors import PolicyError
from grasp_ctrl.estimators.linear import fit_linear
from grasp_ctrl.estimators.registry import load_policy
from grasp_ctrl.evaluation.calibration import MODELS, Correction, fit_correction
from grasp_ctrl.evaluation.direction import angles_deg
from grasp_ctrl.learning.dataset import write_raw_csv
from grasp_ctrl.learning.synthetic import generate, generate_trials, mock_biotac_forward

# The other sensor: 1.4 times more sensitive (every signal's deviation from rest), and mounted
# rolled by 20 deg with per-axis gains relative to the frame its force labels come in
SIGNAL_GAIN = 1.4
LABEL_MAP = Rotation.from_rotvec([np.radians(20.0), 0.0, 0.0]).as_matrix() @ np.diag([1.3, 0.8, 1.0])
RIGID = ("rigid-ft",)


def _more_sensitive():
    nominal = mock_biotac_forward()

    def forward(p: np.ndarray, f: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        raw = nominal(p, f, rng)
        rest = raw[np.linalg.norm(f, axis=1) == 0].mean(axis=0)
        return rest + SIGNAL_GAIN * (raw - rest)

    return forward


@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> dict:
    d = tmp_path_factory.mktemp("calib")
    # a base policy made for the nominal sensor: a linear fit to its presses
    nominal = generate(3000, seed=11, sources=RIGID)
    w, b = fit_linear(nominal.tared, nominal.f_sensor)
    base = {
        "name": "base_lin",
        "kind": "linear",
        "sensor_type": "biotac",
        "has_variance": False,
        "weights_n_per_count": w.tolist(),
        "bias_n": b.tolist(),
    }
    (d / "base_lin.json").write_text(json.dumps(base))
    other = _more_sensitive()
    rows = [t.raw_rows() for t in generate_trials(3000, seed=12, forward=other, sources=RIGID)]
    for r in rows:
        r.f_sensor = r.f_sensor @ LABEL_MAP.T  # 0 0 0 tare rows and NaN (no label) stay so
    write_raw_csv(d / "mysensor.csv", rows)
    test = generate(3000, seed=13, forward=other, sources=RIGID)
    test.f_sensor = test.f_sensor @ LABEL_MAP.T
    return {"dir": d, "test": test}


def _median_angle(policy: str, test) -> float:
    f = load_policy(policy).estimate(test.tared, ["f"] * len(test)).f_sensor
    return float(np.median(angles_deg(f, test.f_sensor)))


@pytest.mark.parametrize("model", ["gains", "residual"])
def test_calibration_fixes_a_sensor_with_other_gains(sim: dict, model: str, capsys: pytest.CaptureFixture) -> None:
    d = sim["dir"]
    out = d / f"base_lin_mysensor_{model}.json"
    assert (
        main(
            [
                "calibrate",
                "--data",
                str(d / "mysensor.csv"),
                "--policy",
                str(d / "base_lin.json"),
                "--out",
                str(out),
                "--model",
                model,
            ]
        )
        == 0
    )
    assert "wrote" in capsys.readouterr().out
    before = _median_angle(str(d / "base_lin.json"), sim["test"])
    after = _median_angle(str(out), sim["test"])
    print(f"{model}: median direction error on the other sensor {before:.1f} deg before, {after:.1f} deg after")
    # the residual model is the documented recipe; the output-only gains model cannot undo a
    # sensitivity change of a nonlinear sensor exactly, but must still cut the error a lot
    assert before > after + 5.0
    if model == "residual":
        assert after < 10.0
    meta = json.loads(out.read_text())
    assert meta["kind"] == "calibrated" and meta["base_policy"]["name"] == "base_lin"
    assert len(meta["calibration"]["data"]["sha256"]) == 64 and "base_lin.json" in meta["base_policy"]["sha256"]
    fit = meta["calibration"]["metrics"]["fit"]
    assert fit["after"]["median_deg"] < fit["before"]["median_deg"]


def test_base_policy_must_not_change(sim: dict, tmp_path: Path) -> None:
    d = sim["dir"]
    base = json.loads((d / "base_lin.json").read_text())
    (tmp_path / "base_lin.json").write_text(json.dumps(base))
    out = tmp_path / "cal.json"
    assert (
        main(
            [
                "calibrate",
                "--data",
                str(d / "mysensor.csv"),
                "--policy",
                str(tmp_path / "base_lin.json"),
                "--out",
                str(out),
                "--model",
                "linear",
            ]
        )
        == 0
    )
    load_policy(str(out))
    base["bias_n"] = [0.0, 0.0, 0.1]
    (tmp_path / "base_lin.json").write_text(json.dumps(base))
    with pytest.raises(PolicyError, match="changed since the calibration"):
        load_policy(str(out))
    # refused: calibrating a calibrated policy, overwriting, the base as output
    assert (
        main(["calibrate", "--data", str(d / "mysensor.csv"), "--policy", str(out), "--out", str(tmp_path / "x.json")])
        == 2
    )
    assert (
        main(
            [
                "calibrate",
                "--data",
                str(d / "mysensor.csv"),
                "--policy",
                str(tmp_path / "base_lin.json"),
                "--out",
                str(out),
            ]
        )
        == 2
    )
    assert (
        main(["calibrate", "--data", str(d / "nope.csv"), "--policy", "linear_mock", "--out", str(tmp_path / "y.json")])
        == 2
    )
    meta = json.loads(out.read_text())
    meta["correction"]["matrix"] = [[1, 0], [0, 1]]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**meta, "base_policy": {"name": "linear_mock"}}))
    with pytest.raises(PolicyError, match="correction"):
        load_policy(str(bad))


def test_correction_models_recover_a_known_map() -> None:
    assert CLI_MODELS == MODELS
    rng = np.random.default_rng(0)
    f_base = rng.normal(size=(400, 3)) + [0, 0, 3]
    tared = np.zeros((400, 44))
    tared[:, :19] = rng.normal(0, 100, (400, 19))
    a = Rotation.from_rotvec([0.1, -0.2, 0.3]).as_matrix() @ np.diag([1.5, 0.8, 1.1])
    w = rng.normal(0, 1e-3, (3, 19))
    for model, target in (
        ("gains", f_base @ a.T),
        ("linear", f_base @ a.T),
        ("affine", f_base @ a.T + [0.1, 0, -0.2]),
        ("residual", f_base @ a.T + tared[:, :19] @ w.T + [0.1, 0, -0.2]),
    ):
        corr = fit_correction(f_base, tared, target, model, ridge=0.0)
        assert isinstance(corr, Correction)
        np.testing.assert_allclose(corr.apply(f_base, tared), target, atol=1e-6, err_msg=model)


def test_real_biotac_calibration_beats_the_official_net(
    shared_data: Path, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """icra19_official calibrated on the long trial A, tested on B (plate normals, direction only)."""
    from grasp_ctrl.evaluation.direction import evaluate, gate_trial, policy_directions
    from grasp_ctrl.evaluation.robotic_finger import read_trials

    data = shared_data / "robotic_finger" / "robotic_finger_tidy.csv"
    trial_a, trial_b = "15330_1571242563995", "15834_1571243162016"
    out = tmp_path / "icra19_official_mysensor.json"
    assert (
        main(
            [
                "calibrate",
                "--data",
                str(data),
                "--policy",
                "icra19_official",
                "--out",
                str(out),
                "--trials",
                trial_a,
                "--test-trials",
                trial_b,
            ]
        )
        == 0
    )
    capsys.readouterr()
    meta = json.loads(out.read_text())
    test = meta["calibration"]["metrics"]["test"]
    # evaluate-direction's protocol on the calibrated policy: rotation fitted on A, tested on B
    trials = {t.trial_id: t for t in read_trials(data)}
    samples = [gate_trial(trials[t], 50, 10.0, 10, 50.0) for t in (trial_a, trial_b)]
    a_to_b = {
        name: next(
            r for r in evaluate(name, samples, policy_directions(load_policy(spec))) if r.train == trial_a
        ).percentiles[50]
        for name, spec in (("base", "icra19_official"), ("calibrated", str(out)))
    }
    print(
        f"A -> B median angle: icra19_official {a_to_b['base']:.1f} deg, calibrated {a_to_b['calibrated']:.1f} deg "
        f"(calibrate's own test figure {test['before']['median_deg']:.1f} -> {test['after']['median_deg']:.1f})"
    )
    assert 14.0 < a_to_b["base"] < 20.0
    assert a_to_b["calibrated"] < 10.0 and test["after"]["median_deg"] < 10.0
