"""`run --hand allegro --backend allegro_can --emulate --realtime`: the Allegro's wall-clock dry run.
The control loop ticks every 10 ms of wall time while the backend's PD thread runs at 333 Hz
against the emulator; each record keeps both loops' figures (``timings.loop`` and its
``pd_loop``), the summary gathers them. And the lockstep emulation against MuJoCo on one trial.

Trials here are cut short (a second or two of loop): the figures are asserted on their
structure and on bounds a loaded host cannot break."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.trials.episode import runner
from grasp_ctrl.trials.runs.summary import format_table, summarize

pytest.importorskip("can")
pytest.importorskip("mujoco")
pytestmark = pytest.mark.skipif(not hasattr(__import__("os"), "openpty"), reason="needs POSIX pseudo-terminals")

ROOT = Path(__file__).resolve().parents[2]
ALLEGRO = ROOT / "hand_configs" / "allegro_hand.toml"


@pytest.fixture(autouse=True)
def _temp_in_tmp_path(tmp_path, monkeypatch):
    """The bridge emulator's port link directory (tempfile.mkdtemp) goes under tmp_path too."""
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))


@pytest.fixture(scope="module")
def allegro():
    return load_hand(ALLEGRO)


@pytest.fixture(scope="module")
def allegro_objects(allegro):
    from grasp_ctrl.config.objects import load_objects

    return load_objects(ROOT / "hand_configs" / "objects.toml", allegro.name)


def test_a_realtime_trial_records_the_pd_loop_beside_the_control_loop(allegro, allegro_objects) -> None:
    from grasp_ctrl.emulators.allegro_can_world import allegro_realtime_backends
    from grasp_ctrl.sim.mujoco.backends import make_world
    from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial, trial_seed

    loop_s = 1.5

    def stop(world, ctrl) -> None:
        if world.t > loop_s and not ctrl.terminal:
            ctrl.fail(reason="aborted", detail="test: stop early")

    r = run_sim_trial(
        allegro,
        allegro_objects["lego"],
        estimator_factory("oracle", allegro),
        trial_seed(0, "lego", 0),
        "oracle",
        make_world=make_world,
        make_backends=allegro_realtime_backends,
        backend="allegro_can-emulated",
        on_tick=stop,
        realtime=True,
    )
    loop = r.to_json()["timings"]["loop"]
    assert r.reason == "aborted" and r.sim_duration_s >= loop_s
    assert loop["clock"] == "wall" and loop["period_ms"] == pytest.approx(10.0) and loop["bus"] == "can socketpair"
    assert loop["ticks"] >= 150 and 0 <= loop["deadline_misses"] <= loop["ticks"]
    assert loop["world_steps"] >= loop["ticks"]
    pd = loop["pd_loop"]
    assert pd["rate_hz"] == pytest.approx(333.0) and pd["budget_ms"] == pytest.approx(3.003)
    # the thread's periods over the trial's loop (about 2 s of wall time with the settle): 333 a second
    wall_s = loop["ticks"] * 0.010
    assert 0.5 * 333 * wall_s <= pd["periods"] + pd["missed_periods"] <= 1.5 * 333 * wall_s
    p = pd["period_ms"]
    assert 0.0 < p["p50"] <= p["p90"] <= p["p99"] <= p["max"]
    assert 2.5 < p["p50"] < 4.0  # the deadline schedule's period (generous: a loaded 2-core host)
    assert isinstance(pd["missed_periods"], int) and pd["missed_periods"] >= 0
    assert pd["scheduling"].startswith(("SCHED_FIFO", "nice"))  # what the PD process got


def test_realtime_cli_run_on_the_allegro(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.setattr(runner, "MAX_TRIAL_S", 1.0)  # trials end (aborted) after 1 s of trial time
    run_dir, summary_file = tmp_path / "rt", tmp_path / "summary.json"
    args = ["run", "--hand", str(ALLEGRO), "--backend", "allegro_can", "--emulate", "--realtime"]
    args += ["--objects", "lego", "--policy", "oracle", "--trials", "1", "--yes", "--quiet", "--out", str(run_dir)]
    assert main([*args, "--json", str(summary_file)]) == 0
    out, err = capsys.readouterr()
    assert "pre-flight: 16 joints reported on CAN bus socketpair allegro-emulated-" in err
    assert "no hand faults" in err and "servos" not in err
    rec = json.loads((run_dir / "trials" / "oracle" / "lego" / "trial_000.json").read_text())
    assert rec["backend"] == "allegro_can-emulated"
    pd = rec["timings"]["loop"]["pd_loop"]
    entry = json.loads(summary_file.read_text())["policies"]["oracle"]["objects"]["lego"]
    assert entry["loop"]["pd_loop"]["periods"] == pd["periods"]
    assert entry["loop"]["pd_loop"]["missed_periods"] == pd["missed_periods"]
    assert "wall-clock loop (realtime dry run, 10 ms budget):" in out
    assert f"oracle / lego: PD loop period p50 {pd['period_ms']['p50']:.2f} ms" in out
    assert f"(budget 3.0 ms); missed {pd['missed_periods']} of {pd['periods']} periods" in out
    assert json.loads((run_dir / "run.json").read_text())["realtime"] is True


def _loop(p50: float, p99: float, misses: int, pd: dict | None) -> dict:
    cycle = {"p50": p50, "p90": p99 - 1, "p99": p99, "max": p99 + 1}
    out = {"period_ms": 10.0, "ticks": 100, "deadline_misses": misses, "cycle_ms": cycle, "bus": "can virtual"}
    return out | ({"pd_loop": pd} if pd is not None else {})


def _pd(p50: float, p99: float, missed: int, periods: int = 300) -> dict:
    return {
        "rate_hz": 333.0,
        "budget_ms": 3.003,
        "periods": periods,
        "period_ms": {"p50": p50, "p90": p99 - 0.5, "p99": p99, "max": p99 + 2},
        "missed_periods": missed,
    }


def test_the_summary_gathers_the_pd_loops_figures() -> None:
    def record(trial: int, loop: dict) -> dict:
        timings = {"state_s": {"tare": 0.5}, "loop": loop}
        return {"policy": "p", "object": "lego", "trial": trial, "success": True, "reason": None, "timings": timings}

    records = [
        record(0, _loop(1.0, 5.0, 1, _pd(3.0, 4.0, 2))),
        record(1, _loop(1.0, 5.0, 0, _pd(3.1, 5.5, 1))),
        record(2, _loop(1.0, 5.0, 0, {"periods": "many"})),  # hand-edited: left out
        record(3, _loop(1.0, 5.0, 0, None)),  # a servo hand's record
    ]
    summary = summarize(records, "run", "allegro_can-emulated", "allegro_hand", 0)
    pd = summary["policies"]["p"]["objects"]["lego"]["loop"]["pd_loop"]
    assert pd["periods"] == 600 and pd["missed_periods"] == 3
    assert pd["period_ms"] == {"p50": 3.05, "p90": 5.0, "p99": 5.5, "max": 7.5}  # median p50, worst rest
    assert pd["rate_hz"] == 333.0 and pd["budget_ms"] == 3.003
    table = format_table(summary)
    assert "p / lego: PD loop period p50 3.05 ms, p99 5.50 ms, max 7.5 ms (budget 3.0 ms); missed 3 of 600" in table
    servo_only = summarize([record(0, _loop(1.0, 5.0, 1, None))], "run", "dynamixel-emulated", "leap_hand", 0)
    assert "pd_loop" not in servo_only["policies"]["p"]["objects"]["lego"]["loop"]
    assert "PD loop" not in format_table(servo_only)


def test_the_emulated_hand_runs_a_trial_as_mujoco_does(allegro, allegro_objects) -> None:
    """Lockstep: one lego trial (oracle, grip_load controller, nominal world) through the CAN path
    and on MuJoCo's own backends: the same outcome and states, the lift within a few mm."""
    from grasp_ctrl.controller.registry import settings_for
    from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial, trial_seed

    obj = allegro_objects["lego"]
    settings = settings_for("grip_load", allegro)
    runs = {}
    for backend in ("mujoco", "allegro_can-emulated"):
        runs[backend] = run_sim_trial(
            allegro,
            obj,
            estimator_factory("oracle", allegro),
            trial_seed(0, obj.name, 0),
            "oracle",
            settings=settings,
            backend=backend,
        )
    sim, emu = runs["mujoco"], runs["allegro_can-emulated"]
    assert sim.success, (sim.reason, sim.fault_detail)
    assert (emu.success, emu.reason, emu.final_state) == (sim.success, sim.reason, sim.final_state)
    assert [b for _, _, b in emu.transitions] == [b for _, _, b in sim.transitions]
    assert abs(emu.max_object_z_m - sim.max_object_z_m) < 0.005
    # the same timeline, within a few ticks a state
    t_sim = np.array([t for t, _, _ in sim.transitions])
    t_emu = np.array([t for t, _, _ in emu.transitions])
    assert np.max(np.abs(t_sim - t_emu)) < 1.0
