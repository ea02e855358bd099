"""`plot` and its replay on a trial of the main job's output (run through the CLI)."""

from __future__ import annotations

import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.estimators.registry import DEFAULT_POLICY


@pytest.fixture(scope="module")
def main_job_trial(tmp_path_factory):
    """One trial of the main job (`run` with its defaults, one object, one trial)."""
    run_dir = tmp_path_factory.mktemp("main") / "run"
    assert (
        main(["run", "--backend", "mock", "--objects", "chips_can", "--trials", "1", "--out", str(run_dir), "--quiet"])
        == 0
    )
    return run_dir / "trials" / DEFAULT_POLICY / "chips_can" / "trial_000.json"


def test_plot_of_a_trial_is_a_nontrivial_png(main_job_trial, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    Image = pytest.importorskip("PIL.Image")
    assert main(["plot", str(main_job_trial)]) == 0
    png = main_job_trial.with_name("trial_000.png")
    assert f"plot: {png}" in capsys.readouterr().out
    with Image.open(png) as im:
        assert im.format == "PNG" and im.size[0] >= 800 and im.size[1] >= 800
        rgb = im.convert("RGB")
        colours = rgb.getcolors(maxcolors=rgb.size[0] * rgb.size[1])  # never None: at most one per pixel
        assert len(colours) > 50  # traces, bands, text: not a blank canvas
    assert png.stat().st_size > 30_000


def test_replay_is_an_animated_gif(main_job_trial, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    Image = pytest.importorskip("PIL.Image")
    gif = tmp_path / "replay.gif"
    ticks = main_job_trial.with_name("trial_000_ticks.parquet")
    assert main(["plot", str(ticks), "--out", str(tmp_path / "p.png"), "--animate", str(gif), "--frames", "6"]) == 0
    assert f"replay: {gif}" in capsys.readouterr().out
    with Image.open(gif) as im:
        assert im.format == "GIF" and im.n_frames == 6 and im.size[0] >= 600
        first = im.convert("RGB").tobytes()
        im.seek(5)
        assert im.convert("RGB").tobytes() != first  # the hand moves
    assert gif.stat().st_size > 20_000


def test_replay_refuses_other_formats_and_a_hand_that_does_not_match(main_job_trial, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    from grasp_ctrl.loop.ticklog import read_tick_log
    from grasp_ctrl.trials.analysis.trial_view import TrialView, hand_for_replay

    assert (
        main(["plot", str(main_job_trial), "--out", str(tmp_path / "p.png"), "--animate", str(tmp_path / "r.mp4")]) == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and ".gif" in err[0]
    header, cols = read_tick_log(main_job_trial.with_name("trial_000_ticks.parquet"))
    fewer = [c for c in header if c != "q15" and c != "q_goal15"]
    view = TrialView(main_job_trial, fewer, {c: cols[c] for c in fewer})
    from grasp_ctrl.errors import UsageError

    with pytest.raises(UsageError, match="logged 15 joints.*--hand"):
        hand_for_replay(view, None)


def test_plot_prints_what_the_trial_loader_could_not_load(main_job_trial, tmp_path, capsys):
    """A record cut in half and a run.json that does not read: the plot is made without them and
    says so on stderr (the loader's notes), instead of silently."""
    pytest.importorskip("matplotlib")
    import shutil

    run_dir = tmp_path / "run"
    shutil.copytree(main_job_trial.parents[3], run_dir)
    record = run_dir / main_job_trial.relative_to(main_job_trial.parents[3])
    text = record.read_text()
    record.write_text(text[: len(text) // 2])
    (run_dir / "run.json").write_text("{")
    capsys.readouterr()
    assert main(["plot", str(record), "--out", str(tmp_path / "p.png")]) == 0
    err = capsys.readouterr().err
    assert f"note: {record}: unreadable record (not JSON" in err
    assert f"note: {run_dir / 'run.json'}: unreadable run file" in err and "hand the trial ran with is unknown" in err
