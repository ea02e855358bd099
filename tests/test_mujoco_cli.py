"""`run --backend mujoco`, `view`, `--record-video` and the bench figures (mujoco is a dependency)."""

from __future__ import annotations

import json

import mujoco

from grasp_ctrl.bench.runner import all_figures
from grasp_ctrl.cli import main


def test_run_backend_mujoco_scores_from_the_simulation(tmp_path, capsys):
    out = tmp_path / "run"
    assert (
        main(
            [
                "run",
                "--backend",
                "mujoco",
                "--objects",
                "chips_can",
                "--policy",
                "oracle:scale=4",
                "--trials",
                "1",
                "--out",
                str(out),
                "--quiet",
                "--no-tick-logs",
                "--variation",
                "nominal",
            ]
        )
        == 0
    )
    summary = json.loads((out / "summary.json").read_text())
    assert summary["backend"] == "mujoco"
    records = list(out.rglob("*.json"))
    trial = [json.loads(p.read_text()) for p in records if p.name not in ("summary.json", "run.json")]
    assert len(trial) == 1 and trial[0]["backend"] == "mujoco" and trial[0]["reason"] == "slipped"
    assert "slipped" in capsys.readouterr().out


def test_record_video_needs_the_mujoco_backend(tmp_path, capsys):
    assert (
        main(
            [
                "run",
                "--backend",
                "mock",
                "--objects",
                "lego",
                "--trials",
                "1",
                "--out",
                str(tmp_path / "r"),
                "--record-video",
                str(tmp_path / "v"),
            ]
        )
        != 0
    )
    assert "--record-video: only with --backend mujoco" in capsys.readouterr().err


def test_view_without_a_display_says_so(monkeypatch, capsys, tmp_path):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    assert main(["view", "--backend", "mujoco", "--object", "paper_cup"]) == 2
    assert "no display" in capsys.readouterr().err
    xml = tmp_path / "scene.xml"
    assert main(["view", "--object", "paper_cup", "--save-xml", str(xml)]) == 0
    assert mujoco.MjModel.from_xml_path(str(xml)).nu == 16


def test_view_names_an_unknown_object(capsys):
    assert main(["view", "--object", "no_such_thing"]) != 0
    assert "no object 'no_such_thing'" in capsys.readouterr().err


def test_the_realtime_figure_is_listed():
    assert "mujoco_realtime_factor" in all_figures()
    assert "mujoco_bare_realtime_factor" in all_figures()


def test_the_bare_engine_figure_runs():
    """mj_step alone on the recorded inputs of a short trial: a finite rate."""
    import numpy as np

    from grasp_ctrl.bench import fig_mujoco

    assert fig_mujoco._bare_steps(0.3, 0) > 0.0
    rec = fig_mujoco._StepRecorder(mujoco)
    assert rec.mjtState is mujoco.mjtState and rec.inputs == []
    assert np.isfinite(fig_mujoco.mujoco_bare_realtime_factor(True).median)


def test_recording_world_writes_a_video_or_says_why(tmp_path, capsys, hand, objects):
    from grasp_ctrl.trials.episode.mujoco_video import RecordingWorld

    RecordingWorld._warned = False
    world = RecordingWorld(hand, objects["lego"], 0, None, tmp_path / "trial")
    for _ in range(12):
        world.step()
    written = world.close()
    if written is None:  # no GL backend in this process: a clear message, no crash
        assert "no OpenGL backend" in capsys.readouterr().err
    else:
        assert written.suffix in (".gif", ".mp4") and written.stat().st_size > 0
