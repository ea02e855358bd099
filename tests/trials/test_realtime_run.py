"""`run --backend dynamixel --emulate --realtime`: the wall-clock dry run. The loop's pacing
(emulators/wall_clock.py), its figures in the trial record and the summary, a 16 ms latency
timer's misses and pre-flight warning, run.json's ``realtime`` and the flag's checks.

The trials here are cut short (a few seconds of loop): the figures are asserted on their
structure and on bounds a loaded host cannot break (the 16 ms timer makes every tick slow)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.emulators.wall_clock import WallClockLoop, percentiles_ms
from grasp_ctrl.emulators.world_rig import realtime_backends
from grasp_ctrl.errors import UsageError
from grasp_ctrl.estimators.registry import DEFAULT_POLICY
from grasp_ctrl.files.paths import REPO_ROOT
from grasp_ctrl.trials.episode import runner
from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial, trial_seed
from grasp_ctrl.trials.runs.manifest import RunManifest, read_manifest
from grasp_ctrl.trials.runs.summary import format_table, summarize

pytestmark = pytest.mark.skipif(not hasattr(__import__("os"), "openpty"), reason="needs POSIX pseudo-terminals")


@pytest.fixture(autouse=True)
def _temp_in_tmp_path(tmp_path, monkeypatch):
    """The bridge emulator's port link directory (tempfile.mkdtemp) goes under tmp_path too."""
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))


class FakeTime:
    """A clock that moves only when the loop sleeps or a tick 'works'."""

    def __init__(self) -> None:
        self.t = 100.0

    def clock(self) -> float:
        return self.t

    def sleep(self, s: float) -> None:
        self.t += s


def test_the_loop_paces_on_deadlines_counts_misses_and_catches_the_world_up() -> None:
    ft = FakeTime()
    loop = WallClockLoop(0.010, 0.010, clock=ft.clock, sleep=ft.sleep, max_catchup_s=0.05)
    steps: list[float] = []
    work = [0.003, 0.004, 0.025, 0.002, 0.002, 0.200, 0.001]  # seconds of tick work
    loop.start()
    for w in work:
        loop.wait_for_release()
        loop.step_world(lambda: steps.append(ft.t))
        loop.bus_s += w / 2
        ft.t += w
        loop.tick_done()
    assert loop.ticks == 7 and loop.misses == 2  # the 25 ms and the 200 ms tick
    # one step a tick, two after the 25 ms tick (whose successor starts at once, no burst),
    # after the 200 ms stall at most 50 ms of world (5 steps) and the rest counted as dropped
    assert loop.world_steps == len(steps) == 1 + 1 + 1 + 2 + 1 + 1 + 5
    assert loop.dropped_steps == 15
    figures = loop.figures()
    assert figures["ticks"] == 7 and figures["deadline_misses"] == 2
    assert figures["cycle_ms"]["max"] == pytest.approx(200.0)
    assert figures["bus_ms"]["max"] == pytest.approx(100.0)
    assert figures["world_behind_s"] == pytest.approx(0.15)
    assert set(figures["cycle_ms"]) == {"p50", "p90", "p99", "max"}
    assert percentiles_ms([]) == {}


def _short_realtime_trial(hand, objects, latency_ms: int, loop_s: float):
    """A realtime emulated trial stopped after ``loop_s`` of trial time (the controller faults
    'aborted' and settles)."""
    from grasp_ctrl.sim.mujoco.backends import make_world

    h = replace(hand, dynamixel=replace(hand.dynamixel, latency_timer_ms=latency_ms))

    def stop(world, ctrl) -> None:
        if world.t > loop_s and not ctrl.terminal:
            ctrl.fail(reason="aborted", detail="test: stop early")

    return run_sim_trial(
        h,
        objects["chips_can"],
        estimator_factory(DEFAULT_POLICY, h),
        trial_seed(0, "chips_can", 0),
        DEFAULT_POLICY,
        make_world=make_world,
        make_backends=realtime_backends,
        backend="dynamixel-emulated",
        on_tick=stop,
        realtime=True,
    )


def test_a_realtime_trial_records_its_loop_figures(hand, objects) -> None:
    r = _short_realtime_trial(hand, objects, 1, 1.5)
    loop = r.to_json()["timings"]["loop"]
    assert r.reason == "aborted" and "state_s" in r.timings  # the state timings are kept beside it
    assert loop["clock"] == "wall" and loop["period_ms"] == pytest.approx(10.0)
    assert loop["latency_timer_ms"] == 1 and loop["baud"] == hand.dynamixel.baud
    assert loop["ticks"] >= 50 and 0 <= loop["deadline_misses"] <= loop["ticks"]
    for key in ("cycle_ms", "bus_ms", "world_step_ms"):
        f = loop[key]
        assert 0.0 < f["p50"] <= f["p90"] <= f["p99"] <= f["max"]
    assert loop["bus_ms"]["p50"] <= loop["cycle_ms"]["p50"]  # the bus is part of the cycle
    # the world followed the wall clock: a step per tick, more after a slow one
    assert loop["world_steps"] >= loop["ticks"]
    assert r.sim_duration_s >= 1.5
    assert loop["cycle_ms"]["p50"] < 10.0  # generous: ~3 ms on a loaded 2-core machine


def test_a_16_ms_latency_timer_misses_its_deadlines(hand, objects) -> None:
    loop = _short_realtime_trial(hand, objects, 16, 1.0).to_json()["timings"]["loop"]
    assert loop["latency_timer_ms"] == 16
    # every state read waits a whole timer after its last full USB packet: no tick fits 10 ms
    assert loop["bus_ms"]["p50"] >= 16.0
    assert loop["deadline_misses"] >= loop["ticks"] // 2 > 0


def _fast_trials(monkeypatch, seconds: float) -> None:
    """Trials end (aborted) after ``seconds`` of trial time: the CLI path in a few seconds."""
    monkeypatch.setattr(runner, "MAX_TRIAL_S", seconds)


def test_realtime_cli_run_with_a_16_ms_hand_file(tmp_path, monkeypatch, capsys) -> None:
    hand_file = tmp_path / "slow_usb.toml"
    text = (REPO_ROOT / "hand_configs" / "leap_hand.toml").read_text()
    assert "latency_timer_ms = 1 " in text
    hand_file.write_text(text.replace("latency_timer_ms = 1 ", "latency_timer_ms = 16 ", 1))
    _fast_trials(monkeypatch, 1.0)
    run_dir, summary_file = tmp_path / "rt", tmp_path / "summary.json"
    args = ["run", "--backend", "dynamixel", "--emulate", "--realtime", "--hand", str(hand_file)]
    args += ["--objects", "lego", "--trials", "1", "--yes", "--quiet", "--out", str(run_dir)]
    assert main([*args, "--json", str(summary_file)]) == 0
    out, err = capsys.readouterr()
    # the pre-flight names the problem and the fix, and the run goes on
    assert "pre-flight: 16 servos answered" in err
    assert "pre-flight: warning: servo bus too slow for the 10 ms control tick" in err
    assert f"latency timer 16 ms, [dynamixel] latency_timer_ms in {hand_file.resolve()}" in err
    assert "fix: set latency_timer_ms = 1" in err
    rec = json.loads((run_dir / "trials" / DEFAULT_POLICY / "lego" / "trial_000.json").read_text())
    loop = rec["timings"]["loop"]
    assert loop["latency_timer_ms"] == 16 and loop["deadline_misses"] >= loop["ticks"] // 2 > 0
    # the summary carries the figures per object and the table prints them
    entry = json.loads(summary_file.read_text())["policies"][DEFAULT_POLICY]["objects"]["lego"]
    assert entry["loop"]["deadline_misses"] == loop["deadline_misses"] and entry["loop"]["latency_timer_ms"] == 16
    assert "wall-clock loop (realtime dry run, 10 ms budget):" in out
    assert f"deadline misses {loop['deadline_misses']} of {loop['ticks']} ticks, latency timer 16 ms" in out
    # run.json keeps it, so a resume is realtime too; the flag itself is not given again
    assert json.loads((run_dir / "run.json").read_text())["realtime"] is True
    assert read_manifest(run_dir).realtime is True
    assert main(["run", "--resume", str(run_dir), "--realtime", "--yes"]) == 2
    assert "drop --realtime" in capsys.readouterr().err


def test_realtime_flag_checks(tmp_path, capsys) -> None:
    out = str(tmp_path / "x")
    assert main(["run", "--backend", "dynamixel", "--realtime", "--objects", "lego", "--out", out]) == 2
    err = capsys.readouterr().err
    assert "--realtime: only with --backend dynamixel --emulate" in err and len(err.strip().splitlines()) == 1
    assert main(["run", "--backend", "mujoco", "--realtime", "--objects", "lego", "--out", out]) == 2
    assert "--realtime: only with" in capsys.readouterr().err
    args = ["run", "--backend", "dynamixel", "--emulate", "--realtime", "--jobs", "2", "--objects", "lego"]
    assert main([*args, "--yes", "--out", out]) == 2
    assert "--jobs: a --realtime dry run keeps one trial at a time" in capsys.readouterr().err
    assert not Path(out).exists()


def test_run_json_realtime_key(objects) -> None:
    m = RunManifest("dynamixel-emulated", "leap_hand", 0, 1, ["mlp_mock"], [objects["lego"]], realtime=True)
    doc = m.to_json()
    assert doc["realtime"] is True and RunManifest.from_json(doc, "run.json").realtime is True
    old = {k: v for k, v in doc.items() if k != "realtime"}  # a run.json from before the flag
    assert RunManifest.from_json(old, "run.json").realtime is False
    assert not RunManifest.from_json(old, "run.json").same_plan(m)
    with pytest.raises(UsageError, match=r"run.json: realtime: true or false"):
        RunManifest.from_json({**doc, "realtime": "yes"}, "run.json")
    with pytest.raises(UsageError, match=r"run.json: realtime: true only with backend dynamixel-emulated"):
        RunManifest.from_json({**doc, "backend": "mujoco"}, "run.json")


def _record(obj: str, trial: int, loop: dict | None) -> dict:
    timings = {"state_s": {"tare": 0.5}} | ({"loop": loop} if loop is not None else {})
    return {"policy": "p", "object": obj, "trial": trial, "success": True, "reason": None, "timings": timings}


def _loop(p50: float, p99: float, misses: int, ticks: int = 100) -> dict:
    cycle = {"p50": p50, "p90": p99 - 1, "p99": p99, "max": p99 + 1}
    return {"period_ms": 10.0, "ticks": ticks, "deadline_misses": misses, "cycle_ms": cycle, "latency_timer_ms": 1}


def test_the_summary_gathers_each_objects_loop_figures() -> None:
    records = [
        _record("lego", 0, _loop(3.0, 7.0, 1)),
        _record("lego", 1, _loop(5.0, 9.0, 2)),
        _record("lego", 2, {"ticks": "many"}),  # hand-edited: left out of the figures, not of the trial
        _record("cleanser", 0, None),
    ]
    summary = summarize(records, "run", "dynamixel-emulated", "leap_hand", 0)
    objs = summary["policies"]["p"]["objects"]
    assert objs["lego"]["trials"] == 3 and "loop" not in objs["cleanser"]
    loop = objs["lego"]["loop"]
    assert loop["trials"] == 2 and loop["ticks"] == 200 and loop["deadline_misses"] == 3
    assert loop["cycle_ms"] == {"p50": 4.0, "p90": 8.0, "p99": 9.0, "max": 10.0}  # median p50, worst rest
    assert loop["latency_timer_ms"] == 1 and loop["period_ms"] == 10.0
    table = format_table(summary)
    assert "wall-clock loop (realtime dry run, 10 ms budget):" in table
    assert "p / lego: cycle p50 4.0 ms, p99 9.0 ms, max 10.0 ms; deadline misses 3 of 200 ticks" in table
    plain = format_table(summarize([_record("lego", 0, None)], "run", "mujoco", "leap_hand", 0))
    assert "wall-clock" not in plain


def test_a_backend_without_wall_clock_links_is_refused_for_realtime(hand, objects):
    """The wall-clock loop needs the hand and sensor backends' declared hooks
    (emulators/wall_clock.py, WallClockHand and WallClockLink); the mock's have none."""
    from grasp_ctrl.trials.episode.runner import estimator_factory, run_sim_trial

    with pytest.raises(UsageError, match="do not run on the wall clock"):
        run_sim_trial(
            hand, objects["lego"], estimator_factory("oracle", hand), 0, "oracle", backend="mock", realtime=True
        )
