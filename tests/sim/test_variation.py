"""Variation profiles (sim/variation.py, ``--variation NAME``): the draws, what they do in the
MuJoCo world, and their plumbing (run.json, trial records, resume, workers, tune, lift-capacity)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.errors import UsageError
from grasp_ctrl.sim.mock.world import MockWorld, WorldParams
from grasp_ctrl.sim.mujoco.backends import MuJoCoHand
from grasp_ctrl.sim.mujoco.world import MuJoCoParams, MuJoCoWorld
from grasp_ctrl.sim.variation import (
    BENCH,
    NOMINAL,
    VARIATIONS,
    draw_object,
    max_rotated_half_extents,
    variation,
    variation_from_json,
)
from grasp_ctrl.trials.runs.manifest import RunManifest

SEEDS = (0, 1, 7, 12345)


def _old_draws(obj, seed):
    """The draws exactly as the worlds made them before the profiles existed."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-0.003, 0.003, size=2)
    mass = obj.mass_kg * (1.0 + 0.03 * rng.uniform(-1, 1))
    mu = obj.mu * (1.0 + 0.03 * rng.uniform(-1, 1))
    k = obj.stiffness_n_per_m * (1.0 + 0.05 * rng.uniform(-1, 1))
    return xy, mass, mu, k, rng


def test_the_registry_and_an_unknown_name_in_one_line(capsys):
    assert set(VARIATIONS) == {"bench", "nominal"} and variation("bench") is BENCH
    assert BENCH.describe().startswith("bench (placement +-10 mm, yaw +-10 deg, mass +-15 %, friction +-20 %")
    with pytest.raises(UsageError) as exc:
        variation("x")
    assert str(exc.value) == "--variation 'x': unknown (one of bench, nominal)"
    for argv in (
        ["run", "--backend", "mock", "--objects", "lego", "--trials", "1", "--variation", "x"],
        ["lift-capacity", "--variation", "x"],
        ["tune", "--object", "lego", "--param", "tau_n=2", "--variation", "x"],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()[-1]  # argparse's usage, then its one error line
        assert "argument --variation: invalid choice: 'x'" in err and "bench" in err and "nominal" in err, argv


def test_nominal_reproduces_the_old_draws_and_physics(hand, objects):
    obj = objects["lego"]
    for seed in SEEDS:
        xy, mass, mu, k, old_rng = _old_draws(obj, seed)
        world = MuJoCoWorld(hand, obj, seed)  # the library default: nominal
        assert world.params.variation == NOMINAL
        assert (world.mass, world.mu, world.k_contact) == (mass, mu, k)
        assert world.scene.xml.count(f'<body name="object" pos="{xy[0]:.9g} {xy[1]:.9g} 0">') == 1  # no quat
        assert world.yaw_rad == 0.0 and not world.joint_offset_rad.any()
        assert np.array_equal(world.q_measured, world.q)
        mock = MockWorld(hand, obj, seed)
        assert (mock.mass, mock.mu, mock.k_contact) == (mass, mu, k) and tuple(mock._obj[:2]) == tuple(xy)
        # The main stream is left where the old draws left it (the sensors' noise follows on it).
        rng = np.random.default_rng(seed)
        draw_object(rng, NOMINAL)
        assert rng.bit_generator.state == old_rng.bit_generator.state
        d = world.draw
        assert d["placement_m"] == [round(float(xy[0]), 7), round(float(xy[1]), 7)]
        assert d["mass_frac"] == pytest.approx(mass / obj.mass_kg - 1.0, abs=1e-6)


def test_bench_draws_lie_within_the_half_widths_and_vary_with_the_seed(hand, objects):
    obj = objects["cleanser"]
    params = MuJoCoParams(variation=BENCH)
    draws = []
    for seed in SEEDS:
        world = MuJoCoWorld(hand, obj, seed, params)
        d = world.draw
        draws.append(d)
        assert all(abs(x) <= BENCH.placement_m for x in d["placement_m"])
        assert abs(d["yaw_deg"]) <= BENCH.yaw_deg
        assert abs(d["mass_frac"]) <= BENCH.mass_frac and abs(d["friction_frac"]) <= BENCH.friction_frac
        assert abs(d["stiffness_frac"]) <= BENCH.stiffness_frac
        assert len(d["joint_offset_deg"]) == len(hand.joints)
        assert all(abs(o) <= BENCH.joint_offset_deg for o in d["joint_offset_deg"])
        assert world.mass == pytest.approx(obj.mass_kg * (1.0 + d["mass_frac"]), rel=1e-6)
        assert world.mu == pytest.approx(obj.mu * (1.0 + d["friction_frac"]), rel=1e-6)
        assert world.k_contact == pytest.approx(obj.stiffness_n_per_m * (1.0 + d["stiffness_frac"]), rel=1e-6)
        mock = MockWorld(hand, obj, seed, WorldParams(variation=BENCH))  # the mock: the same object draws
        assert (mock.mass, mock.mu) == (world.mass, world.mu) and mock.draw["yaw_deg"] == 0.0
    for key in ("yaw_deg", "mass_frac", "friction_frac", "stiffness_frac"):
        assert len({d[key] for d in draws}) == len(SEEDS), key
    assert len({tuple(d["joint_offset_deg"]) for d in draws}) == len(SEEDS)
    # Wider than nominal could ever draw, somewhere.
    assert max(abs(x) for d in draws for x in d["placement_m"]) > NOMINAL.placement_m
    assert max(abs(d["mass_frac"]) for d in draws) > NOMINAL.mass_frac


def test_the_yaw_turns_the_object_body(hand, objects):
    world = MuJoCoWorld(hand, objects["cleanser"], 3, MuJoCoParams(variation=BENCH))
    yaw = math.radians(world.draw["yaw_deg"])
    assert abs(yaw) > math.radians(1.0)  # seed 3 draws a clear yaw
    w, x, y, z = world.data.xquat[world._obj_body]
    assert abs(x) < 1e-6 and abs(y) < 1e-6  # still upright
    assert 2.0 * math.atan2(z, w) == pytest.approx(yaw, abs=1e-3)
    # The grasp height does not depend on the draw (the controller is told it), only on the profile.
    assert max_rotated_half_extents(0.1, 0.03, 0.0) == (0.1, 0.03)
    hx, hy = max_rotated_half_extents(0.1, 0.03, math.radians(10.0))
    assert hx > 0.1 * math.cos(math.radians(10.0)) and hy > 0.03


def test_a_joint_offset_shows_in_the_measured_angle_and_the_goal(hand, objects):
    world = MuJoCoWorld(hand, objects["lego"], 5, MuJoCoParams(variation=BENCH))
    offset = np.radians(world.draw["joint_offset_deg"])
    assert np.abs(offset).max() > math.radians(0.2)
    np.testing.assert_allclose(world.joint_offset_rad, offset, atol=1e-7)
    backend = MuJoCoHand(world, hand)
    backend.connect()
    state = backend.read()
    np.testing.assert_array_equal(state.q, world.q - world.joint_offset_rad)  # q_measured = q_true - offset
    # A goal of the measured angle is the joint's true angle: the joint holds still (a joint
    # resting on its limit may read beyond the hand file's limits: the backend clamps that goal).
    before = world.q
    backend.write_goals(state.q)
    inside = (state.q >= world.lower) & (state.q <= world.upper)
    assert inside.sum() >= len(inside) - 2
    np.testing.assert_allclose(world.q_goal[inside], before[inside], atol=1e-12)
    np.testing.assert_array_equal(world.q_goal_measured, np.clip(state.q, world.lower, world.upper))
    # It moves as a hand without offsets does under the same command (gravity takes the slack
    # the old goal held), not by its offsets.
    plain = MuJoCoWorld(hand, objects["lego"], 5)
    plain_backend = MuJoCoHand(plain, hand)
    plain_before = plain.q
    plain_backend.write_goals(plain_backend.read().q)
    for _ in range(10):
        world.step()
        plain.step()
    moved, plain_moved = world.q - before, plain.q - plain_before
    assert np.abs(moved - plain_moved)[inside].max() < 0.1 * np.abs(offset).max()
    # The goal goes to the joint shifted by its offset.
    goal = state.q + 0.01
    backend.write_goals(goal)
    np.testing.assert_allclose(world.q_goal, np.clip(goal + world.joint_offset_rad, world.lower, world.upper))


def test_the_emulated_servo_chain_reports_and_commands_calibrated_angles(hand, objects):
    from grasp_ctrl.emulators.world_hand import EmulatedDynamixelHand
    from grasp_ctrl.hardware.dynamixel.control_table import RAD_PER_COUNT

    world = MuJoCoWorld(hand, objects["lego"], 5, MuJoCoParams(variation=BENCH))
    emulated = EmulatedDynamixelHand(world, hand)
    emulated.connect()
    try:
        q = emulated.read().q
        np.testing.assert_allclose(q, world.q_measured, atol=RAD_PER_COUNT)
        assert np.abs(q - world.q).max() > 10 * RAD_PER_COUNT  # the offsets, not the truth
        emulated.write_goals(q)
        np.testing.assert_allclose(world.q_goal, np.clip(world.q, world.lower, world.upper), atol=2 * RAD_PER_COUNT)
    finally:
        emulated.close()


def _run(tmp_path, name, *extra):
    out = tmp_path / name
    argv = ["run", "--objects", "lego", "--policy", "oracle", "--trials", "1", "--out", str(out), "--quiet", *extra]
    return out, main([*argv, "--no-tick-logs"])


def test_run_records_the_variation_and_each_trial_its_draw_and_resume_refuses_the_flag(tmp_path, capsys):
    out, rc = _run(tmp_path, "bench")  # the command line's default: bench
    assert rc == 0
    assert "variation: bench (placement +-10 mm, yaw +-10 deg" in capsys.readouterr().out
    plan = json.loads((out / "run.json").read_text())
    assert plan["variation"] == BENCH.to_json()
    rec = json.loads((out / "trials" / "oracle" / "lego" / "trial_000.json").read_text())
    draw = rec["variation_draw"]
    assert set(draw) == {"placement_m", "yaw_deg", "mass_frac", "friction_frac", "stiffness_frac", "joint_offset_deg"}
    assert draw["yaw_deg"] != 0.0 and len(draw["joint_offset_deg"]) == 16
    assert main(["run", "--resume", str(out), "--variation", "nominal", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--variation" in err and "run.json" in err and err.count("\n") == 1
    assert main(["run", "--resume", str(out), "--quiet"]) == 0  # nothing left to run: same plan


def test_run_json_round_trip_old_runs_and_bad_fields(objects):
    m = RunManifest("mujoco", "leap_hand", 0, 1, ["oracle"], [objects["lego"]], variation=BENCH)
    assert RunManifest.from_json(m.to_json(), "run.json").variation == BENCH
    old = m.to_json()
    del old["variation"]  # a run from before the profiles drew the nominal ones
    assert RunManifest.from_json(old, "run.json").variation == NOMINAL
    hand_run = dict(m.to_json(), backend="dynamixel", variation=None)
    assert RunManifest.from_json(hand_run, "run.json").variation is None
    with pytest.raises(UsageError, match=r"^run.json: variation.mass_frac: a number from 0 to 0.99"):
        RunManifest.from_json(dict(m.to_json(), variation=dict(BENCH.to_json(), mass_frac=1.5)), "run.json")
    with pytest.raises(UsageError, match=r"^run.json: variation: a table"):
        variation_from_json([1], "run.json")
    # A nominal run keeps the fingerprint it had before the profiles; another profile is named.
    from grasp_ctrl.trials.runs.fingerprint import settings_digests

    nominal = dict(m.to_json(), variation=NOMINAL.to_json())
    assert "variation" not in settings_digests(nominal) and "variation" in settings_digests(m.to_json())
    assert not m.same_plan(RunManifest("mujoco", "leap_hand", 0, 1, ["oracle"], [objects["lego"]]))


def test_worker_processes_draw_under_the_run_s_variation(tmp_path, hand, objects):
    out, rc = _run(tmp_path, "jobs", "--backend", "mock", "--objects", "lego,paper_cup", "--jobs", "2")
    assert rc == 0
    for obj in ("lego", "paper_cup"):
        rec = json.loads((out / "trials" / "oracle" / obj / "trial_000.json").read_text())
        here = MockWorld(hand, objects[obj], rec["seed"], WorldParams(variation=BENCH))
        assert rec["variation_draw"] == here.draw and here.draw != MockWorld(hand, objects[obj], rec["seed"]).draw
        assert rec["variation_draw"]["yaw_deg"] == 0.0  # the mock has no yaw


def test_tune_studies_differ_by_variation_only_when_not_nominal(objects):
    pytest.importorskip("optuna")
    from grasp_ctrl.trials.tuning.search_space import parse_params
    from grasp_ctrl.trials.tuning.study import StudyPlan

    params = parse_params(["tau_n=1.5,2"])

    def plan(v):
        return StudyPlan(objects["lego"], params, 2, 0, "oracle", "mujoco", 2, variation=v)

    assert plan(None).identity() == plan(NOMINAL).identity()  # a study from before keeps its name
    assert plan(BENCH).identity()["variation"] == BENCH.to_json()
    assert plan(BENCH).study_name() != plan(NOMINAL).study_name()


def _lift_line(text, name):
    line = next(ln for ln in text.splitlines() if ln.split() and ln.split()[0] == name)
    weight, liftable, ratio = (float(x) for x in line.split()[1:4])
    return weight, liftable, ratio


def test_lift_capacity_uses_the_worst_corner(capsys):
    assert main(["lift-capacity", "--objects", "lego", "--variation", "nominal"]) == 0
    nominal = capsys.readouterr().out
    assert main(["lift-capacity", "--objects", "lego"]) == 0  # default bench
    bench = capsys.readouterr().out
    assert "worst corner, mass +15 % and friction -20 %" in bench and "worst corner" not in nominal
    w0, lift0, r0 = _lift_line(nominal, "lego")
    w1, lift1, r1 = _lift_line(bench, "lego")
    assert w1 == pytest.approx(1.15 * w0, abs=0.01) and w1 > w0
    assert lift1 < lift0 and r1 < r0  # less friction carries less
