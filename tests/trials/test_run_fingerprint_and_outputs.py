"""One run is one experiment, and nothing is written where nobody asked.

Regression tests for the run fingerprint (resume refuses a changed policy, hand, object
file or run.json setting unless --force, which run.json records; every record carries
the fingerprint; score counts only planned trials), for outputs (never a run's managed
file, never through a symlink, format checked, MuJoCo's log kept out of the working
directory), and for the Ctrl-C hint. Trials are stubbed where the trial itself does not
matter, so these run in seconds.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
from pathlib import Path

import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.files.paths import default_hand_file, default_objects_file, policies_dir
from grasp_ctrl.trials.episode import runner as episode_runner
from grasp_ctrl.trials.runs.manifest import read_manifest


def _stub_trials(monkeypatch: pytest.MonkeyPatch) -> None:

    def fake_trial_fn(hand, policies, settings=None, threads=1, **_kw):
        def run(p, obj, k, seed, log):
            if log is not None:
                Path(log).write_text("t,state\n")
            return {
                "object": obj.name,
                "policy": p,
                "trial": k,
                "seed": seed,
                "success": k % 2 == 0,
                "reason": None if k % 2 == 0 else "slipped",
            }

        return run

    monkeypatch.setattr(episode_runner, "sim_trial_fn", fake_trial_fn)


def _err(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err


@pytest.fixture
def files(tmp_path: Path) -> dict[str, Path]:
    """Copies of the hand, object and a policy file that the tests may edit."""
    out = {"hand": tmp_path / "hand.toml", "objects": tmp_path / "objects.toml", "policy": tmp_path / "pol.json"}
    shutil.copy(default_hand_file(), out["hand"])
    shutil.copy(default_objects_file(), out["objects"])
    shutil.copy(policies_dir() / "linear_mock.json", out["policy"])
    return out


def _start(run_dir: Path, files: dict[str, Path], trials: int = 2) -> list[str]:
    return [
        "run",
        "--backend",
        "mock",
        "--objects",
        "lego",
        "--trials",
        str(trials),
        "--quiet",
        "--no-tick-logs",
        "--policy",
        str(files["policy"]),
        "--hand",
        str(files["hand"]),
        "--object-file",
        str(files["objects"]),
        "--out",
        str(run_dir),
    ]


def _records(run_dir: Path) -> list[Path]:
    return sorted(run_dir.glob("trials/*/*/trial_*.json"))


def _half_run(tmp_path: Path, files: dict[str, Path], monkeypatch) -> Path:
    """A 2-trial run whose second record is gone (as after a crash)."""
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main(_start(run_dir, files)) == 0
    _records(run_dir)[1].unlink()
    return run_dir


# ---------------------------------------------------------------- 1. the fingerprint
def test_run_json_fingerprints_every_file_and_setting_and_records_carry_it(tmp_path, files, monkeypatch):
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main(_start(run_dir, files)) == 0
    fp = json.loads((run_dir / "run.json").read_text())["fingerprint"]
    paths = {Path(v["path"]) for v in fp["files"].values()}
    assert {files["hand"].resolve(), files["objects"].resolve(), files["policy"].resolve()} <= paths
    assert all(len(v["sha256"]) == 64 for v in fp["files"].values())
    assert {"seed", "trials", "settings", "objects.lego"} <= fp["settings"].keys()
    for rec in _records(run_dir):
        assert json.loads(rec.read_text())["fingerprint"] == fp["sha256"]


def test_a_model_file_is_part_of_its_policy_fingerprint():
    from grasp_ctrl.trials.runs.fingerprint import policy_files

    names = {p.name for _, p in policy_files("icra19_official")}
    assert names == {"icra19_official.json", "icra19_official.onnx"}
    assert policy_files("oracle:scale=2") == []


@pytest.mark.parametrize(
    "edit, named",
    [
        (lambda f, d: f["policy"].write_text(f["policy"].read_text().replace('"name"', '"name" ', 1)), "policy"),
        (lambda f, d: f["hand"].write_text(f["hand"].read_text() + "\n# edited\n"), "hand"),
        (lambda f, d: f["objects"].write_text(f["objects"].read_text() + "\n# tuned\n"), "object_file"),
        (lambda f, d: _edit_run_json(d, lambda j: j["settings"].update(ramp_tolerance_n=0.123)), "run.json settings"),
        (lambda f, d: _edit_run_json(d, lambda j: j["objects"][0].update(tau_n=1.5)), "run.json objects.lego"),
    ],
)
def test_resume_refuses_a_changed_file_or_setting_naming_it(tmp_path, files, monkeypatch, capsys, edit, named):
    run_dir = _half_run(tmp_path, files, monkeypatch)
    capsys.readouterr()
    before = sorted(p.name for p in run_dir.rglob("*"))
    edit(files, run_dir)
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 2
    line = _err(capsys)
    assert named in line and "--force" in line and len(line.strip().splitlines()) == 1
    assert sorted(p.name for p in run_dir.rglob("*")) == before  # nothing ran, nothing written


def _edit_run_json(run_dir: Path, change) -> None:
    path = run_dir / "run.json"
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc))


def test_resume_with_force_continues_and_records_what_changed(tmp_path, files, monkeypatch, capsys):
    run_dir = _half_run(tmp_path, files, monkeypatch)
    old = read_manifest(run_dir).fingerprint["sha256"]
    files["policy"].write_text(files["policy"].read_text().replace('"name"', '"name" ', 1))
    assert main(["run", "--resume", str(run_dir), "--quiet", "--force"]) == 0
    m = read_manifest(run_dir)
    assert len(m.forced) == 1 and m.forced[0]["from"] == old and m.forced[0]["to"] == m.fingerprint["sha256"]
    assert any("policy" in c for c in m.forced[0]["changed"])
    prints = [json.loads(p.read_text())["fingerprint"] for p in _records(run_dir)]
    assert prints == [old, m.fingerprint["sha256"]]
    capsys.readouterr()
    assert main(["score", str(run_dir)]) == 0  # both belong to the run (the change was accepted)
    assert "not counted" not in _err(capsys)


def test_force_names_both_of_its_uses(capsys):
    """--force accepts a changed run on --resume, and on a hand an object the grasp cannot carry."""
    assert main(["run", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "with --resume: continue although" in text and "the capacity preflight refuses" in text


def test_resume_of_an_unchanged_run_still_works(tmp_path, files, monkeypatch):
    run_dir = _half_run(tmp_path, files, monkeypatch)
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 0
    assert len(_records(run_dir)) == 2


def test_score_counts_only_planned_trials_and_names_the_others(tmp_path, files, monkeypatch, capsys):
    from grasp_ctrl.trials.episode.runner import trial_seed

    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main(_start(run_dir, files)) == 0
    first = _records(run_dir)[0]
    rec = json.loads(first.read_text())
    extra = dict(rec, trial=7, seed=trial_seed(0, "lego", 7))  # trial 7 of a 2-trial run
    (first.parent / "trial_007.json").write_text(json.dumps(extra))
    other = first.parent.parent / "cleanser"  # an object outside the run
    other.mkdir()
    (other / "trial_000.json").write_text(json.dumps(dict(rec, object="cleanser", seed=trial_seed(0, "cleanser", 0))))
    foreign = dict(rec, fingerprint="0" * 64)  # another experiment's record
    capsys.readouterr()
    assert main(["score", str(run_dir), "--json", str(tmp_path / "s.json")]) == 0
    err = _err(capsys)
    assert "trial_007.json" in err and "outside the run's 2 trials" in err
    assert "cleanser" in err and "not one of the run's" in err
    summary = json.loads((tmp_path / "s.json").read_text())
    assert summary == json.loads((run_dir / "summary.json").read_text()) | {"run_dir": summary["run_dir"]}
    first.write_text(json.dumps(foreign))
    assert main(["score", str(run_dir)]) == 0
    assert "another fingerprint" in _err(capsys)


# ---------------------------------------------------------------- 2. writes only where asked
@pytest.mark.parametrize("target", ["run.json", "summary.json", "run.lock", "trials/x/lego/trial_000.json"])
def test_score_json_refuses_a_managed_file_of_the_run(tmp_path, files, monkeypatch, capsys, target):
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main(_start(run_dir, files)) == 0
    before = (run_dir / "run.json").read_text()
    capsys.readouterr()
    assert main(["score", str(run_dir), "--json", str(run_dir / target)]) == 2
    assert "manages" in _err(capsys)
    assert (run_dir / "run.json").read_text() == before
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 0  # the run is intact


def test_run_json_into_its_own_run_json_is_refused_before_anything_runs(tmp_path, files, monkeypatch, capsys):
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main(_start(run_dir, files) + ["--json", str(run_dir / "run.json")]) == 2
    assert "manages" in _err(capsys) and not run_dir.exists()


def test_a_symlink_at_the_json_destination_is_replaced_not_written_through(tmp_path, files, monkeypatch):
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main(_start(run_dir, files)) == 0
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me\n")
    link = tmp_path / "out.json"
    link.symlink_to(victim)
    assert main(["score", str(run_dir), "--json", str(link)]) == 0
    assert victim.read_text() == "keep me\n"
    assert not link.is_symlink() and json.loads(link.read_text())["seed"] == 0


def test_compare_png_through_a_symlink_leaves_the_target_alone(tmp_path, files, monkeypatch, capsys):
    pytest.importorskip("matplotlib")
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main(_start(run_dir, files)) == 0
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me\n")
    (run_dir / "compare.png").symlink_to(victim)
    assert main(["compare", str(run_dir)]) == 0
    assert victim.read_text() == "keep me\n"
    png = run_dir / "compare.png"
    assert not png.is_symlink() and png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    "argv, flag",
    [
        (["compare", "{run}", "--png", "{tmp}/chart.xyz"], "--png"),
        (["compare", "{run}", "--png", "{tmp}/chart"], "--png"),
        (["plot", "{tmp}/trial_000.json", "--out", "{tmp}/p.nonsense"], "--out"),
        (["plot", "{tmp}/trial_000.json", "--animate", "{tmp}/p.png"], "--animate"),
    ],
)
def test_plot_and_compare_check_the_output_format_first(tmp_path, files, monkeypatch, capsys, argv, flag):
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main(_start(run_dir, files)) == 0
    capsys.readouterr()
    args = [a.format(run=run_dir, tmp=tmp_path) for a in argv]
    assert main(args) == 2
    line = _err(capsys)
    assert flag in line and "extension" in line
    assert not list(tmp_path.glob("chart*")) and not list(tmp_path.glob("p.*"))


def test_save_figure_replaces_a_symlink_and_checks_the_format(tmp_path):
    pytest.importorskip("matplotlib")
    from grasp_ctrl.display.plotting import pyplot
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.files.safe_write import save_figure

    plt = pyplot()
    fig = plt.figure()
    victim = tmp_path / "victim"
    victim.write_text("x")
    link = tmp_path / "fig.png"
    link.symlink_to(victim)
    save_figure(fig, link)
    with pytest.raises(UsageError, match="extension"):
        save_figure(fig, tmp_path / "fig.unknown")
    plt.close(fig)
    assert victim.read_text() == "x" and link.read_bytes()[:4] == b"\x89PNG"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.png", "victim"]


def test_replace_in_place_keeps_mode_and_follows_a_symlink_to_its_target(tmp_path):
    from grasp_ctrl.files.safe_write import replace_in_place

    target = tmp_path / "real" / "objects.toml"
    target.parent.mkdir()
    target.write_text("old\n")
    os.chmod(target, 0o640)
    link = tmp_path / "objects.toml"
    link.symlink_to(target)
    assert replace_in_place(link, "new\n") == target.resolve()
    assert link.is_symlink() and target.read_text() == "new\n"
    assert stat.S_IMODE(target.stat().st_mode) == 0o640
    assert sorted(p.name for p in target.parent.iterdir()) == ["objects.toml"]


def test_mujoco_warnings_go_to_the_run_directory_or_nowhere(tmp_path, monkeypatch):
    mujoco = pytest.importorskip("mujoco")
    from grasp_ctrl.sim.mujoco import log as mujoco_log

    monkeypatch.chdir(tmp_path)
    mujoco_log.install(mujoco)
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><freejoint/><geom type="box" size=".1 .1 .1" mass="1"/></body></worldbody></mujoco>'
    )

    def unstable_step() -> None:
        data = mujoco.MjData(model)
        data.qvel[:] = 1e300
        mujoco.mj_step(model, data)

    unstable_step()
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists() and "QVEL" in mujoco_log.messages[-1]
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    mujoco_log.set_log_dir(run_dir)
    try:
        unstable_step()
    finally:
        mujoco_log.set_log_dir(None)
    assert "QVEL" in (run_dir / "MUJOCO_LOG.TXT").read_text()
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_ctrl_c_before_the_run_exists_does_not_offer_a_resume(tmp_path, files, monkeypatch, capsys):
    from grasp_ctrl.trials.runs import series

    def interrupted(*_a, **_kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(series, "run_series", interrupted)
    assert main(_start(tmp_path / "never", files)) == 130
    err = _err(capsys)
    assert "--resume" not in err and "nothing was recorded" in err
    assert not (tmp_path / "never").exists()


@pytest.mark.parametrize(
    "lock",
    [
        '{"pid": ' + "9" * 30 + ', "host": "HOST"}',
        '{"pid": true, "host": "HOST"}',
        '{"pid": -5, "host": "HOST"}',
        "[" * 100000,
        "x" * 200000,
    ],
)
def test_a_hostile_lock_file_is_taken_over_with_a_warning(tmp_path, files, monkeypatch, capsys, lock):
    import socket

    run_dir = _half_run(tmp_path, files, monkeypatch)
    (run_dir / "run.lock").write_text(lock.replace("HOST", socket.gethostname()))
    capsys.readouterr()
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 0
    assert "taking it over" in _err(capsys)
    assert not (run_dir / "run.lock").exists() and len(_records(run_dir)) == 2


def test_a_live_lock_still_keeps_a_second_writer_out(tmp_path, files, monkeypatch, capsys):
    import socket

    run_dir = _half_run(tmp_path, files, monkeypatch)
    (run_dir / "run.lock").write_text(json.dumps({"pid": os.getppid(), "host": socket.gethostname(), "started": "x"}))
    capsys.readouterr()
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 2
    assert "is in use by process" in _err(capsys) and len(_records(run_dir)) == 1


def test_a_run_tree_with_a_symlinked_folder_is_refused(tmp_path, files, monkeypatch, capsys):
    run_dir = _half_run(tmp_path, files, monkeypatch)
    elsewhere = tmp_path / "elsewhere"
    lego = next(run_dir.glob("trials/*/lego"))
    shutil.move(lego, elsewhere)
    lego.symlink_to(elsewhere, target_is_directory=True)
    before = sorted(p.name for p in elsewhere.iterdir())
    capsys.readouterr()
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 2
    assert "is a symlink" in _err(capsys)
    assert sorted(p.name for p in elsewhere.iterdir()) == before
    link = tmp_path / "link"
    link.symlink_to(elsewhere, target_is_directory=True)
    assert main(_start(link, files)) == 2 and "a symlink" in _err(capsys)


def test_an_output_that_replaces_a_file_keeps_its_mode(tmp_path):
    from grasp_ctrl.files.safe_write import write_output

    path = tmp_path / "out.json"
    path.write_text("{}")
    os.chmod(path, 0o640)
    write_output(path, "[]")
    assert path.read_text() == "[]" and stat.S_IMODE(path.stat().st_mode) == 0o640
