"""Lift-and-place trials on the real hand (``run --backend dynamixel``).

The same controller, sensing pipeline and tick as on the mock, driven by the
wall clock at the hand's control rate. There is no ground truth: the record
holds the controller's own view, and ``cmd_run`` asks the operator to label
each trial. The object is expected at the world origin on the table (the spot
the arm's frame is calibrated to); the hand reaches to ``grasp_height_m`` of its
profile (plus its ``approach_offset_m``) plus ``grasp.palm_above_contact_m``.

Safety: a hardware or sensor fault goes through the state machine to the safe
action; Ctrl-C (or SIGTERM) marks the trial ``aborted`` naming it, keeps ticking
the safe action for a moment, closes the rig (which stops the hand as configured)
and re-raises with the trial's record attached, so the series keeps it beside its
records, stops, and can be resumed.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.registry import default_settings, make_controller
from grasp_ctrl.errors import UsageError
from grasp_ctrl.estimators.base import ForceEstimator
from grasp_ctrl.estimators.registry import load_policy
from grasp_ctrl.hardware.base import FIRST_FRAMES_TIMEOUT_S
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.loop.sensing import SensingPipeline
from grasp_ctrl.loop.tick import control_tick
from grasp_ctrl.loop.ticklog import CurrentTap, TickLog
from grasp_ctrl.rigs.hardware_rig import HardwareRig, open_rig
from grasp_ctrl.sim.oracle import is_oracle
from grasp_ctrl.trials.episode.runner import (
    MAX_TRIAL_S,
    SETTLE_S,
    controller_view,
    first_interrupt,
    interrupted_record,
    state_timings,
    trial_settings,
    with_record,
)
from grasp_ctrl.trials.episode.warm_up import warm_kernels_once

RigOpener = Callable[[HandConfig], HardwareRig]
_sleep = time.sleep  # the tick pacing; tests replace it to inject an operator's Ctrl-C


def reach_pose_world(hand: HandConfig, obj: ObjectProfile) -> np.ndarray:
    """The profile's grasp height plus its ``approach_offset_m``, ``palm_above_contact_m`` higher."""
    return np.array([0.0, 0.0, obj.grasp_height_m + obj.approach_offset_m + hand.grasp.palm_above_contact_m])


def run_hardware_trial(
    hand: HandConfig,
    obj: ObjectProfile,
    rig: HardwareRig,
    estimator: ForceEstimator,
    settings: PaperSettings | None = None,
    kin: HandKinematics | None = None,
    log_path: Path | None = None,
    max_trial_s: float = MAX_TRIAL_S,
    sleep: Callable[[float], None] | None = None,
    raw_frames: bool = False,
) -> dict[str, Any]:
    """One trial on real (or emulated) hardware; returns the controller's view and timings.
    ``raw_frames``: the tick log keeps every raw frame whole."""
    kin = kin or HandKinematics(hand)
    sleep = sleep or _sleep
    pipeline = SensingPipeline(hand, kin, estimator)
    ctrl = make_controller(hand, obj, reach_pose_world(hand, obj), settings, kin)
    log = TickLog(log_path, pipeline.names, len(hand.joints), truth=False, raw_frames=raw_frames) if log_path else None
    hand_io = CurrentTap(rig.hand)  # keeps the currents of the tick's one read, for the log
    wait = getattr(rig.sensors, "wait_for_frames", None)
    if wait is not None:
        wait(FIRST_FRAMES_TIMEOUT_S, min_frames=1)
    dt = hand.dt
    t0 = rig.clock.now()
    next_tick = t0
    overruns = 0
    settle_ticks = int(round(SETTLE_S / dt))
    peak = np.zeros(len(pipeline.names))
    grasp = np.array([f.grasp for f in hand.fingers])
    peak_grip = 0.0
    interrupted: KeyboardInterrupt | None = None
    try:
        while True:
            try:
                now = rig.clock.now()
                snap, cmd, raw = control_tick(hand_io, rig.arm, rig.sensors, pipeline, ctrl, now)
                np.maximum(peak, np.linalg.norm(snap.f_sensor, axis=1), out=peak)
                peak_grip = max(peak_grip, float(np.max(snap.grip_n[grasp], initial=0.0)))
                if log:
                    log.append(
                        ctrl.state, snap, cmd, pipeline.tared, raw=raw, grip_target_n=ctrl.tau, current_a=hand_io.take()
                    )
                if ctrl.terminal:
                    settle_ticks -= 1
                    if settle_ticks <= 0:
                        break
                elif now - t0 > max_trial_s:
                    ctrl.fail(reason="aborted", detail=f"trial longer than {max_trial_s:g} s")
                next_tick += dt
                delay = next_tick - rig.clock.now()
                if delay > 0:
                    sleep(delay)
                else:
                    overruns += 1
                    next_tick = rig.clock.now()  # do not try to catch up with a burst
            except KeyboardInterrupt as exc:  # operator abort: the safe action, then stop
                interrupted = first_interrupt(ctrl, exc, interrupted)
    finally:
        if log:
            log.close()
    end = rig.clock.now() - t0
    record = {
        "object": obj.name,
        "controller": controller_view(ctrl),
        "final_state": ctrl.state,
        "success": ctrl.state == "done",
        "reason": ctrl.failure_reason if ctrl.state != "done" else None,
        "fault_detail": ctrl.failure_detail,
        "wall_duration_s": round(end, 4),
        "tick_overruns": overruns,
        "peak_grip_est_n": round(peak_grip, 4),
        "transitions": [(round(t - t0, 3), a, b) for t, a, b in ctrl.history],
        "timings": state_timings([(t - t0, a, b) for t, a, b in ctrl.history], end),
        "peak_forces": {n: {"force_est_n": round(float(peak[i]), 4)} for i, n in enumerate(pipeline.names)},
        "settings": trial_settings(hand, obj, settings),
        "judged_by": "controller",
    }
    if interrupted is not None:
        raise with_record(interrupted, record)
    return record


def hardware_trial_fn(
    hand: HandConfig,
    policies: Sequence[str],
    settings: PaperSettings | None,
    threads: int,
    open_rig_fn: RigOpener | None = None,
    port: str | None = None,
    sensor_port: str | None = None,
    raw_frames: bool = False,
) -> Callable[..., dict[str, Any]]:
    """The ``run_series`` trial function for the real hand (policies loaded up front);
    ``raw_frames``: its tick logs keep every raw frame whole."""
    for p in policies:
        if is_oracle(p):
            raise UsageError(f"--policy {p}: oracle policies need the mock world's ground truth")
    estimators = {p: load_policy(p, hand, threads) for p in policies}
    kin = HandKinematics(hand)
    opener = open_rig_fn or (lambda h: open_rig(h, port, sensor_port))
    if policies:  # a kernel's first load must not stall the first trial's loop on the hand
        warm_kernels_once(hand, settings or default_settings(), policies[0])

    def run(policy: str, obj: ObjectProfile, trial: int, seed: int, log_path: Path | None) -> dict[str, Any]:
        rig = opener(hand)
        try:
            record = run_hardware_trial(
                hand, obj, rig, estimators[policy], settings, kin, log_path, raw_frames=raw_frames
            )
        except KeyboardInterrupt as exc:
            kept = interrupted_record(exc)
            if kept is not None:
                kept.update({"policy": policy, "trial": trial, "seed": seed})
            raise
        finally:
            rig.close()
        record.update({"policy": policy, "trial": trial, "seed": seed})
        return record

    return run
