"""Trial records, run.json and summary.json are strict JSON: a non-finite number (a policy with
a huge but finite bias makes infinite peak forces) is written as null, and the record says
which values were not finite under ``non_finite``, so every reader still loads it."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.files.paths import default_hand_file, default_objects_file
from grasp_ctrl.files.storage import NON_FINITE_KEY, write_json
from grasp_ctrl.trials.episode import runner as episode_runner
from grasp_ctrl.trials.runs.records import read_record


def _strict(path: Path) -> Any:
    """``path`` parsed as JSON that has no NaN or Infinity (Python's json accepts them)."""

    def refuse(name: str) -> None:
        raise ValueError(f"{path}: {name} is not JSON")

    return json.loads(path.read_text(), parse_constant=refuse)


def test_write_json_turns_non_finite_numbers_into_null_and_names_them(tmp_path: Path) -> None:
    record = {
        "policy": "huge_bias",
        "object": "lego",
        "trial": 0,
        "seed": 7,
        "success": False,
        "reason": "overforce",
        "peak_grip_est_n": math.inf,
        "peak_forces": {"index": {"force_est_n": -math.inf, "grip_est_n": 1.5}},
        "transitions": [(0.5, "ramp", "fault"), (math.nan, "fault", "fault")],
        "sim_duration_s": 2.0,
    }
    path = tmp_path / "trials" / "huge_bias" / "lego" / "trial_000.json"
    path.parent.mkdir(parents=True)
    write_json(path, record)
    doc = _strict(path)
    assert doc["peak_grip_est_n"] is None and doc["peak_forces"]["index"] == {"force_est_n": None, "grip_est_n": 1.5}
    assert doc["transitions"] == [[0.5, "ramp", "fault"], [None, "fault", "fault"]]
    assert doc[NON_FINITE_KEY] == {
        "peak_grip_est_n": "inf",
        "peak_forces.index.force_est_n": "-inf",
        "transitions[1][0]": "nan",
    }
    assert record["peak_grip_est_n"] == math.inf and NON_FINITE_KEY not in record  # the caller's dict as it was
    rec, why = read_record(path)
    assert why is None and rec is not None and rec["sim_duration_s"] == 2.0
    write_json(path, {**rec, "extra": math.nan})  # written again: what it said is kept
    assert _strict(path)[NON_FINITE_KEY] == {**doc[NON_FINITE_KEY], "extra": "nan"}


def test_a_run_whose_records_hold_infinities_writes_strict_json_that_score_reads(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def trial_fn(hand, policies, settings=None, threads=1, **_kw):  # a huge-bias policy's records
        def run(policy, obj, k, seed, log):
            return {
                "object": obj.name,
                "policy": policy,
                "trial": k,
                "seed": seed,
                "success": False,
                "reason": "overforce",
                "peak_grip_est_n": math.inf,
                "peak_forces": {"index": {"force_est_n": math.inf}},
                "events": [{"t": 1.0, "kind": "crushed", "detail": ""}],
            }

        return run

    monkeypatch.setattr(episode_runner, "sim_trial_fn", trial_fn)
    run_dir = tmp_path / "run"
    argv = ["run", "--backend", "mock", "--objects", "lego", "--trials", "2", "--quiet", "--no-tick-logs"]
    argv += ["--hand", str(default_hand_file()), "--object-file", str(default_objects_file()), "--out", str(run_dir)]
    assert main(argv) == 0
    records = sorted(run_dir.glob("trials/*/*/trial_*.json"))
    assert len(records) == 2
    for path in [run_dir / "run.json", run_dir / "summary.json", *records]:
        _strict(path)  # no NaN or Infinity anywhere
    rec = _strict(records[0])
    assert rec["peak_grip_est_n"] is None
    assert rec[NON_FINITE_KEY] == {"peak_grip_est_n": "inf", "peak_forces.index.force_est_n": "inf"}
    capsys.readouterr()
    out = tmp_path / "scored.json"
    assert main(["score", str(run_dir), "--json", str(out)]) == 0
    err = capsys.readouterr().err
    assert "skipped" not in err and "differs" not in err and "Traceback" not in err
    assert _strict(out)["policies"]
