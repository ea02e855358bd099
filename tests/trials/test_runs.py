"""Run directories: resume after a crash, scoring from the records, broken records."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.cli import main
from grasp_ctrl.errors import UsageError
from grasp_ctrl.estimators.registry import DEFAULT_POLICY
from grasp_ctrl.files.storage import record_path, ticks_path
from grasp_ctrl.loop.ticklog import read_tick_log
from grasp_ctrl.trials.episode import runner as episode_runner
from grasp_ctrl.trials.episode.runner import trial_seed
from grasp_ctrl.trials.runs.manifest import read_manifest
from grasp_ctrl.trials.runs.records import load_records
from grasp_ctrl.trials.runs.scoring import score_run
from grasp_ctrl.trials.runs.series import run_series

# Two quick objects x an honest and an under-reading oracle: a mix of successes
# and failure reasons (which ones is the mock world's business, not asserted here).
OBJECTS = ["lego", "paper_cup"]
POLICIES = ["oracle", "oracle:scale=0.5"]
SEED = 7


class Crash(Exception):
    pass


@pytest.fixture(scope="module")
def full_run(tmp_path_factory, hand, objects):
    run_dir = tmp_path_factory.mktemp("runs") / "full"
    summary = run_series(
        hand, [objects[o] for o in OBJECTS], POLICIES, 1, SEED, run_dir, progress=False, backend="mock"
    )
    return run_dir, summary


def _copy(run_dir: Path, dest: Path) -> Path:
    shutil.copytree(run_dir, dest)
    return dest


def _json(path: Path) -> dict:
    return json.loads(path.read_text())


def test_live_run_covers_every_trial_with_records_and_tick_logs(full_run, hand):
    run_dir, summary = full_run
    for p in POLICIES:
        entry = summary["policies"][p]
        assert set(entry["objects"]) == set(OBJECTS)
        assert entry["overall"]["trials"] == 2
    rec = _json(record_path(run_dir, "oracle:scale=0.5", "paper_cup", 0))
    entry = summary["policies"]["oracle:scale=0.5"]["objects"]["paper_cup"]
    assert entry["successes"] == int(rec["success"])
    assert entry["failures"] == ({} if rec["success"] else {rec["reason"]: 1})
    assert rec["seed"] == trial_seed(SEED, "paper_cup", 0)
    assert set(rec["peak_forces"]) == {f.name for f in hand.fingers}
    assert rec["peak_grip_est_n"] == pytest.approx(
        max(v["grip_est_n"] for k, v in rec["peak_forces"].items() if k in {f.name for f in hand.fingers if f.grasp})
    )
    assert rec["settings"]["tau_n"] == 2.0 and "controller" in rec["settings"]
    assert rec["controller"]["final_state"] == rec["final_state"]
    assert rec["judged_by"] == "world"
    assert sum(rec["timings"]["state_s"].values()) == pytest.approx(rec["sim_duration_s"], abs=0.02)
    ticks = run_dir / "trials" / "oracle_scale_0.5" / "paper_cup" / "trial_000_ticks.parquet"
    header, cols = read_tick_log(ticks)
    assert len(cols["t"]) > 100 and ticks.stat().st_size < 200_000
    pq = pytest.importorskip("pyarrow.parquet")
    assert pq.read_table(ticks).column_names == header
    for col in (
        "state",
        "grip_target_n",
        "index_raw_pdc",
        "index_pdc_tared",
        "index_contact",
        "index_fx_sensor",
        "index_fz_world",
        "q0",
        "q_goal0",
    ):
        assert col in header
    assert _json(run_dir / "summary.json") == summary
    assert read_manifest(run_dir).policies == POLICIES


def test_scoring_from_the_records_equals_the_live_summary(full_run, tmp_path, capsys):
    run_dir, summary = full_run
    assert score_run(run_dir).summary == summary
    out = tmp_path / "scored.json"
    assert main(["score", str(run_dir), "--json", str(out)]) == 0
    assert _json(out) == summary
    captured = capsys.readouterr()
    assert "oracle:scale=0.5" in captured.out and captured.err == ""


def test_resume_after_a_crash_gives_the_uninterrupted_summary(full_run, tmp_path, hand, objects):
    run_dir, summary = full_run
    work = _copy(run_dir, tmp_path / "run")
    # The crash hit during the third trial: the last two records never reached the disk.
    for policy, obj in [("oracle:scale=0.5", "lego"), ("oracle:scale=0.5", "paper_cup")]:
        record_path(work, policy, obj, 0).unlink()
    (work / "summary.json").unlink()
    profiles = [objects[o] for o in OBJECTS]

    def crash_after_first(rec):
        raise Crash(rec["object"])

    with pytest.raises(Crash):  # crashes again, after one more trial
        run_series(
            hand,
            profiles,
            POLICIES,
            1,
            SEED,
            work,
            progress=False,
            resume=True,
            after_trial=crash_after_first,
            backend="mock",
        )
    assert len(load_records(work).records) == 3
    ran = []
    resumed = run_series(
        hand, profiles, POLICIES, 1, SEED, work, progress=False, resume=True, after_trial=ran.append, backend="mock"
    )
    assert [(r["policy"], r["object"]) for r in ran] == [("oracle:scale=0.5", "paper_cup")]
    assert {k: v for k, v in resumed.items() if k != "run_dir"} == {k: v for k, v in summary.items() if k != "run_dir"}
    assert score_run(work).summary == resumed


def test_a_finished_run_directory_is_not_overwritten(full_run, hand, objects):
    run_dir, _ = full_run
    with pytest.raises(UsageError, match="--resume"):
        run_series(hand, [objects["lego"]], POLICIES, 1, SEED, run_dir, progress=False, backend="mock")
    with pytest.raises(UsageError, match="other trials"):
        run_series(hand, [objects["lego"]], POLICIES, 1, SEED + 1, run_dir, progress=False, resume=True, backend="mock")


def test_corrupt_and_truncated_records_are_named_and_skipped(full_run, tmp_path, capsys):
    run_dir, summary = full_run
    work = _copy(run_dir, tmp_path / "run")
    truncated = record_path(work, "oracle", "lego", 0)
    truncated.write_text(truncated.read_text()[:57])
    garbage = record_path(work, "oracle", "paper_cup", 0)
    garbage.write_bytes(b"\x00\xff not json")
    wrong = record_path(work, "oracle:scale=0.5", "lego", 0)
    doc = _json(wrong)
    doc["success"] = "yes"
    wrong.write_text(json.dumps(doc))
    assert main(["score", str(work)]) == 0
    err = capsys.readouterr().err
    for path in (truncated, garbage, wrong):
        assert str(path) in err
    assert "1 of 4 trials" in err and "differs" in err
    scored = score_run(work)
    assert [r["policy"] for r in scored.records] == ["oracle:scale=0.5"]
    assert (
        scored.summary["policies"]["oracle:scale=0.5"]["objects"]["paper_cup"]
        == summary["policies"]["oracle:scale=0.5"]["objects"]["paper_cup"]
    )


def test_resume_reruns_a_corrupt_record_and_says_so(full_run, tmp_path, capsys):
    run_dir, summary = full_run
    work = _copy(run_dir, tmp_path / "run")
    broken = record_path(work, "oracle:scale=0.5", "lego", 0)
    broken.write_text('{"object": "lego", "pol')
    assert main(["run", "--resume", str(work), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert str(broken) in captured.err and "run again" in captured.err
    # (run, the CLI, adds the mock's test_double flag to what run_series wrote)
    assert {k: v for k, v in _json(work / "summary.json").items() if k not in ("run_dir", "test_double")} == {
        k: v for k, v in summary.items() if k != "run_dir"
    }


def test_resume_refuses_flags_that_would_change_the_run(full_run, capsys):
    run_dir, _ = full_run
    assert main(["run", "--resume", str(run_dir), "--trials", "3"]) == 2
    assert "--trials" in capsys.readouterr().err
    assert main(["run", "--resume", str(run_dir.parent / "nothing-here")]) == 2
    assert "run.json" in capsys.readouterr().err


def test_score_without_a_run_is_one_line_error(tmp_path, capsys):
    assert main(["score", str(tmp_path / "absent")]) == 2
    assert "no such run directory" in capsys.readouterr().err


def test_compare_prints_fig6_table_and_saves_a_chart(full_run, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    run_dir, summary = full_run
    png = tmp_path / "cmp.png"
    assert main(["compare", str(run_dir), "--png", str(png)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split() == ["success", "rate", *POLICIES]
    assert [line.split()[0] for line in out[1:4]] == [*OBJECTS, "all"]
    for i, p in enumerate(POLICIES):
        e = summary["policies"][p]["overall"]
        assert f"({e['successes']}/{e['trials']})" in out[3].split()[2 + 2 * i]
    assert "paired trials" in out[4]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_saves_force_traces_of_a_trial(full_run, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    run_dir, _ = full_run
    record = record_path(run_dir, "oracle", "lego", 0)
    png = tmp_path / "trace.png"
    assert main(["plot", str(record), "--out", str(png), "--xyz", "--frame", "world"]) == 0
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert main(["plot", str(tmp_path / "trial_000.json")]) == 2
    assert "no tick log" in capsys.readouterr().err


def test_preset_paper_is_six_objects_five_trials_two_policies():
    from grasp_ctrl.cli import build_parser
    from grasp_ctrl.cli.cmd_run import _plan
    from grasp_ctrl.trials.runs.presets import PAPER_POLICIES

    hand, m = _plan(build_parser().parse_args(["run", "--preset", "paper"]))
    assert (len(m.objects), m.trials, m.policies, m.preset) == (6, 5, list(PAPER_POLICIES), "paper")
    # on the paper's hand, an Allegro, under the nominal variation, with the paper's controller
    assert hand.name == "allegro_hand" and m.hand == "allegro_hand" and m.hand_file.endswith("allegro_hand.toml")
    assert m.variation is not None and m.variation.name == "nominal" and m.settings.controller == "paper"
    hand, m = _plan(build_parser().parse_args(["run", "--preset", "paper", "--hand", "hand_configs/leap_hand.toml"]))
    assert hand.name == "leap_hand"  # a flag beside the preset overrides it
    # in the reference world, with the authors' network fine-tuned on the simulated sensor
    assert m.backend == "mujoco" and PAPER_POLICIES[-1] == "icra19_finetuned_mock"
    _, m = _plan(build_parser().parse_args(["run"]))  # the main job
    assert m.backend == "mujoco"
    _, m = _plan(
        build_parser().parse_args(
            ["run", "--backend", "mock", "--preset", "paper", "--trials", "2", "--objects", "lego"]
        )
    )
    assert (m.object_names, m.trials) == (["lego"], 2)


def test_ctrl_c_keeps_finished_trials_and_resume_completes(tmp_path, monkeypatch, capsys):
    """The CLI path: interrupted after one trial, then 'run --resume' finishes the plan."""

    calls = []

    def fake_trial_fn(hand, policies, settings=None, threads=1, **_kw):
        def run(policy, obj, trial, seed, log_path):
            calls.append((obj.name, trial))
            if len(calls) == 2:
                raise KeyboardInterrupt
            return {
                "object": obj.name,
                "policy": policy,
                "trial": trial,
                "seed": seed,
                "success": trial % 2 == 0,
                "reason": None if trial % 2 == 0 else "slipped",
            }

        return run

    monkeypatch.setattr(episode_runner, "sim_trial_fn", fake_trial_fn)
    run_dir = tmp_path / "run"
    assert (
        main(["run", "--backend", "mock", "--objects", "lego", "--trials", "3", "--out", str(run_dir), "--quiet"])
        == 130
    )
    assert "1 of 3 trials are recorded" in capsys.readouterr().err
    assert main(["run", "--resume", str(run_dir)]) == 0
    captured = capsys.readouterr()
    # Off a terminal: the resume notice, no progress bar.
    assert captured.err.strip() == "resuming: 1 of 3 trials already recorded"
    assert calls == [("lego", 0), ("lego", 1), ("lego", 1), ("lego", 2)]
    entry = _json(run_dir / "summary.json")["policies"][DEFAULT_POLICY]["objects"]["lego"]
    assert (entry["successes"], entry["failures"]) == (2, {"slipped": 1})


@settings(max_examples=60, deadline=None)
@given(
    content=st.one_of(
        st.binary(max_size=300),
        st.text(max_size=300).map(str.encode),
        st.just(b"[" * 5000),
        st.dictionaries(
            st.sampled_from(["policy", "object", "trial", "seed", "success", "reason"]),
            st.one_of(st.none(), st.booleans(), st.integers(), st.text(max_size=8)),
        ).map(lambda d: json.dumps(d).encode()),
    )
)
def test_any_record_file_content_is_loaded_or_named_never_fatal(tmp_path_factory, content):
    run_dir = tmp_path_factory.mktemp("fuzz")
    path = record_path(run_dir, "p", "o", 0)
    path.parent.mkdir(parents=True)
    path.write_bytes(content)
    loaded = load_records(run_dir)
    assert len(loaded.records) + len(loaded.problems) == 1
    if loaded.problems:
        assert loaded.problems[0][0] == path and loaded.problems[0][1]
    else:
        rec = loaded.records[0]
        assert (rec["policy"], rec["object"], rec["trial"]) == ("p", "o", 0)


def test_without_matplotlib_compare_prints_the_table_and_plot_says_what_to_install(full_run, monkeypatch, capsys):
    import importlib.util
    import sys

    run_dir, _ = full_run
    real_find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "matplotlib" else real_find_spec(name, *a)
    )
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    assert main(["compare", str(run_dir)]) == 0
    captured = capsys.readouterr()
    assert "all" in captured.out and "matplotlib is not installed" in captured.err
    assert not (run_dir / "compare.png").exists()
    assert main(["plot", str(record_path(run_dir, "oracle", "lego", 0))]) == 2
    assert "[plot]" in capsys.readouterr().err


def test_plot_of_an_older_csv_tick_log_cut_short_by_a_crash(full_run, tmp_path):
    pytest.importorskip("matplotlib")
    run_dir, _ = full_run
    header, cols = read_tick_log(run_dir / "trials" / "oracle" / "lego" / "trial_000_ticks.parquet")
    cut = tmp_path / "trial_000_ticks.csv"
    rows = [",".join(str(cols[c][i]) for c in header) for i in range(len(cols["t"]))]
    text = "\n".join([",".join(header)] + rows) + "\n"
    cut.write_text(text[: len(text) // 3])  # ends mid-row
    png = tmp_path / "cut.png"
    assert main(["plot", str(cut), "--out", str(png)]) == 0
    assert png.stat().st_size > 1000


def test_parallel_jobs_give_the_same_records_and_summary(full_run, tmp_path, hand, objects):
    """Two missing trials run in two worker processes (resume + --jobs 2)."""
    run_dir, summary = full_run
    par = _copy(run_dir, tmp_path / "par")
    missing = [("oracle", "lego"), ("oracle:scale=0.5", "paper_cup")]
    for policy, obj in missing:
        record_path(par, policy, obj, 0).unlink()
        ticks_path(par, policy, obj, 0).unlink()
    got = run_series(
        hand, [objects[o] for o in OBJECTS], POLICIES, 1, SEED, par, progress=False, jobs=2, resume=True, backend="mock"
    )
    assert {k: v for k, v in got.items() if k != "run_dir"} == {k: v for k, v in summary.items() if k != "run_dir"}
    for policy, obj in missing:
        a, b = _json(record_path(run_dir, policy, obj, 0)), _json(record_path(par, policy, obj, 0))
        a.pop("wall_duration_s"), b.pop("wall_duration_s")
        assert a == b
        assert ticks_path(par, policy, obj, 0).read_bytes() == ticks_path(run_dir, policy, obj, 0).read_bytes()


def test_an_interrupt_just_after_run_json_keeps_the_run_resumable(hand, objects, tmp_path, monkeypatch):
    """Ctrl-C between run.json's rename and the first trial: run.json is whole (the rename is
    atomic), so the new directory stays and the interrupt's message can give --resume (the
    directory used to be removed as a failed start)."""
    import grasp_ctrl.trials.runs.series as series

    real_sync = series.sync_manifest

    def sync_then_interrupt(*args, **kwargs):
        real_sync(*args, **kwargs)
        raise KeyboardInterrupt

    monkeypatch.setattr(series, "sync_manifest", sync_then_interrupt)
    run_dir = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        run_series(hand, [objects["lego"]], ["oracle"], 1, SEED, run_dir, progress=False, backend="mock")
    assert (run_dir / "run.json").is_file()
    monkeypatch.setattr(series, "sync_manifest", real_sync)
    run_series(hand, [objects["lego"]], ["oracle"], 1, SEED, run_dir, progress=False, resume=True, backend="mock")
    assert len(list(run_dir.glob("trials/*/*/trial_*.json"))) == 1


def test_an_interrupt_before_run_json_leaves_no_directory(hand, objects, tmp_path, monkeypatch):
    import grasp_ctrl.trials.runs.series as series

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(series, "sync_manifest", interrupted)
    run_dir = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        run_series(hand, [objects["lego"]], ["oracle"], 1, SEED, run_dir, progress=False, backend="mock")
    assert not run_dir.exists()
