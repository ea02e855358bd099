"""Operator labels at a prompt, driven by scripted input."""

from __future__ import annotations

import io
import json

import pytest

from grasp_ctrl.trials.episode.labelling import FAILURE_REASONS, Label, OperatorLabeller, OperatorQuit, labelled
from grasp_ctrl.trials.runs.records import check_record, load_records
from grasp_ctrl.trials.runs.scoring import score_run
from grasp_ctrl.trials.runs.series import run_series


def _observed(success: bool, reason: str | None = None) -> dict:
    return {
        "controller": {"final_state": "done" if success else "fault", "success": success, "reason": reason},
        "peak_grip_est_n": 2.04,
    }


def _labeller(script: str) -> tuple[OperatorLabeller, io.StringIO]:
    out = io.StringIO()
    return OperatorLabeller(io.StringIO(script), out), out


def test_success_with_a_note():
    lab, out = _labeller("s\nclean place\n")
    assert lab.label("linear / lego / trial 0", _observed(True)) == Label(True, None, "clean place")
    shown = out.getvalue()
    assert "linear / lego / trial 0" in shown and "says success" in shown and "2.04 N" in shown


def test_failure_reason_by_number_and_by_word():
    lab, _ = _labeller("f\n2\n\n")
    assert lab.label("t", _observed(True)) == Label(False, FAILURE_REASONS[1], "")
    lab, _ = _labeller("failure\ntipped_sideways\nbumped the can\n")
    assert lab.label("t", _observed(True)) == Label(False, "tipped_sideways", "bumped the can")


def test_enter_accepts_the_controllers_own_verdict():
    lab, _ = _labeller("\n\n\n")
    assert lab.label("t", _observed(False, "ramp_timeout")) == Label(False, "ramp_timeout", "")
    lab, _ = _labeller("\n\n")
    assert lab.label("t", _observed(True)) == Label(True, None, "")


def test_bad_answers_are_asked_again():
    lab, out = _labeller("maybe\nf\n99\nNot A Word!\nslipped\n\n")
    assert lab.label("t", _observed(True)) == Label(False, "slipped", "")
    text = out.getvalue()
    assert "please answer s, f or q" in text and "snake_case" in text


@pytest.mark.parametrize("script", ["q\n", "", "f\n"])
def test_quit_or_end_of_input_stops_the_run(script):
    lab, _ = _labeller(script)
    with pytest.raises(OperatorQuit):
        lab.label("t", _observed(True))


def _fake_hardware_trial(policy, obj, trial, seed, log_path):
    """Stands in for the real-hand trial: the controller thinks every trial went well."""
    return {
        "object": obj.name,
        "policy": policy,
        "trial": trial,
        "seed": seed,
        "success": True,
        "reason": None,
        "final_state": "done",
        "backend": "dynamixel",
        "judged_by": "controller",
        "controller": {"final_state": "done", "success": True, "reason": None},
        "peak_grip_est_n": 1.9,
    }


def test_labelled_series_keeps_label_and_controller_view_and_resumes(tmp_path, hand, objects):
    run_dir = tmp_path / "hw"
    profiles = [objects["lego"], objects["cleanser"]]
    # First trial: the operator saw a slip the controller missed; then quits.
    lab, _ = _labeller("f\nslipped\nfell at the top\nq\n")
    with pytest.raises(OperatorQuit):
        run_series(
            hand,
            profiles,
            ["linear_mock"],
            1,
            3,
            run_dir,
            progress=False,
            tick_logs=False,
            trial_fn=labelled(_fake_hardware_trial, lab),
            backend="dynamixel",
        )
    (rec,) = load_records(run_dir).records
    assert (rec["success"], rec["reason"], rec["note"], rec["judged_by"]) == (
        False,
        "slipped",
        "fell at the top",
        "operator",
    )
    assert rec["controller"] == {"final_state": "done", "success": True, "reason": None}
    assert check_record(rec) is None
    lab, _ = _labeller("s\n\n")
    summary = run_series(
        hand,
        profiles,
        ["linear_mock"],
        1,
        3,
        run_dir,
        progress=False,
        tick_logs=False,
        trial_fn=labelled(_fake_hardware_trial, lab),
        backend="dynamixel",
        resume=True,
    )
    assert summary["backend"] == "dynamixel"
    objs = summary["policies"]["linear_mock"]["objects"]
    assert objs["lego"]["failures"] == {"slipped": 1} and objs["cleanser"]["successes"] == 1
    assert score_run(run_dir).summary == json.loads((run_dir / "summary.json").read_text())
