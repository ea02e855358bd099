"""`--executor ray`: a small sweep on a local Ray instance gives the records, summary,
ranking and trained models of the local executor; resume works across executors."""

from __future__ import annotations

import json

import pytest

ray = pytest.importorskip("ray")

from grasp_ctrl.cli import main  # noqa: E402
from grasp_ctrl.files.storage import record_path, ticks_path  # noqa: E402
from grasp_ctrl.trials.runs.series import run_series  # noqa: E402

OBJECTS = ["lego", "chips_can"]


@pytest.fixture(scope="module")
def local_ray():
    """One small local instance for the module (the commands then use it and leave it running)."""
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, object_store_memory=80 * 1024 * 1024)
    yield
    ray.shutdown()


def _records(run_dir, policies):
    out = {}
    for p in policies:
        for o in OBJECTS:
            rec = json.loads(record_path(run_dir, p, o, 0).read_text())
            rec.pop("wall_duration_s")
            out[(p, o)] = rec
    return out


def test_run_and_resume_on_ray_match_the_local_run(local_ray, tmp_path, hand, objects):
    policies = ["linear_mock", "oracle"]
    profiles = [objects[o] for o in OBJECTS]
    local = run_series(hand, profiles, policies, 1, 5, tmp_path / "local", progress=False, backend="mock")
    on_ray = run_series(
        hand, profiles, policies, 1, 5, tmp_path / "ray", progress=False, executor="ray", jobs=2, backend="mock"
    )
    assert {k: v for k, v in on_ray.items() if k != "run_dir"} == {k: v for k, v in local.items() if k != "run_dir"}
    assert _records(tmp_path / "ray", policies) == _records(tmp_path / "local", policies)
    assert (
        ticks_path(tmp_path / "ray", "oracle", "lego", 0).read_bytes()
        == ticks_path(tmp_path / "local", "oracle", "lego", 0).read_bytes()
    )
    # An interrupted local run resumed on Ray (and the CLI's flags for it).
    record_path(tmp_path / "local", "oracle", "chips_can", 0).unlink()
    assert main(["run", "--resume", str(tmp_path / "local"), "--executor", "ray", "--quiet"]) == 0
    assert _records(tmp_path / "local", policies) == _records(tmp_path / "ray", policies)


def test_mujoco_trials_on_ray_match_the_local_run(local_ray, tmp_path, hand, objects):
    """The Ray worker builds the world the run names (not the mock's)."""
    pytest.importorskip("mujoco")
    profiles = [objects["lego"]]
    local = run_series(hand, profiles, ["oracle"], 1, 3, tmp_path / "local", progress=False, backend="mujoco")
    on_ray = run_series(
        hand, profiles, ["oracle"], 1, 3, tmp_path / "ray", progress=False, backend="mujoco", executor="ray", jobs=1
    )
    assert {k: v for k, v in on_ray.items() if k != "run_dir"} == {k: v for k, v in local.items() if k != "run_dir"}
    ray_rec = json.loads(record_path(tmp_path / "ray", "oracle", "lego", 0).read_text())
    local_rec = json.loads(record_path(tmp_path / "local", "oracle", "lego", 0).read_text())
    assert ray_rec["backend"] == "mujoco"
    ray_rec.pop("wall_duration_s"), local_rec.pop("wall_duration_s")
    assert ray_rec == local_rec


def test_tune_on_ray_ranks_like_local(local_ray, tmp_path):
    pytest.importorskip("optuna")
    common = ["tune", "--backend", "mock", "--object", "lego", "--param", "tau=1.5,2.5", "--trials", "1", "--quiet"]
    assert main([*common, "--json", str(tmp_path / "local.json")]) == 0
    assert main([*common, "--executor", "ray", "--json", str(tmp_path / "ray.json")]) == 0
    assert json.loads((tmp_path / "ray.json").read_text()) == json.loads((tmp_path / "local.json").read_text())


def test_fig3_style_experiment_on_ray_trains_the_same_models(local_ray, tmp_path):
    pytest.importorskip("torch")
    from grasp_ctrl.learning.pipeline import DataSpec, load_data, run_experiment
    from grasp_ctrl.learning.splits import split_by_trials

    ds, info = load_data(DataSpec(synthetic_per_source=300, seed=6), report=lambda s: None)
    split = split_by_trials(ds, seed=6, test_per_source=50)
    models = {"analytic": ("analytic", None), "su": ("su", None)}
    docs = {}
    for executor in ("local", "ray"):
        docs[executor] = run_experiment(
            ds, split, models, tmp_path / executor, 1, 3, info, progress=lambda s: None, executor=executor
        )
        assert (tmp_path / executor / "mixed__su.pt").is_file()
    strip = lambda d: {c: {m: v["metrics"] for m, v in r.items()} for c, r in d["results"].items()}  # noqa: E731
    assert strip(docs["ray"]) == strip(docs["local"])


def test_executor_errors_are_one_line(tmp_path, capsys):
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
                "--address",
                "10.0.0.1:6379",
                "--out",
                str(tmp_path / "x"),
            ]
        )
        == 2
    )
    assert "--address: only with --executor ray" in capsys.readouterr().err
    assert (
        main(
            [
                "run",
                "--backend",
                "dynamixel",
                "--emulate",
                "--executor",
                "ray",
                "--objects",
                "lego",
                "--out",
                str(tmp_path / "y"),
            ]
        )
        == 2
    )
    assert "only simulated trials" in capsys.readouterr().err
