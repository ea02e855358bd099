"""`run --backend dynamixel --emulate`: the whole hardware path on emulators, in CI;
the pre-flight check names a failing servo or fingertip."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.config.sensor_layout import PDC
from grasp_ctrl.emulators.dxl_chain import DynamixelChainEmulator
from grasp_ctrl.emulators.tactile_bridge import SyntheticSource, TactileBridgeEmulator
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.estimators.registry import DEFAULT_POLICY
from grasp_ctrl.trials.episode.preflight import preflight_hardware
from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial, trial_seed
from grasp_ctrl.trials.runs.manifest import read_manifest

pytestmark = pytest.mark.skipif(not hasattr(__import__("os"), "openpty"), reason="needs POSIX pseudo-terminals")


def test_one_emulated_trial_runs_like_mujoco(tmp_path, hand, objects, capsys):
    run_dir, summary_file = tmp_path / "emu", tmp_path / "summary.json"
    assert (
        main(
            [
                "run",
                "--backend",
                "dynamixel",
                "--emulate",
                "--objects",
                "chips_can",
                "--trials",
                "1",
                "--seed",
                "0",
                "--yes",
                "--out",
                str(run_dir),
                "--json",
                str(summary_file),
                "--quiet",
                "--variation",
                "nominal",
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "pre-flight: 16 servos answered" in err and "4 fingertips streaming and tareable" in err
    summary = json.loads(summary_file.read_text())
    assert summary["backend"] == "dynamixel-emulated"
    rec = json.loads((run_dir / "trials" / DEFAULT_POLICY / "chips_can" / "trial_000.json").read_text())
    assert rec["backend"] == "dynamixel-emulated" and rec["judged_by"] == "world"
    assert (run_dir / "trials" / DEFAULT_POLICY / "chips_can" / "trial_000_ticks.parquet").stat().st_size > 10_000
    # run.json (revalidated on resume) accepts the emulated backend: the finished run resumes to itself
    assert read_manifest(run_dir).backend == "dynamixel-emulated"
    assert main(["run", "--resume", str(run_dir), "--yes", "--quiet", "--json", str(tmp_path / "again.json")]) == 0
    assert json.loads((tmp_path / "again.json").read_text())["policies"] == summary["policies"]
    # The same trial on MuJoCo's own backends (the physics behind --emulate): the emulated links
    # quantise goals, joint counts and frames, nothing more (ramp 2.46 s here, 2.45 s there). A
    # trial whose ramp ends at its timeout is not a fair comparison: seed 4's first chips can
    # trial settles after 2.5 s on MuJoCo's backends and after 5.3-6.0 s emulated, where the
    # quantised goals decide whether the steady rule (controller/ramp_settle.py) fires in time.
    mock = run_sim_trial(
        hand,
        objects["chips_can"],
        estimator_factory(DEFAULT_POLICY, hand),
        trial_seed(0, "chips_can", 0),
        DEFAULT_POLICY,
        backend="mujoco",
    )
    assert rec["success"] == mock.success and rec["reason"] == mock.reason
    assert rec["sim_duration_s"] == pytest.approx(mock.sim_duration_s, abs=1.0)
    assert [b for _, _, b in rec["transitions"]] == [b for _, _, b in mock.transitions]


def test_the_start_must_be_confirmed(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr("builtins.input", lambda prompt: "n")
    run_dir = tmp_path / "emu"
    assert (
        main(
            ["run", "--backend", "dynamixel", "--emulate", "--objects", "lego", "--trials", "1", "--out", str(run_dir)]
        )
        == 1
    )
    err = capsys.readouterr().err
    assert "pre-flight:" in err and "not confirmed" in err and not run_dir.exists()
    assert main(["run", "--emulate", "--objects", "lego", "--out", str(run_dir)]) == 2
    assert "--emulate: only with --backend dynamixel" in capsys.readouterr().err


@pytest.fixture
def rig(hand):
    """A servo chain and a fingertip stream on ptys, as the real hand's ports."""
    slow_ok = replace(hand, dynamixel=replace(hand.dynamixel, packet_timeout_ms=40.0, retries=3))
    dxl = DynamixelChainEmulator.for_hand(slow_ok).start()
    yield slow_ok, dxl
    dxl.stop()


def _bridge(hand, source=None):
    bridge = TactileBridgeEmulator([f.sensor_id for f in hand.fingers], source or SyntheticSource(seed=1, free_s=60.0))
    bridge.start()
    return bridge


def test_preflight_passes_and_names_a_missing_servo(rig):
    hand, dxl = rig
    bridge = _bridge(hand)
    try:
        report = preflight_hardware(hand, port=dxl.port, sensor_port=bridge.port)
        assert len(report.servos) == len(hand.joints) and len(report.fingertips) == len(hand.fingers)
        joint = hand.joints[5]
        dxl.set_missing(joint.servo_id)
        with pytest.raises(HardwareError, match=rf"{joint.name} \(id {joint.servo_id}\)"):
            preflight_hardware(hand, port=dxl.port, sensor_port=bridge.port)
    finally:
        bridge.close()


def test_preflight_names_a_silent_and_a_pressed_fingertip(rig):
    hand, dxl = rig
    ring = next(f for f in hand.fingers if f.name == "ring")
    bridge = _bridge(hand)
    try:
        bridge.pause(30.0, [ring.sensor_id])
        with pytest.raises(HardwareError, match=r"ring \(sensor"):
            preflight_hardware(hand, port=dxl.port, sensor_port=bridge.port)
    finally:
        bridge.close()
    quiet = SyntheticSource(seed=2, free_s=60.0)

    def pressed(sensor_id: int, k: int) -> np.ndarray:
        frame = quiet(sensor_id, k)
        if sensor_id == ring.sensor_id:
            frame[PDC] += 8.0 * (k % 20)  # pdc pumping: somebody presses it
        return frame

    bridge = _bridge(hand, pressed)
    try:
        with pytest.raises(HardwareError, match=r"fingertip 'ring' .* cannot be tared"):
            preflight_hardware(hand, port=dxl.port, sensor_port=bridge.port)
    finally:
        bridge.close()


def test_an_overheating_servo_ends_the_trial_in_a_safe_stop_and_a_record(hand, objects):
    """On the Dynamixel backend (emulated, MuJoCo behind it) a servo that reports overheating in
    its Hardware Error Status mid-lift ends the trial: fault, reason hardware_error, the servo
    named in the record, the hand file's safe action (open) taken and the trial recorded."""
    from grasp_ctrl.emulators import world_rig
    from grasp_ctrl.sim.mujoco.backends import make_world

    rigs: list = []

    def backends(world, hand_cfg):
        pair = world_rig.emulated_backends(world, hand_cfg)
        rigs.append(pair[0])
        return pair

    def on_tick(world, ctrl):
        if ctrl.state == "lift" and not getattr(world, "_hot", False):
            world._hot = True
            rigs[0].emu.inject_hardware_error(14, 0x04)  # thumb_mcp, the joint raised to 1.2 A: overheating

    r = run_sim_trial(
        hand,
        objects["chips_can"],
        estimator_factory("oracle", hand),
        trial_seed(0, "chips_can", 0),
        "oracle",
        make_world=make_world,
        make_backends=backends,
        backend="dynamixel-emulated",
        on_tick=on_tick,
    )
    assert not r.success and r.reason == "hardware_error" and r.final_state == "fault"
    assert "thumb_mcp (id 14): overheating" in r.fault_detail
    assert [b for _, _, b in r.transitions][-1] == "fault"
    assert r.to_json()["controller"]["detail"] == r.fault_detail
