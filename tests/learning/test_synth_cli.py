"""``synth``: the simulated dataset written to a file reads back as the same samples, and
``train --data`` on it trains like ``train --synthetic``."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.learning.dataset import read_csv
from grasp_ctrl.learning.synthetic import generate

N, SEED = 60, 5
FIELDS = ("trial_id", "source", "t", "tared", "f_sensor", "projected", "r_world_sensor")


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("synth")
    out = {"raw": d / "raw.csv", "tared": d / "tared.csv"}
    assert main(["synth", "--n", str(N), "--seed", str(SEED), "--out", str(out["raw"]), "--raw"]) == 0
    assert main(["synth", "--n", str(N), "--seed", str(SEED), "--out", str(out["tared"])]) == 0
    return out


@pytest.mark.parametrize("kind", ["raw", "tared"])
def test_file_reads_back_as_the_synthetic_arrays(files: dict[str, Path], kind: str) -> None:
    expected = generate(N, seed=SEED)
    back, bad = read_csv(files[kind])
    assert bad == []
    for field in FIELDS:
        np.testing.assert_array_equal(getattr(back, field), getattr(expected, field), err_msg=field)


def test_raw_trials_start_with_tare_rows_then_the_whole_stream(files: dict[str, Path]) -> None:
    with files["raw"].open() as fh:
        rows = list(csv.DictReader(fh))
    by_trial: dict[str, list[dict[str, str]]] = {}
    for r in rows:
        by_trial.setdefault(r["trial_id"], []).append(r)
    n_samples = len(generate(N, seed=SEED))
    assert len(rows) > n_samples + 10 * len(by_trial)  # ungated frames are in the file too
    for trial_rows in by_trial.values():
        labels = [(r["fx"], r["fy"], r["fz"]) for r in trial_rows]
        n_zero = next(i for i, lab in enumerate(labels) if lab != ("0.0", "0.0", "0.0"))
        assert n_zero >= 10
        assert float(trial_rows[n_zero]["t"]) == 0.0 and float(trial_rows[0]["t"]) < 0


def test_synth_refuses_bad_arguments(files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["synth", "--n", "10", "--out", str(files["raw"])]) == 2  # exists
    assert main(["synth", "--n", "0", "--out", str(tmp_path / "x.csv")]) == 2
    assert main(["synth", "--n", "10", "--sources", "ball", "--out", str(tmp_path / "x.csv")]) == 2
    assert main(["synth", "--n", "10", "--out", str(tmp_path / "nope" / "x.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 4 and all(line.startswith("grasp-ctrl: error:") for line in err)


def _train(args: list[str], capsys: pytest.CaptureFixture) -> str:
    assert main(["train", *args, "--seed", str(SEED), "--quiet"]) == 0
    out = capsys.readouterr().out
    # drop lines with timings and data-source notes, keep the split and the metrics
    return "\n".join(
        ln for ln in out.splitlines() if ln.startswith(("split", "test set", "rigid", "ball", "planar", "mixed"))
    )


def test_train_on_the_raw_file_equals_train_synthetic(
    files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    pytest.importorskip("torch")
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    from_file = _train(["--data", str(files["raw"]), "--arch", "analytic", "--out", str(a)], capsys)
    synthetic = _train(["--synthetic", str(N), "--arch", "analytic", "--out", str(b)], capsys)
    assert from_file == synthetic and "mixed" in from_file
    ga, gb = (json.loads(p.read_text()) for p in (a, b))
    assert ga["gains_n_per_count"] == gb["gains_n_per_count"] and ga["metrics"] == gb["metrics"]
    su = ["--arch", "su", "--epochs", "3", "--batch-size", "64"]
    assert _train(["--data", str(files["raw"]), *su, "--out", str(tmp_path / "a.pt")], capsys) == _train(
        ["--synthetic", str(N), *su, "--out", str(tmp_path / "b.pt")], capsys
    )


def test_train_on_a_hostile_file_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    pytest.importorskip("torch")
    bad = tmp_path / "bad.csv"
    bad.write_bytes(b"trial_id,source,t\n\xff\xfe\x00garbage\n")
    assert main(["train", "--data", str(bad), "--arch", "analytic"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.csv" in err[0]
