"""Hardening: every fault ends in a safe stop and a record, every file is checked, nothing is lost.

One regression test (or a few) per numbered defect of the issue; the property tests
that throw hostile values at every loader live in ``test_loader_properties.py``.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import copy_policy

from grasp_ctrl.cli import main
from grasp_ctrl.config.objects import CapProfile, load_objects
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.errors import ConfigError, PolicyError, UsageError
from grasp_ctrl.estimators.base import Estimate
from grasp_ctrl.estimators.registry import DEFAULT_POLICY, list_policy_names, load_policy
from grasp_ctrl.files.paths import default_objects_file, policies_dir
from grasp_ctrl.files.storage import LOCK_FILE, record_path, safe_name, temp_path, ticks_path
from grasp_ctrl.loop.ticklog import read_tick_log
from grasp_ctrl.trials.episode import runner as episode_runner
from grasp_ctrl.trials.episode.runner import run_sim_trial
from grasp_ctrl.trials.runs.manifest import read_manifest
from grasp_ctrl.trials.runs.records import load_records
from grasp_ctrl.trials.runs.series import run_series

OBJECTS_TOML = Path(default_objects_file()).read_text()


def _err_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    return lines[0]


def _objects_file(tmp_path: Path, extra: str = "", replace: tuple[str, str] | None = None) -> Path:
    text = OBJECTS_TOML if replace is None else OBJECTS_TOML.replace(*replace)
    path = tmp_path / "objects.toml"
    path.write_text(text + extra)
    return path


def _files_under(root: Path) -> set[Path]:
    return {p for p in root.rglob("*")}


# ---------------------------------------------------------------- 1. resume with the mustard cap
def test_1_run_json_gives_the_cap_back_as_a_cap_profile(tmp_path, hand, objects):
    from grasp_ctrl.trials.runs.manifest import RunManifest, write_manifest

    m = RunManifest("mock", hand.name, 0, 1, ["linear_mock"], [objects["mustard_bottle"]])
    write_manifest(tmp_path, m)
    back = read_manifest(tmp_path)
    assert isinstance(back.objects[0].cap, CapProfile)
    assert back.objects[0] == objects["mustard_bottle"]
    assert back.same_plan(m)


# ---------------------------------------------------------------- 2. non-finite estimates, sensors, goals
class _NanPolicy:
    """Wraps a real policy; returns NaN (or inf) once ``after`` calls were made."""

    has_variance = False

    def __init__(self, inner, value: float, after: int = 0) -> None:
        self.inner, self.value, self.after, self.calls = inner, value, after, 0
        self.name = f"bad_{value}"

    def estimate(self, tared, fingers):
        self.calls += 1
        est = self.inner.estimate(tared, fingers)
        if self.calls > self.after:
            f = est.f_sensor.copy()
            f[0, 0] = self.value
            return Estimate(f_sensor=f)
        return est


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
def test_2_non_finite_estimate_is_a_recorded_safe_fault(tmp_path, hand, objects, value):
    inner = load_policy("linear_mock", hand)
    policy = _NanPolicy(inner, value, after=5)

    def trial_fn(pol, obj, trial, seed, log_path):
        return run_sim_trial(hand, obj, lambda w: policy, seed, pol, trial, log_path=log_path, backend="mock").to_json()

    run_dir = tmp_path / "run"
    summary = run_series(
        hand, [objects["lego"]], ["linear_mock"], 1, 0, run_dir, progress=False, trial_fn=trial_fn, backend="mock"
    )
    rec = json.loads(record_path(run_dir, "linear_mock", "lego", 0).read_text())
    assert rec["final_state"] == "fault" and rec["reason"] == "estimate_invalid"
    assert "non-finite force" in rec["fault_detail"] and rec["controller"]["detail"] == rec["fault_detail"]
    assert summary["policies"]["linear_mock"]["objects"]["lego"]["failures"] == {"estimate_invalid": 1}
    # the safe action ran: on_fault = open, the fingers went to the open posture, finite goals only
    header, cols = read_tick_log(ticks_path(run_dir, "linear_mock", "lego", 0))
    last_goals = [cols[c][-1] for c in header if c.startswith("q_goal")]
    assert len(last_goals) == len(hand.joints) and all(np.isfinite(last_goals))
    q_open = [j.open_rad for j in hand.joints]
    assert np.allclose(last_goals, q_open, atol=0.06)


def test_2_nan_force_never_passes_the_overforce_check(hand, objects):
    from grasp_ctrl.controller.snapshot import Snapshot

    ctrl = GraspController(hand, objects["lego"], np.array([0.0, 0.0, 0.2]))
    n = len(hand.fingers)
    q = np.array([j.open_rad for j in hand.joints])
    f = np.zeros((n, 3))
    f[1] = np.nan
    snap = Snapshot(
        t=0.0,
        q=q,
        p_palm_world=np.zeros(3),
        tare_ready=True,
        in_contact=np.ones(n, bool),
        f_sensor=f,
        f_hand=f,
        f_world=f,
        grip_n=np.zeros(n),
    )
    cmd = ctrl.tick(snap)
    assert ctrl.state == "fault" and ctrl.failure_reason == "estimate_invalid"
    assert np.all(np.isfinite(cmd.q_goal))


def test_2_non_finite_sensor_frame_is_sensor_invalid(hand, objects):
    from grasp_ctrl.hardware.base import JointState
    from grasp_ctrl.kinematics.chain import HandKinematics
    from grasp_ctrl.loop.sensing import SensingPipeline

    pipeline = SensingPipeline(hand, HandKinematics(hand), load_policy("linear_mock", hand))
    n, q = len(hand.fingers), np.array([j.open_rad for j in hand.joints])
    raw = np.full((n, 44), 2000.0)
    for _ in range(hand.tactile.tare_frames):
        pipeline.snapshot(raw, JointState(q, 0 * q, 0 * q, 0.0), np.zeros(3), True)
    raw[2, 5] = np.nan
    snap = pipeline.snapshot(raw, JointState(q, 0 * q, 0 * q, 0.0), np.zeros(3), False)
    assert snap.fault == "sensor_invalid" and hand.fingers[2].name in snap.fault_detail
    assert np.all(np.isfinite(snap.f_sensor))
    q_bad = q.copy()
    q_bad[3] = np.inf
    snap = pipeline.snapshot(np.full((n, 44), 2000.0), JointState(q_bad, 0 * q, 0 * q, 0.0), np.zeros(3), False)
    assert snap.fault == "sensor_invalid" and hand.joints[3].name in snap.fault_detail
    assert np.all(np.isfinite(snap.q))


def test_2_non_finite_goal_is_goal_invalid_and_never_sent(hand, objects, monkeypatch):
    from grasp_ctrl.controller import motion

    real = motion.FingertipMotion.next_goal
    calls = {"n": 0}

    def broken_next_goal(self):
        calls["n"] += 1
        q = real(self)
        if calls["n"] == 80:  # once, mid-reach: an IK step that blew up
            q = q * np.nan
        return q

    monkeypatch.setattr(motion.FingertipMotion, "next_goal", broken_next_goal)
    r = run_sim_trial(hand, objects["lego"], lambda w: load_policy("linear_mock", hand), 0, backend="mock")
    assert r.final_state == "fault" and r.reason == "goal_invalid"
    assert "non-finite goal" in r.fault_detail


# ---------------------------------------------------------------- 3. names never become paths outside the run
EVIL = "../../../../x"  # from RUN_DIR/trials/POLICY/ this climbs out of RUN_DIR


def test_3_object_names_are_safe_identifiers(tmp_path, capsys):
    lego = OBJECTS_TOML[OBJECTS_TOML.index("[objects.lego]") :].split("\n\n")[0]
    bad = _objects_file(tmp_path, "\n" + lego.replace("[objects.lego]", f'[objects."{EVIL}"]') + "\n")
    with pytest.raises(ConfigError, match="object names become directory names"):
        load_objects(bad)
    before = _files_under(tmp_path)
    assert (
        main(
            [
                "run",
                "--backend",
                "mock",
                "--object-file",
                str(bad),
                "--objects",
                EVIL,
                "--out",
                str(tmp_path / "a" / "b" / "run"),
                "--trials",
                "1",
                "--quiet",
                "--no-tick-logs",
            ]
        )
        == 2
    )
    assert EVIL in _err_line(capsys)
    assert _files_under(tmp_path) == before


def test_3_run_series_refuses_an_unsafe_profile_name_before_touching_files(tmp_path, hand, objects):
    evil = objects["lego"].with_params(name="../../escape")
    run_dir = tmp_path / "deep" / "run"
    with pytest.raises(UsageError, match="object name"):
        run_series(hand, [evil], ["linear_mock"], 1, 0, run_dir, progress=False, backend="mock")
    assert not (tmp_path / "deep").exists() and not (tmp_path / "escape").exists()


@pytest.mark.parametrize("spec", ["..", ".", "../../x", "/etc/passwd", "a/../../b", "", ".hidden", "oracle:scale=2"])
def test_3_policy_specs_map_to_one_safe_directory_name(spec):
    name = safe_name(spec)
    assert name not in ("", ".", "..") and "/" not in name and not name.startswith(".")


# ---------------------------------------------------------------- 4. a failed start leaves nothing behind
@pytest.mark.parametrize("bad", [["--policy", "no_such_policy"], ["--policy", "linear_mock", "no_such_policy"]])
def test_4_failed_start_leaves_no_run_directory_and_the_retry_works(tmp_path, capsys, monkeypatch, bad):

    run_dir = tmp_path / "run"
    assert (
        main(["run", "--backend", "mock", "--objects", "lego", "--trials", "1", "--out", str(run_dir), "--quiet", *bad])
        == 2
    )
    assert "no_such_policy" in _err_line(capsys)
    assert not run_dir.exists()

    def fake_trial_fn(hand, policies, settings=None, threads=1, **_kw):
        return lambda p, obj, k, seed, log: {
            "object": obj.name,
            "policy": p,
            "trial": k,
            "seed": seed,
            "success": True,
            "reason": None,
        }

    monkeypatch.setattr(episode_runner, "sim_trial_fn", fake_trial_fn)
    assert (
        main(["run", "--backend", "mock", "--objects", "lego", "--trials", "1", "--out", str(run_dir), "--quiet"]) == 0
    )
    assert (run_dir / "run.json").is_file() and not (run_dir / LOCK_FILE).exists()


# ---------------------------------------------------------------- 5. the run lock and atomic files
def _child_pid(alive: bool) -> tuple[int, subprocess.Popen | None]:
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    if alive:
        return proc.pid, proc
    proc.kill()
    proc.wait()
    return proc.pid, None


def _fake_records(monkeypatch):

    seen = []

    def fake_trial_fn(hand, policies, settings=None, threads=1, **_kw):
        def run(p, obj, k, seed, log):
            seen.append(log)
            if log is not None:
                log.write_text("t,state\n0.0,tare\n")
            return {"object": obj.name, "policy": p, "trial": k, "seed": seed, "success": True, "reason": None}

        return run

    monkeypatch.setattr(episode_runner, "sim_trial_fn", fake_trial_fn)
    return seen


def test_5_resume_is_refused_while_another_process_holds_the_run(tmp_path, capsys, monkeypatch):
    _fake_records(monkeypatch)
    run_dir = tmp_path / "run"
    assert (
        main(["run", "--backend", "mock", "--objects", "lego", "--trials", "1", "--out", str(run_dir), "--quiet"]) == 0
    )
    record_path(run_dir, DEFAULT_POLICY, "lego", 0).unlink()
    pid, proc = _child_pid(alive=True)
    try:
        (run_dir / LOCK_FILE).write_text(json.dumps({"pid": pid, "host": os.uname().nodename, "started": "x"}))
        assert main(["run", "--resume", str(run_dir), "--quiet"]) == 2
        assert f"in use by process {pid}" in _err_line(capsys)
        assert not record_path(run_dir, DEFAULT_POLICY, "lego", 0).exists()
    finally:
        proc.kill()
        proc.wait()


def test_5_a_stale_lock_is_taken_over_with_a_warning(tmp_path, capsys, monkeypatch):
    _fake_records(monkeypatch)
    run_dir = tmp_path / "run"
    assert (
        main(["run", "--backend", "mock", "--objects", "lego", "--trials", "2", "--out", str(run_dir), "--quiet"]) == 0
    )
    record_path(run_dir, DEFAULT_POLICY, "lego", 1).unlink()
    pid, _ = _child_pid(alive=False)
    (run_dir / LOCK_FILE).write_text(json.dumps({"pid": pid, "host": os.uname().nodename, "started": "x"}))
    leftover = temp_path(record_path(run_dir, DEFAULT_POLICY, "lego", 1))
    leftover.write_text("{half a rec")  # a dead writer's temporary file
    capsys.readouterr()
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 0
    assert f"stale lock of process {pid}" in capsys.readouterr().err
    assert record_path(run_dir, DEFAULT_POLICY, "lego", 1).is_file()
    assert not leftover.exists() and not (run_dir / LOCK_FILE).exists()


def test_5_tick_logs_are_written_under_a_unique_temporary_name_then_renamed(tmp_path, hand, objects, monkeypatch):
    seen = _fake_records(monkeypatch)
    run_dir = tmp_path / "run"
    run_series(hand, [objects["lego"]], ["linear_mock"], 2, 0, run_dir, progress=False, backend="mock")
    finals = [ticks_path(run_dir, "linear_mock", "lego", k) for k in range(2)]
    assert all(log is not None and log not in finals and log.name.startswith(".") for log in seen)
    assert len(set(seen)) == 2
    assert all(p.read_text().startswith("t,state") for p in finals)
    assert not [p for p in run_dir.rglob("*") if p.name.endswith(".tmp")]
    a, b = temp_path(finals[0]), temp_path(finals[0])
    assert a != b and str(os.getpid()) in a.name


# ---------------------------------------------------------------- 6. run.json revalidated on resume
@pytest.mark.parametrize(
    "edit, field",
    [
        (lambda d: d["objects"][0].update(tau_n=float("nan")), "objects.lego.tau_n"),
        (lambda d: d["objects"][0].update(tau_n=-1.0), "objects.lego.tau_n"),
        (lambda d: d["objects"][0].update(mass_kg=0.0), "objects.lego.mass_kg"),
        (lambda d: d["objects"][0].update(name="../../x"), "name"),
        (lambda d: d.update(seed=-1), "seed"),
        (lambda d: d.update(trials=0), "trials"),
        (lambda d: d.update(backend="laser"), "backend"),
        (lambda d: d["settings"].update(ramp_timeout_s=float("inf")), "settings.ramp_timeout_s"),
        (lambda d: d["settings"].update(close_speed_m_s=-0.1), "settings.close_speed_m_s"),
        (lambda d: d.update(objects="lego"), "objects"),
    ],
)
def test_6_a_bad_run_json_is_refused_on_resume_naming_the_field(tmp_path, capsys, monkeypatch, edit, field):
    _fake_records(monkeypatch)
    run_dir = tmp_path / "run"
    assert (
        main(["run", "--backend", "mock", "--objects", "lego", "--trials", "1", "--out", str(run_dir), "--quiet"]) == 0
    )
    doc = json.loads((run_dir / "run.json").read_text())
    edit(doc)
    (run_dir / "run.json").write_text(json.dumps(doc))
    record_path(run_dir, DEFAULT_POLICY, "lego", 0).unlink()
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 2
    line = _err_line(capsys)
    assert "run.json" in line and field in line
    assert not record_path(run_dir, DEFAULT_POLICY, "lego", 0).exists()


# ---------------------------------------------------------------- 7. policy files
@pytest.mark.parametrize("name", list_policy_names())
def test_7_every_shipped_policy_loads_with_its_hash_and_graph_checked(name, hand):
    est = load_policy(name, hand)
    assert est.estimate(np.zeros((0, 44)), []).f_sensor.shape == (0, 3)


@pytest.mark.parametrize(
    "name, edit, message",
    [
        (
            "icra19_official",
            lambda m: m.update(model_sha256="0" * 64),
            "model_sha256: icra19_official.onnx has SHA-256",
        ),
        ("icra19_official", lambda m: m.pop("model_sha256"), "model_sha256: required key is missing"),
        ("icra19_official", lambda m: m.update(model_sha256="nope"), "model_sha256: 64 hexadecimal digits"),
        (
            "icra19_official",
            lambda m: m["input"]["tensors"]["electrode_voxels"].update(dtype="float64"),
            "input.tensors.electrode_voxels.dtype: metadata says float64",
        ),
        (
            "icra19_official",
            lambda m: m["output"]["tensors"]["force"].update(shape=["batch", 4]),
            "output.tensors.force.shape",
        ),
        (
            "icra19_dropout_official",
            lambda m: m["output"]["tensors"]["force_heads"].update(shape=["batch", 9, 3]),
            "output.tensors.force_heads.shape",
        ),
        (
            "su_rigid_ft_mock",
            lambda m: m["input"]["tensors"]["electrodes"].update(shape=["batch", 18]),
            "input.tensors.electrodes.shape",
        ),
        (
            "su_rigid_ft_mock",
            lambda m: m["output"]["tensors"]["f_sensor"].update(dtype="int64"),
            "output.tensors.f_sensor.dtype",
        ),
        ("su_rigid_ft_mock", lambda m: m["input"]["tensors"].pop("pdc"), "needs ['pdc'], not in the metadata"),
        ("su_rigid_ft_mock", lambda m: m.update(input=["electrodes"]), "malformed policy metadata"),
    ],
)
def test_7_policy_file_problems_are_one_line_naming_file_and_field(tmp_path, hand, name, edit, message):
    path = copy_policy(tmp_path, edit, name)
    with pytest.raises(PolicyError) as info:
        load_policy(str(path), hand)
    assert message in str(info.value) and str(path.name) in str(info.value)
    assert "\n" not in str(info.value)


def test_7_a_replaced_model_file_is_refused_before_it_is_parsed(tmp_path, hand, capsys):
    path = copy_policy(tmp_path, lambda m: None, "su_rigid_ft_mock")
    shutil.copy(policies_dir() / "voxel_alpha_mixed_mock.onnx", tmp_path / "su_rigid_ft_mock.onnx")
    assert (
        main(
            [
                "run",
                "--backend",
                "mock",
                "--policy",
                str(path),
                "--objects",
                "lego",
                "--trials",
                "1",
                "--out",
                str(tmp_path / "r"),
            ]
        )
        == 2
    )
    assert "model_sha256" in _err_line(capsys)
    assert not (tmp_path / "r").exists()


def test_7_checkpoints_load_weights_only(tmp_path):
    torch = pytest.importorskip("torch")
    from grasp_ctrl.learning.train import CHECKPOINT_FORMAT, load_checkpoint

    marker = tmp_path / "pwned"
    ckpt = tmp_path / "evil.pt"
    torch.save({"format": CHECKPOINT_FORMAT, "payload": _Exploit(str(marker))}, ckpt)
    with pytest.raises(ValueError, match="weights-only"):
        load_checkpoint(str(ckpt))
    assert not marker.exists()  # the pickled code never ran


class _Exploit:
    def __init__(self, path: str) -> None:
        self.path = path

    def __reduce__(self):
        return (Path.touch, (Path(self.path),))


# ---------------------------------------------------------------- 8. cross-field checks
@pytest.mark.parametrize(
    "replace, extra, key",
    [
        (("tip_force_n = 4.0\n", "tip_force_n = 4.0\ntau_n = 9.0\n"), "", "objects.lego.tau_n"),
        (
            ("tip_force_n = 4.0\n", "tip_force_n = 4.0\nrelease_threshold_n = -0.3\n"),
            "",
            "objects.lego.release_threshold_n",
        ),
        (
            ("tip_force_n = 4.0\n", "tip_force_n = 4.0\nrelease_threshold_n = 0.0\n"),
            "",
            "objects.lego.release_threshold_n",
        ),
        (("mass_kg = 0.06\n", "mass_kg = -0.06\n"), "", "objects.lego.mass_kg"),
        (('size_m = [0.032, 0.064]', 'size_m = [0.0, 0.064]'), "", "objects.lego.size_m"),
        (('finger = "index"', 'finger = "palm"'), "", "objects.mustard_bottle.cap.finger"),
    ],
)
def test_8_cross_field_and_bound_errors_name_the_field(tmp_path, capsys, replace, extra, key):
    path = _objects_file(tmp_path, extra, replace)
    obj = key.split(".")[1]
    run_dir = tmp_path / "run"
    assert (
        main(
            [
                "run",
                "--backend",
                "mock",
                "--object-file",
                str(path),
                "--objects",
                obj,
                "--trials",
                "1",
                "--out",
                str(run_dir),
                "--quiet",
            ]
        )
        == 2
    )
    line = _err_line(capsys)
    assert str(path) in line and key in line
    assert not run_dir.exists()


@pytest.mark.parametrize("seed", ["-1", "-99999999999999999999", str(2**63)])
def test_8_negative_or_huge_seed_is_one_line(tmp_path, capsys, seed):
    assert (
        main(
            [
                "run",
                "--backend",
                "mock",
                "--seed",
                seed,
                "--objects",
                "lego",
                "--trials",
                "1",
                "--out",
                str(tmp_path / "r"),
            ]
        )
        == 2
    )
    assert "--seed" in _err_line(capsys)
    assert not (tmp_path / "r").exists()


def test_8_contact_threshold_zero_is_refused(tmp_path):
    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.files.paths import default_hand_file

    text = Path(default_hand_file()).read_text()
    assert "contact_pdc_threshold" in text
    import re

    bad = re.sub(r"contact_pdc_threshold\s*=\s*[0-9.]+", "contact_pdc_threshold = 0.0", text)
    path = tmp_path / "hand.toml"
    path.write_text(bad)
    with pytest.raises(ConfigError, match="tactile.contact_pdc_threshold"):
        load_hand(path)


# ---------------------------------------------------------------- 9. records name what failed
def test_9_a_mock_servo_fault_names_the_servo_in_the_record(hand, objects):
    from grasp_ctrl.sim.mock import backends

    def on_tick(world, ctrl):
        if ctrl.state == "close" and getattr(world, "_broke", False) is False:
            world._broke = True
            injected["hand"].fault = "id 7: overheating (status 0x04)"

    injected: dict = {}
    real_init = backends.MockHand.__init__

    def spy_init(self, *a, **k):
        real_init(self, *a, **k)
        injected["hand"] = self

    mp = pytest.MonkeyPatch()
    mp.setattr(backends.MockHand, "__init__", spy_init)
    try:
        r = run_sim_trial(
            hand, objects["lego"], lambda w: load_policy("linear_mock", hand), 0, on_tick=on_tick, backend="mock"
        )
    finally:
        mp.undo()
    assert r.reason == "hardware_error"
    assert "id 7" in r.fault_detail and "0x04" in r.fault_detail
    assert r.controller["detail"] == r.fault_detail


def test_9_overforce_names_the_fingertip_and_the_force(hand, objects):
    from grasp_ctrl.sim.oracle import OracleEstimator

    r = run_sim_trial(
        hand, objects["lego"], lambda w: OracleEstimator(w, 100.0, name="oracle:scale=100"), 0, backend="mock"
    )
    assert r.reason == "overforce"
    assert "N >" in r.fault_detail and any(f.name in r.fault_detail for f in hand.fingers)


# ---------------------------------------------------------------- 10. hand-check: temperature, voltage, error bits
def test_10_hand_check_shows_temperature_voltage_and_flags_a_hot_servo(tmp_path, capsys):
    from grasp_ctrl.emulators.dxl_chain import DynamixelChainEmulator
    from grasp_ctrl.emulators.dxl_servo import PRESENT_INPUT_VOLTAGE, PRESENT_TEMPERATURE
    from tests.dxl_helpers import leap, leap_file

    if not hasattr(os, "openpty"):
        pytest.skip("needs POSIX pseudo-terminals")
    with DynamixelChainEmulator.for_hand(leap()) as emu:
        emu.servo(5).set(PRESENT_TEMPERATURE, 68)  # limit 70 degC
        emu.servo(9).set(PRESENT_INPUT_VOLTAGE, 40)  # 4.0 V, below 5.5 V
        emu.inject_hardware_error(13, 0x24)  # overheating + overload
        assert main(["hand-check", "--hand", str(leap_file(tmp_path)), "--port", emu.port]) == 1
    cap = capsys.readouterr()
    assert "temp_C" in cap.out and "input_V" in cap.out
    assert " 30 " in cap.out and " 12.0 " in cap.out  # every servo's reading
    assert "(id 5): HOT 68 degC" in cap.err
    assert "(id 9): INPUT VOLTAGE 4.0 V" in cap.err
    assert "(id 13): HARDWARE ERROR overheating,overload (status 0x24" in cap.err


# ---------------------------------------------------------------- done when: interrupted == uninterrupted
def test_interrupted_run_of_every_default_object_resumes_to_the_same_summary(tmp_path, capsys, monkeypatch):
    """Real mock trials of the default set (mustard bottle and its cap included): Ctrl-C
    during the fourth trial, then 'run --resume', gives the uninterrupted run's summary."""
    from grasp_ctrl.config.objects import default_set

    names = default_set(default_objects_file())
    assert "mustard_bottle" in names
    full, cut = tmp_path / "full", tmp_path / "cut"
    assert main(["run", "--backend", "mock", "--trials", "1", "--out", str(full), "--quiet", "--no-tick-logs"]) == 0

    real = episode_runner.sim_trial_fn
    calls = {"n": 0}

    def interrupted_fn(*a, **k):
        run = real(*a, **k)

        def trial(*args):
            calls["n"] += 1
            if calls["n"] == 4:
                raise KeyboardInterrupt  # the operator's Ctrl-C, mid-trial
            return run(*args)

        return trial

    monkeypatch.setattr(episode_runner, "sim_trial_fn", interrupted_fn)
    assert main(["run", "--backend", "mock", "--trials", "1", "--out", str(cut), "--quiet", "--no-tick-logs"]) == 130
    assert len(load_records(cut).records) == 3 and not (cut / LOCK_FILE).exists()
    monkeypatch.setattr(episode_runner, "sim_trial_fn", real)
    capsys.readouterr()
    assert main(["run", "--resume", str(cut), "--quiet"]) == 0
    a = json.loads((full / "summary.json").read_text())
    b = json.loads((cut / "summary.json").read_text())
    assert set(b["policies"][DEFAULT_POLICY]["objects"]) == set(names)
    assert {k: v for k, v in a.items() if k != "run_dir"} == {k: v for k, v in b.items() if k != "run_dir"}
    for name in names:  # and trial by trial, the same outcome
        ra = json.loads(record_path(full, DEFAULT_POLICY, name, 0).read_text())
        rb = json.loads(record_path(cut, DEFAULT_POLICY, name, 0).read_text())
        assert (ra["success"], ra["reason"], ra["sim_duration_s"]) == (
            rb["success"],
            rb["reason"],
            rb["sim_duration_s"],
        )
