"""One lift-and-place trial in a simulated world (or, through ``trial_fn``, on the hand).

One trial: tare in free space, then the controller runs until done or fault,
then the world settles for a moment under the safe action so consequences
(a dropped object) are seen; the outcome comes from the world's ground truth.
Ctrl-C or SIGTERM mid-trial ends it as a hand's trial ends (trials/episode/hardware.py):
``aborted`` naming the interrupt, the safe action ticked through the settle (a second
interrupt cuts it short), then the interrupt raised with the trial's record attached
(``interrupted_record``), which the series keeps beside its records.
Every trial's seed depends only on the base seed, the object and the trial index
(``trial_seed``), so a resumed series (trials/runs/series.py) scores exactly like an
uninterrupted one.
"""

from __future__ import annotations

import sys
import time
import zlib
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.controller.motion import squeeze_mode
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.registry import default_settings, flat_settings
from grasp_ctrl.emulators.wall_clock import TimedHand, TrialClock, WallClockHand, WallClockLink, WallClockLoop
from grasp_ctrl.errors import UsageError, interrupt_detail
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.loop.ticklog import CurrentTap, TickLog
from grasp_ctrl.rigs.registry import DEFAULT_BACKEND, BackendFactory, WorldFactory
from grasp_ctrl.rigs.registry import backend as backend_entry
from grasp_ctrl.rigs.trial_builder import EstimatorFactory, build_trial, trial_factories
from grasp_ctrl.sim.variation import Variation
from grasp_ctrl.sim.world_api import World
from grasp_ctrl.sim.world_params import WorldParams
from grasp_ctrl.trials.episode.estimators import estimator_factory
from grasp_ctrl.trials.episode.outcome import judge
from grasp_ctrl.trials.episode.warm_up import warm_kernels_once, warm_world

MAX_TRIAL_S = 60.0
SETTLE_S = 0.5
RECORD_FORMAT = 1
_RECORD_ATTR = "trial_record"


def with_record(exc: BaseException, record: dict[str, Any]) -> BaseException:
    """``exc`` (an interrupt that ended a trial) carrying that trial's record."""
    setattr(exc, _RECORD_ATTR, record)
    return exc


def first_interrupt(
    ctrl: GraspController, exc: KeyboardInterrupt, interrupted: KeyboardInterrupt | None
) -> KeyboardInterrupt:
    """The interrupt (Ctrl-C or SIGTERM) that ends a trial: the first fails the controller as
    ``aborted``, naming it, so its safe action ticks on through the settle; a second, while it
    does, is raised at once."""
    if interrupted is not None:
        raise exc
    if not ctrl.terminal:
        ctrl.fail(reason="aborted", detail=interrupt_detail(exc))
    return exc


def interrupted_record(exc: BaseException) -> dict[str, Any] | None:
    """The record an interrupt carries (``with_record``), if any."""
    record = getattr(exc, _RECORD_ATTR, None)
    return record if isinstance(record, dict) else None


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
    backend: str = DEFAULT_BACKEND
    judged_by: str = "world"  # world (mock ground truth) | operator (label at the prompt)
    note: str = ""  # the operator's note
    controller: dict[str, Any] = field(default_factory=dict)  # the controller's own view
    timings: dict[str, Any] = field(default_factory=dict)
    peak_forces: dict[str, dict[str, float]] = field(default_factory=dict)
    fault_detail: str | None = None  # the controller's fault, in words (None without a fault)
    # The world's draw of this trial (sim/variation.py; None on the real hand): the judge's
    # truth, which the controller never saw.
    variation_draw: dict[str, Any] | None = None
    format: int = RECORD_FORMAT

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def trial_seed(seed: int, obj_name: str, trial: int) -> int:
    """Same seed for the same object and trial index whatever the policy (paired comparison)."""
    ss = np.random.SeedSequence([seed, zlib.crc32(obj_name.encode()), trial])
    return int(ss.generate_state(1)[0])


# The hand and sensor backends of a trial on a world: the mock's own, or the real
# backends on emulators (emulators/world_rig.py, ``run --backend dynamixel --emulate``).
# The world of a trial: the mock world, or MuJoCo's (``run --backend mujoco``, sim/mujoco/world.py).


def state_timings(transitions: Sequence[tuple[float, str, str]], end_t: float) -> dict[str, Any]:
    """Seconds spent in each state, and the time from first contact to the object set down."""
    spans: dict[str, float] = {}
    state, since = "tare", 0.0
    entered: dict[str, float] = {}
    for t, _src, dst in transitions:
        spans[state] = round(spans.get(state, 0.0) + t - since, 4)
        state, since = dst, t
        entered.setdefault(dst, t)
    spans[state] = round(spans.get(state, 0.0) + max(end_t - since, 0.0), 4)
    out: dict[str, Any] = {"state_s": spans}
    if "ramp" in entered and "release" in entered:
        out["grasp_to_release_s"] = round(entered["release"] - entered["ramp"], 4)
    return out


def controller_view(ctrl: GraspController) -> dict[str, Any]:
    """What the controller itself concluded (no ground truth): kept beside any label."""
    return {
        "final_state": ctrl.state,
        "success": ctrl.state == "done",
        "reason": ctrl.failure_reason,
        "detail": ctrl.failure_detail,  # what failed (servo id and error bits, port, fingertip)
    }


def trial_settings(hand: HandConfig, obj: ObjectProfile, settings: PaperSettings | None) -> dict[str, Any]:
    return {
        "tau_n": obj.tau_n,
        "release_threshold_n": obj.release_threshold_n,
        "release_debounce": obj.release_debounce,
        "lift_height_m": obj.lift_height_m,
        "hold_s": obj.hold_s,
        "on_fault": hand.safety.on_fault,
        "max_fingertip_force_n": hand.safety.max_fingertip_force_n,
        "controller": flat_settings(settings or default_settings()),
        "squeeze": squeeze_mode(hand, (settings or default_settings()).stiffness_aware_squeeze),
    }


def run_sim_trial(
    hand: HandConfig,
    obj: ObjectProfile,
    make_estimator: EstimatorFactory,
    seed: int,
    policy_name: str = "",
    trial: int = 0,
    settings: PaperSettings | None = None,
    world_params: WorldParams | None = None,
    log_path: Path | None = None,
    kin: HandKinematics | None = None,
    on_tick: Callable[[World, GraspController], None] | None = None,
    make_backends: BackendFactory | None = None,
    backend: str = DEFAULT_BACKEND,
    make_world: WorldFactory | None = None,
    raw_frames: bool = False,
    realtime: bool = False,
) -> TrialResult:
    """One trial; ``raw_frames``: the tick log at ``log_path`` keeps every raw frame whole.
    ``realtime``: the loop runs on the wall clock (emulators/wall_clock.py): a tick every
    ``hand.dt`` on a deadline schedule, the world stepped to keep up, each backend's
    ``before_world_step`` / ``after_world_step`` called around each step; the record's
    ``timings.loop`` holds the loop's cycle times and deadline misses."""
    wall0 = time.perf_counter()
    parts = build_trial(
        hand,
        obj,
        seed,
        make_estimator,
        backend=backend,
        world_params=world_params,
        settings=settings,
        kin=kin,
        make_world=make_world,
        make_backends=make_backends,
        realtime=realtime,
    )
    world, hand_backend, sensors = parts.world, parts.hand_backend, parts.sensors
    pipeline, ctrl = parts.pipeline, parts.ctrl
    names = pipeline.names
    grasp = np.array([f.grasp for f in hand.fingers])
    # realtime: the backends' clock (or one of the world's time base) paces the loop and stamps the ticks
    clock: TrialClock | None = None
    step_world: Callable[[], None] = world.step
    if realtime:
        if not (isinstance(hand_backend, WallClockHand) and isinstance(sensors, WallClockLink)):
            parts.close(raise_error=False)
            raise UsageError(f"backend {backend!r}: its hand and sensors do not run on the wall clock (realtime)")
        clock = hand_backend.trial_clock or TrialClock(world.t)
        step_world = _world_stepper(world, hand_backend, sensors)
    loop = WallClockLoop(hand.dt, world.dt, clock=clock.now) if clock is not None else None
    # the generic tick's reads, for the log's currents (realtime: its bus time too)
    tap = CurrentTap(hand_backend if loop is None else TimedHand(hand_backend, loop))
    log = TickLog(log_path, names, len(hand.joints), truth=True, raw_frames=raw_frames) if log_path else None
    # the peak of |f_sensor|^2 (its root at the end is the peak of |f_sensor|), of the grip and the true force
    peaks = np.zeros((3, len(names)))
    tip_force_sq, tip_grip, tip_true = peaks
    settle_ticks = int(round(SETTLE_S / hand.dt))
    interrupted: KeyboardInterrupt | None = None
    if clock is not None and loop is not None:  # the trial's time runs on the wall clock from here
        clock.start()
        loop.start()
    try:
        while world.t < MAX_TRIAL_S:
            try:
                if loop is None:
                    snap, cmd, raw = parts.step(tap)
                else:  # sleep until the tick's release, then the world catches up with the wall clock
                    loop.wait_for_release()
                    loop.step_world(step_world)
                    snap, cmd, raw = parts.tick(loop.clock(), tap)
                parts.record(snap, cmd, raw, peaks, log, tap.take())
                if loop is not None:
                    loop.tick_done()
                if on_tick:
                    on_tick(world, ctrl)
                if ctrl.terminal:
                    settle_ticks -= 1
                    if settle_ticks <= 0:
                        break
            except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM: the safe action, then stop
                interrupted = first_interrupt(ctrl, exc, interrupted)
            except Exception:
                if interrupted is None:
                    raise
                break  # (settling after an interrupt: the interrupt ends the trial, not this)
        else:
            if not ctrl.terminal:
                ctrl.fail(reason="aborted", detail=f"trial longer than {MAX_TRIAL_S:g} s of simulated time")
    finally:
        if log:
            log.close()
        # A close error must not hide the error (or the interrupt) that ended the trial.
        parts.close(raise_error=sys.exc_info()[0] is None and interrupted is None)
    # The peaks over the grasping fingers follow from the per-fingertip peaks.
    tip_force = np.sqrt(tip_force_sq)  # = np.linalg.norm(f, axis=1), at its peak
    peak_est = max(0.0, float(np.max(tip_grip[grasp], initial=0.0)))
    peak_true = max(0.0, float(np.max(tip_true[grasp], initial=0.0)))
    success, reason = judge(world, ctrl)
    wall = time.perf_counter() - wall0
    timings = state_timings(ctrl.history, world.t)
    if loop is not None:
        assert isinstance(hand_backend, WallClockHand)  # (checked before the loop started)
        timings["loop"] = {**loop.figures(), **hand_backend.bus_figures()}
    result = TrialResult(
        object=obj.name,
        policy=policy_name,
        trial=trial,
        seed=seed,
        success=success,
        reason=reason,
        final_state=ctrl.state,
        sim_duration_s=round(world.t, 4),
        wall_duration_s=round(wall, 4),
        peak_grip_est_n=round(peak_est, 4),
        peak_grip_true_n=round(peak_true, 4),
        max_object_z_m=round(world.max_obj_z, 5),
        transitions=[(round(t, 3), a, b) for t, a, b in ctrl.history],
        events=[{"t": round(e.t, 3), "kind": e.kind, "detail": e.detail} for e in world.events],
        settings=trial_settings(hand, obj, settings),
        backend=backend,
        controller=controller_view(ctrl),
        fault_detail=ctrl.failure_detail,
        variation_draw=world.draw,
        timings=timings,
        peak_forces={
            name: {
                "force_est_n": round(float(tip_force[i]), 4),
                "grip_est_n": round(float(tip_grip[i]), 4),
                "normal_true_n": round(float(tip_true[i]), 4),
            }
            for i, name in enumerate(names)
        },
    )
    if interrupted is not None:
        raise with_record(interrupted, result.to_json())
    return result


def _world_stepper(world: World, hand: WallClockHand, sensors: WallClockLink) -> Callable[[], None]:
    """One world step on the wall clock: the servos' goals drive it, then the hand's and the
    sensors' links publish its state."""

    def step() -> None:
        hand.before_world_step()
        world.step()
        hand.after_world_step()
        sensors.after_world_step()

    return step


# A trial runner for one (policy, object, trial index, seed): returns the JSON record.
TrialFn = Callable[[str, ObjectProfile, int, int, "Path | None"], dict[str, Any]]


@dataclass(frozen=True)
class TrialSetup:
    """What every trial of a series shares: the hand, the policies, the controller settings, the
    estimators' threads, the simulated backend, the variation profile and whether tick logs keep
    raw frames whole. Picklable: worker processes and Ray tasks get it whole and build their
    trial runner from it (``trial_fn``) once."""

    hand: HandConfig
    policies: tuple[str, ...]
    settings: PaperSettings | None = None
    threads: int = 1
    backend: str = DEFAULT_BACKEND
    variation: Variation | None = None
    raw_frames: bool = False
    realtime: bool = False

    def trial_fn(self) -> TrialFn:
        """The runner of one trial (``sim_trial_fn``): its policies are loaded here."""
        return sim_trial_fn(
            self.hand,
            self.policies,
            self.settings,
            self.threads,
            backend=self.backend,
            variation=self.variation,
            raw_frames=self.raw_frames,
            realtime=self.realtime,
        )


def sim_trial_fn(
    hand: HandConfig,
    policies: Sequence[str],
    settings: PaperSettings | None = None,
    threads: int = 1,
    make_backends: BackendFactory | None = None,
    backend: str = DEFAULT_BACKEND,
    make_world: WorldFactory | None = None,
    variation: Variation | None = None,
    raw_frames: bool = False,
    realtime: bool = False,
) -> TrialFn:
    """Policies are loaded up front, so a bad one fails before the first trial. ``variation``:
    the world's per-trial draws (sim/variation.py; None: the world's own, nominal);
    ``raw_frames``: the tick logs keep every raw frame whole; ``realtime``: each trial's loop
    runs on the wall clock (``run_sim_trial``), one trial at a time."""
    factories = {p: estimator_factory(p, hand, threads) for p in policies}
    kin = HandKinematics(hand)
    make_world, make_backends = trial_factories(backend, make_world, make_backends, realtime)
    params = backend_entry(backend).world_params(variation)
    if realtime:  # a kernel's first load must not stall the first trial's wall-clock loop
        warm_kernels_once(hand, settings or default_settings(), policies[0] if policies else None)
        warm_world(make_world, hand, params)

    def run(policy: str, obj: ObjectProfile, trial: int, seed: int, log_path: Path | None) -> dict[str, Any]:
        return run_sim_trial(
            hand,
            obj,
            factories[policy],
            seed,
            policy,
            trial,
            settings,
            world_params=params,
            log_path=log_path,
            kin=kin,
            make_backends=make_backends,
            backend=backend,
            make_world=make_world,
            raw_frames=raw_frames,
            realtime=realtime,
        ).to_json()

    return run
