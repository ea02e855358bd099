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


def test_the_realtime_figures_are_listed():
    for name in ("mujoco_realtime_factor", "mujoco_bare_realtime_factor", "mujoco_replayed_realtime_factor"):
        assert name in all_figures()


class _FakeClock:
    """A perf_counter that only MuJoCo's steps advance: one unit per step."""

    def __init__(self) -> None:
        self.now = 0.0

    def perf_counter(self) -> float:
        return self.now


def test_the_bare_figure_times_each_of_the_trials_steps_and_nothing_else(monkeypatch):
    """The world's mj_step calls inside the trial, nstep steps or one: the time summed is the
    engine's alone (a clock only the steps move gives one unit per step of the trial), and the
    world's time of the same trial holds it."""
    import sys

    from grasp_ctrl.bench import fig_mujoco

    clock = _FakeClock()

    class CountingMuJoCo:
        def __getattr__(self, name: str):  # noqa: ANN204
            return getattr(mujoco, name)

        def mj_step(self, m, d, nstep: int = 1) -> None:  # noqa: ANN001
            mujoco.mj_step(m, d, nstep)
            clock.now += nstep

    monkeypatch.setattr(fig_mujoco, "time", clock)
    monkeypatch.setitem(sys.modules, "mujoco", CountingMuJoCo())
    sim_s = 0.3
    world_s, engine_s = fig_mujoco._timed_trial(sim_s, 0)
    assert engine_s == round(sim_s / 0.01) * 5  # 30 control periods of 5 MuJoCo steps (0.002 s)
    assert world_s == engine_s  # the world's steps hold them all


def test_the_replayed_engine_figure_runs():
    """mj_step alone on the recorded inputs of a short trial: a finite rate."""
    import numpy as np

    from grasp_ctrl.bench import fig_mujoco

    assert fig_mujoco._replayed_steps(0.3, 0) > 0.0
    rec = fig_mujoco._StepRecorder(mujoco)
    assert rec.mjtState is mujoco.mjtState and rec.inputs == []
    assert np.isfinite(fig_mujoco.mujoco_replayed_realtime_factor(True).median)
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


def test_the_main_job_figures_time_the_main_job_s_trial_and_its_mujoco_steps(monkeypatch):
    """The main job's trial (grip_load, the default policy, bench), whole and its mj_step calls
    alone, from the same trials: MuJoCo's steps are part of the trial, so they run faster alone."""
    import numpy as np

    from grasp_ctrl.bench import fig_main_job
    from grasp_ctrl.trials.episode import runner

    seen = []
    real_fn = runner.sim_trial_fn

    def one_object(path, names, hand):
        return [o for o in real_select(path, names, hand=hand) if o.name == "lego"]

    def recording_fn(*args, **kwargs):
        seen.append(kwargs)
        return real_fn(*args, **kwargs)

    real_select = fig_main_job.select_objects
    monkeypatch.setattr(fig_main_job, "select_objects", one_object)
    monkeypatch.setattr(fig_main_job, "sim_trial_fn", recording_fn)
    samples = fig_main_job._main_job_trials.__wrapped__(True)
    assert len(samples) == 1
    whole, engine = samples[0]
    assert np.isfinite(whole) and np.isfinite(engine) and 0.0 < whole < engine
    assert seen[0]["backend"] == "mujoco" and seen[0]["variation"].name == "bench"
    assert "main_job_realtime_factor" in all_figures() and "main_job_mujoco_step_realtime_factor" in all_figures()
