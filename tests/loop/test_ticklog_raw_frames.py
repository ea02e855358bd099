"""A mock run's tick logs: the joint currents always, every raw frame whole with ``--raw-frames``,
both equal to what the world's sensors and servos produced at each tick; the option is recorded
in run.json and kept on ``--resume``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.errors import UsageError
from grasp_ctrl.loop.ticklog import raw_frame_columns, read_tick_log, rounded_float32
from grasp_ctrl.sim.mock.world import MockWorld
from grasp_ctrl.trials.runs.manifest import RunManifest

FINGERS = ("index", "middle", "ring", "thumb")
TRIAL = Path("trials") / "oracle" / "lego"


def _run(run_dir: Path, *extra: str) -> int:
    argv = ["run", "--backend", "mock", "--objects", "lego", "--policy", "oracle", "--trials", "1"]
    return main([*argv, "--out", str(run_dir), "--quiet", "--jobs", "1", *extra])


def _watch_the_world(monkeypatch: pytest.MonkeyPatch) -> list[tuple[np.ndarray, np.ndarray]]:
    """(frames, joint currents) of every tick as the mock world made them, taken where each tick
    (fused or generic) sets the world's phase, after its step: independent of the tick log's code."""
    seen: list[tuple[np.ndarray, np.ndarray]] = []
    real = MockWorld.set_phase

    def set_phase(world: MockWorld, phase: str) -> None:
        p = world.params  # the mock servo: current = stiffness * (servo - joint) / torque constant
        seen.append(
            (world.raw.copy(), p.servo_stiffness_nm_per_rad * (world.q_servo - world.q) / world.torque_per_amp_nm)
        )
        real(world, phase)

    monkeypatch.setattr(MockWorld, "set_phase", set_phase)
    return seen


def test_a_run_with_raw_frames_logs_the_sensors_frames_and_the_servos_currents(tmp_path, monkeypatch) -> None:
    seen = _watch_the_world(monkeypatch)
    run_dir = tmp_path / "run"
    assert _run(run_dir, "--raw-frames") == 0
    assert json.loads((run_dir / "run.json").read_text())["raw_frames"] is True
    header, cols = read_tick_log(run_dir / TRIAL / "trial_000_ticks.parquet")
    n = len(cols["t"])
    assert n == len(seen) > 100
    frames = np.stack([f for f, _ in seen])  # (ticks, fingers, 44)
    for i, finger in enumerate(FINGERS):
        logged = np.stack([cols[c] for c in raw_frame_columns(finger)], axis=1)
        assert np.array_equal(logged, frames[:, i])
        assert np.allclose(cols[f"{finger}_raw_e_mean"], logged[:, :19].mean(axis=1), rtol=2e-5)  # the summary stays
    currents = np.stack([c for _, c in seen])
    logged = np.stack([cols[f"current{j}"] for j in range(currents.shape[1])], axis=1)
    assert np.array_equal(logged, rounded_float32(currents)) and np.abs(logged).max() > 0.01
    assert f"current{currents.shape[1]}" not in header

    # resumed, the run keeps them: the trial whose record is gone runs again with its frames
    (run_dir / TRIAL / "trial_000.json").unlink()
    (run_dir / TRIAL / "trial_000_ticks.parquet").unlink()
    assert main(["run", "--resume", str(run_dir), "--quiet", "--jobs", "1"]) == 0
    again = read_tick_log(run_dir / TRIAL / "trial_000_ticks.parquet")[1]
    assert all(np.array_equal(again[c], cols[c]) for c in raw_frame_columns("thumb"))


def test_without_the_option_the_log_keeps_the_summary_and_the_currents(tmp_path, monkeypatch, capsys) -> None:
    seen = _watch_the_world(monkeypatch)
    run_dir = tmp_path / "run"
    assert _run(run_dir) == 0
    assert json.loads((run_dir / "run.json").read_text())["raw_frames"] is False
    header, cols = read_tick_log(run_dir / TRIAL / "trial_000_ticks.parquet")
    assert "index_raw_e1" not in header and "index_raw_pac_std" in header
    assert np.array_equal(cols["thumb_raw_pdc"], [f[3, 19] for f, _ in seen])
    assert np.array_equal(cols["current5"], rounded_float32(np.array([c[5] for _, c in seen])))
    capsys.readouterr()
    assert main(["run", "--resume", str(run_dir), "--raw-frames"]) == 2  # run.json decides
    assert "drop --raw-frames" in capsys.readouterr().err
    assert _run(tmp_path / "r", "--raw-frames", "--no-tick-logs") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--no-tick-logs" in err[0] and not (tmp_path / "r").exists()


def test_run_json_from_before_the_option_resumes_without_frames(tmp_path) -> None:
    from grasp_ctrl.config.objects import load_objects
    from grasp_ctrl.files.paths import default_objects_file

    lego = load_objects(default_objects_file())["lego"]
    doc = RunManifest("mock", "leap", 0, 1, ["oracle"], [lego], raw_frames=True).to_json()
    assert RunManifest.from_json(doc, "run.json").raw_frames is True
    del doc["raw_frames"]
    assert RunManifest.from_json(doc, "run.json").raw_frames is False
    with pytest.raises(UsageError, match="run.json: raw_frames: true or false"):
        RunManifest.from_json({**doc, "raw_frames": "yes"}, "run.json")
