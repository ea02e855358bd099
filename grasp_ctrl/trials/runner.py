"""Run lift-and-place trials on the mock world and series of them.

One trial: tare in free space, then the controller runs until done or fault,
then the world settles for a moment under the safe action so consequences
(a dropped object) are seen; the outcome comes from the world's ground truth.
"""

from __future__ import annotations

import json
import os
import sys
import time
import zlib
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.controller.settings import ControllerSettings
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.estimators.base import ForceEstimator
from grasp_ctrl.estimators.registry import load_policy
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.sim.backends import MockArm, MockHand, MockSensors
from grasp_ctrl.sim.oracle import OracleEstimator, is_oracle, parse_oracle
from grasp_ctrl.sim.world import MockWorld, WorldParams
from grasp_ctrl.trials.outcome import judge
from grasp_ctrl.trials.pipeline import SensingPipeline
from grasp_ctrl.trials.summary import summarize
from grasp_ctrl.trials.ticklog import TickLog

MAX_TRIAL_S = 60.0
SETTLE_S = 0.5


@dataclass
class TrialResult:
    object: str
    policy: str
    trial: int
    seed: int
    success: bool
    reason: str | None
    final_state: str
    sim_duration_s: float
    wall_duration_s: float
    peak_grip_est_n: float
    peak_grip_true_n: float
    max_object_z_m: float
    transitions: list[tuple[float, str, str]] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list)
    settings: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def trial_seed(seed: int, obj_name: str, trial: int) -> int:
    """Same seed for the same object and trial index whatever the policy (paired comparison)."""
    ss = np.random.SeedSequence([seed, zlib.crc32(obj_name.encode()), trial])
    return int(ss.generate_state(1)[0])


EstimatorFactory = Callable[[MockWorld], ForceEstimator]


def estimator_factory(spec: str, hand: HandConfig, threads: int = 1) -> EstimatorFactory:
    """Oracles read each trial's world; other policies are loaded once and shared."""
    if is_oracle(spec):
        scale = parse_oracle(spec)
        return lambda world: OracleEstimator(world, scale, name=spec)
    est = load_policy(spec, hand, threads)
    return lambda world: est


def run_mock_trial(
    hand: HandConfig,
    obj: ObjectProfile,
    make_estimator: EstimatorFactory,
    seed: int,
    policy_name: str = "",
    trial: int = 0,
    settings: ControllerSettings | None = None,
    world_params: WorldParams | None = None,
    log_path: Path | None = None,
    kin: HandKinematics | None = None,
    on_tick: Callable[[MockWorld, GraspController], None] | None = None,
) -> TrialResult:
    wall0 = time.perf_counter()
    kin = kin or HandKinematics(hand)
    world = MockWorld(hand, obj, seed, world_params)
    hand_backend, arm, sensors = MockHand(world, hand), MockArm(world, hand), MockSensors(world)
    hand_backend.connect()
    arm.connect()
    sensors.start()
    estimator = make_estimator(world)
    pipeline = SensingPipeline(hand, kin, estimator)
    ctrl = GraspController(hand, obj, world.reach_pose_world(), settings, kin)
    names = pipeline.names
    grasp = np.array([f.grasp for f in hand.fingers])
    log = TickLog(log_path, names, len(hand.joints), truth=True) if log_path else None
    peak_est = peak_true = 0.0
    settle_ticks = int(round(SETTLE_S / hand.dt))
    try:
        while world.t < MAX_TRIAL_S:
            world.step()
            world.set_phase(ctrl.state)  # type: ignore[attr-defined]
            fault = None
            try:
                hand_backend.check_health()
                raw = pipeline.frames_matrix(sensors.read_latest(), world.t)
            except HardwareError as exc:
                fault = exc.reason
                raw = pipeline.raw
            snap = pipeline.snapshot(raw, hand_backend.read(), arm.position(), ctrl.state == "tare", fault)  # type: ignore[attr-defined]
            cmd = ctrl.tick(snap)
            if not cmd.torque_on:
                hand_backend.set_torque(False)
            hand_backend.write_goals(cmd.q_goal)
            arm.command(cmd.p_palm_world)
            peak_est = max(peak_est, float(np.max(snap.grip_n[grasp], initial=0.0)))
            peak_true = max(peak_true, float(np.max(world.normal_n[grasp], initial=0.0)))
            if log:
                log.append(ctrl.state, snap, cmd, pipeline.tared, world.f_sensor, world.obj_z, world.table_n)  # type: ignore[attr-defined]
            if on_tick:
                on_tick(world, ctrl)
            if ctrl.terminal:
                settle_ticks -= 1
                if settle_ticks <= 0:
                    break
        else:
            if not ctrl.terminal:
                ctrl.fail(reason="aborted")
    finally:
        if log:
            log.close()
        hand_backend.close()
        arm.close()
        sensors.close()
    success, reason = judge(world, ctrl)
    return TrialResult(
        object=obj.name,
        policy=policy_name,
        trial=trial,
        seed=seed,
        success=success,
        reason=reason,
        final_state=ctrl.state,  # type: ignore[attr-defined]
        sim_duration_s=round(world.t, 4),
        wall_duration_s=round(time.perf_counter() - wall0, 4),
        peak_grip_est_n=round(peak_est, 4),
        peak_grip_true_n=round(peak_true, 4),
        max_object_z_m=round(world.max_obj_z, 5),
        transitions=[(round(t, 3), a, b) for t, a, b in ctrl.history],
        events=[{"t": round(e.t, 3), "kind": e.kind, "detail": e.detail} for e in world.events],
        settings={
            "tau_n": obj.tau_n,
            "release_threshold_n": obj.release_threshold_n,
            "release_debounce": obj.release_debounce,
            "lift_height_m": obj.lift_height_m,
            "on_fault": hand.safety.on_fault,
        },
    )


def _write_json(path: Path, doc: Any) -> None:
    """Write atomically and fsync: a crash loses at most the trial in progress."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    with tmp.open("w", encoding="utf-8") as fh:
        json.dump(doc, fh, indent=2)
        fh.write("\n")
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def run_series(
    hand: HandConfig,
    objects: Sequence[ObjectProfile],
    policies: Sequence[str],
    trials: int,
    seed: int,
    run_dir: Path,
    settings: ControllerSettings | None = None,
    progress: bool = True,
    tick_logs: bool = True,
    threads: int = 1,
) -> dict[str, Any]:
    """objects x policies x trials on the mock world with shared seeds; returns the summary."""
    run_dir.mkdir(parents=True, exist_ok=True)
    factories = {p: estimator_factory(p, hand, threads) for p in policies}
    kin = HandKinematics(hand)
    records: list[dict[str, Any]] = []
    total = len(objects) * len(policies) * trials
    done = 0
    for policy in policies:
        for obj in objects:
            out = run_dir / "trials" / _safe(policy) / obj.name
            out.mkdir(parents=True, exist_ok=True)
            for k in range(trials):
                s = trial_seed(seed, obj.name, k)
                result = run_mock_trial(
                    hand, obj, factories[policy], s, policy, k, settings,
                    log_path=out / f"trial_{k:03d}_ticks.csv" if tick_logs else None, kin=kin,
                )
                rec = result.to_json()
                _write_json(out / f"trial_{k:03d}.json", rec)
                records.append(rec)
                done += 1
                if progress:
                    mark = "ok" if result.success else result.reason
                    print(f"[{done}/{total}] {policy} {obj.name} trial {k}: {mark}", file=sys.stderr, flush=True)
    summary = summarize(records, str(run_dir), "mock", hand.name, seed)
    _write_json(run_dir / "summary.json", summary)
    return summary


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name)
