"""The parts of one trial on a simulated world, built in one place, and its step and tick.

``build_trial`` makes the world of the backend the registry names (rigs/registry.py), its hand
and sensor backends and its arm (the wrist target: sim/world_backends.py), connects them, and
adds the sensing pipeline and the controller. The trial runner (trials/episode/runner.py), the warm-up (trials/episode/warm_up.py) and the
benchmark figures (bench/) all build their trials here and step them with ``SimTrial.step``:
the world one control period on, then one control tick at the world's time.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.registry import make_controller
from grasp_ctrl.controller.snapshot import Command, Snapshot
from grasp_ctrl.estimators.base import ForceEstimator
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.loop.loop_kernels import track_peaks
from grasp_ctrl.loop.sensing import SensingPipeline
from grasp_ctrl.loop.tick import control_tick
from grasp_ctrl.loop.ticklog import TickLog
from grasp_ctrl.numeric import jit
from grasp_ctrl.rigs.closing import close_all
from grasp_ctrl.rigs.registry import DEFAULT_BACKEND, BackendFactory, WorldFactory
from grasp_ctrl.rigs.registry import backend as backend_entry
from grasp_ctrl.sim.world_api import World
from grasp_ctrl.sim.world_backends import WorldArm

EstimatorFactory = Callable[[World], ForceEstimator]


@dataclass
class SimTrial:
    """One trial's world, backends, pipeline and controller."""

    world: World
    hand_backend: Any
    sensors: Any
    arm: WorldArm
    pipeline: SensingPipeline
    ctrl: GraspController
    kin: HandKinematics

    def tick(self, now: float, hand_backend: Any = None) -> tuple[Snapshot, Command, np.ndarray]:
        """One control tick at time ``now`` (``hand_backend``: a wrapper of the trial's own, e.g.
        one that keeps what it read for the tick log)."""
        self.world.set_phase(self.ctrl.state)
        return control_tick(hand_backend or self.hand_backend, self.arm, self.sensors, self.pipeline, self.ctrl, now)

    def step(self, hand_backend: Any = None) -> tuple[Snapshot, Command, np.ndarray]:
        """The world one control period on, then one control tick at its time."""
        self.world.step()
        return self.tick(self.world.t, hand_backend)

    def record(
        self,
        snap: Snapshot,
        cmd: Command,
        raw: np.ndarray,
        peaks: np.ndarray,
        log: TickLog | None = None,
        current_a: np.ndarray | None = None,
    ) -> None:
        """What one tick leaves behind: the running peaks per fingertip (``peaks``, (3, n_tips):
        |f_sensor|^2, the grip and the world's true normal force, updated in place) and, with
        ``log``, its tick-log row (``current_a``: the joint currents the hand reported)."""
        tip_force_sq, tip_grip, tip_true = peaks
        world = self.world
        if jit.JIT:
            track_peaks(snap.f_sensor, snap.grip_n, world.normal_n, tip_force_sq, tip_grip, tip_true)
        else:
            f = snap.f_sensor
            np.maximum(tip_force_sq, np.add.reduce(f * f, axis=1), out=tip_force_sq)
            np.maximum(tip_grip, snap.grip_n, out=tip_grip)
            np.maximum(tip_true, world.normal_n, out=tip_true)
        if log:
            log.append(
                self.ctrl.state,
                snap,
                cmd,
                self.pipeline.tared,
                world.f_sensor,
                world.obj_z,
                world.table_n,
                raw=raw,
                grip_target_n=self.ctrl.tau,
                current_a=current_a,
            )

    def close(self, raise_error: bool = True) -> None:
        close_all(self.hand_backend, self.arm, self.sensors, raise_error=raise_error)


def trial_factories(
    backend: str = DEFAULT_BACKEND,
    make_world: WorldFactory | None = None,
    make_backends: BackendFactory | None = None,
    realtime: bool = False,
) -> tuple[WorldFactory, BackendFactory]:
    """A trial's world and hand/sensor backends: those given, the rest from the backend that
    ``backend`` names (a one-line error when it names none or one without a world)."""
    if make_world is None or make_backends is None:
        entry = backend_entry(backend)
        make_world = make_world or entry.make_world()
        make_backends = make_backends or entry.make_backends(realtime)
    return make_world, make_backends


def build_trial(
    hand: HandConfig,
    obj: ObjectProfile,
    seed: int,
    estimator_for: EstimatorFactory,
    *,
    backend: str = DEFAULT_BACKEND,
    world_params: Any = None,
    settings: PaperSettings | None = None,
    kin: HandKinematics | None = None,
    make_world: WorldFactory | None = None,
    make_backends: BackendFactory | None = None,
    realtime: bool = False,
) -> SimTrial:
    """The connected parts of one trial of ``obj`` (seed ``seed``) on ``backend`` (or on the
    factories given); ``estimator_for(world)`` gives the trial's force estimator."""
    kin = kin or HandKinematics(hand)
    make_world, make_backends = trial_factories(backend, make_world, make_backends, realtime)
    world = make_world(hand, obj, seed, world_params)
    hand_backend, sensors = make_backends(world, hand)
    arm = backend_entry(backend).make_arm()(world, hand)
    try:
        hand_backend.connect()
        arm.connect()
        sensors.start()
    except BaseException:
        close_all(hand_backend, arm, sensors, raise_error=False)
        raise
    try:
        pipeline = SensingPipeline(hand, kin, estimator_for(world))
        ctrl = make_controller(hand, obj, world.reach_pose_world(), settings, kin)
    except BaseException:
        close_all(hand_backend, arm, sensors, raise_error=False)
        raise
    return SimTrial(world, hand_backend, sensors, arm, pipeline, ctrl, kin)
