"""The capacity preflight of ``run``: before any trial, the statics at the configured currents and
grip targets name each object the grasp cannot carry (ratio, what binds); a Dynamixel hand
(real or emulated) refuses such an object unless --force, a simulated run flags it in summary.json."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.files.paths import default_hand_file
from grasp_ctrl.trials.episode.capacity_check import (
    CapacityRefused,
    check_object,
    check_objects,
    preflight_capacity,
)


def _halved_hand(tmp_path: Path) -> Path:
    """The shipped hand file with every current limit halved."""
    text = default_hand_file().read_text()
    halved = re.sub(r"current_limit_a = ([0-9.]+)", lambda m: f"current_limit_a = {float(m.group(1)) / 2:g}", text)
    assert halved.count("current_limit_a = 0.275") == 15 and "current_limit_a = 0.6" in halved
    path = tmp_path / "half_current.toml"
    path.write_text(halved)
    return path


def test_the_shipped_hand_carries_every_default_object(hand, objects):
    for v in check_objects(hand, list(objects.values())):
        assert v.carried, v.line()


def test_two_newtons_of_equal_grip_cannot_carry_the_heavy_boxes(hand, objects):
    """The grip targets count, not only the currents: at tau 2 N, all pads equal, the thumb's
    grip binds and the heavy boxes are short, as MuJoCo shows (they slip at lift-off)."""
    for name in ("cleanser", "mustard_bottle"):
        v = check_object(hand, objects[name].with_params(tau_n=2.0, grip_targets="equal"))
        assert not v.carried and v.ratio < 0.8, v.line()
        assert "thumb's grip target 2.00 N" in v.binding


def test_halved_currents_name_the_cleanser_and_the_binding_joint(tmp_path, objects):
    from grasp_ctrl.config.hand import load_hand

    v = check_object(load_hand(_halved_hand(tmp_path)), objects["cleanser"])
    assert not v.carried
    assert re.search(r"\w+_(mcp|pip|dip|ipl|axl|cmc) at 0\.\d+ A", v.binding), v.binding


def test_refused_on_a_hand_unless_forced(hand, objects):
    short = objects["cleanser"].with_params(tau_n=2.0, grip_targets="equal")
    said: list[str] = []
    with pytest.raises(CapacityRefused, match=r"capacity: cleanser: the grasp carries 0\.\d\dx its weight"):
        preflight_capacity(hand, [short], None, on_hand=True, force=False, say=said.append)
    assert [v.object for v in preflight_capacity(hand, [short], None, on_hand=True, force=True, say=said.append)] == [
        "cleanser"
    ]
    assert [
        v.object
        for v in preflight_capacity(hand, [short, objects["lego"]], None, on_hand=False, force=False, say=said.append)
    ] == ["cleanser"]
    assert all(line.startswith("capacity: cleanser") for line in said)


def test_a_simulated_run_names_the_problem_and_flags_the_summary(tmp_path, capsys):
    run_dir = tmp_path / "run"
    assert (
        main(
            [
                "run",
                "--backend",
                "mock",
                "--hand",
                str(_halved_hand(tmp_path)),
                "--objects",
                "cleanser",
                "--trials",
                "1",
                "--out",
                str(run_dir),
                "--quiet",
                "--no-tick-logs",
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "capacity: cleanser: the grasp carries" in err and "Traceback" not in err
    flagged = json.loads((run_dir / "summary.json").read_text())["capacity_short"]
    assert [f["object"] for f in flagged] == ["cleanser"] and flagged[0]["ratio"] < 1.0


def test_the_default_world_runs_it_too(tmp_path, capsys):
    """The issue's check: a hand file with every current limit halved, ``run --objects cleanser``
    (the default backend, MuJoCo) names the capacity problem, no traceback."""
    run_dir = tmp_path / "run"
    assert (
        main(
            [
                "run",
                "--hand",
                str(_halved_hand(tmp_path)),
                "--objects",
                "cleanser",
                "--trials",
                "1",
                "--out",
                str(run_dir),
                "--quiet",
                "--no-tick-logs",
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "capacity: cleanser" in err and "Traceback" not in err
    assert json.loads((run_dir / "summary.json").read_text())["backend"] == "mujoco"


@pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs POSIX pseudo-terminals")
def test_an_emulated_dynamixel_hand_refuses_it_before_any_trial(tmp_path, capsys):
    run_dir = tmp_path / "emu"
    assert (
        main(
            [
                "run",
                "--backend",
                "dynamixel",
                "--emulate",
                "--hand",
                str(_halved_hand(tmp_path)),
                "--objects",
                "cleanser",
                "--trials",
                "1",
                "--yes",
                "--out",
                str(run_dir),
                "--quiet",
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert "error: capacity: cleanser: the grasp carries" in err and "--force" in err
    assert "pre-flight:" not in err and not run_dir.exists()


def test_a_mujoco_summary_has_no_test_double_flag_and_a_mock_one_has(tmp_path, capsys):
    for backend in ("mujoco", "mock"):
        run_dir = tmp_path / backend
        assert (
            main(
                [
                    "run",
                    "--backend",
                    backend,
                    "--objects",
                    "lego",
                    "--trials",
                    "1",
                    "--out",
                    str(run_dir),
                    "--quiet",
                    "--no-tick-logs",
                ]
            )
            == 0
        )
        doc = json.loads((run_dir / "summary.json").read_text())
        assert doc.get("test_double", False) is (backend == "mock")
        assert "capacity_short" not in doc
        assert ("test double" in capsys.readouterr().out) is (backend == "mock")
