"""Run lift-and-place trials on the mock world and series of them.

One trial: tare in free space, then the controller runs until done or fault,
then the world settles for a moment under the safe action so consequences
(a dropped object) are seen; the outcome comes from the world's ground truth.

A series writes ``run.json`` first, then one fsynced record per finished trial,
so an interrupted series loses at most the trial in progress and
``run_series(..., resume=True)`` continues it: every trial's seed depends only
on the base seed, the object and the trial index, so the resumed run scores
exactly like an uninterrupted one.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import shutil
import sys
import time
import zlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl import jit
from grasp_ctrl.config.checks import check_objects_for_hand
from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.controller.motion import squeeze_mode
from grasp_ctrl.controller.registry import make_controller
from grasp_ctrl.controller.settings import ControllerSettings
from grasp_ctrl.emulators.wall_clock import TimedHand, TrialClock, WallClockLoop
from grasp_ctrl.errors import ConfigError, GraspCtrlError, UsageError
from grasp_ctrl.estimators.base import ForceEstimator
from grasp_ctrl.estimators.registry import load_policy
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.loop.sensing import SensingPipeline
from grasp_ctrl.loop.tick import control_tick
from grasp_ctrl.loop.tick_kernels import track_peaks
from grasp_ctrl.loop.ticklog import CurrentTap, TickLog
from grasp_ctrl.sim.backends import MockArm
from grasp_ctrl.sim.mujoco_log import set_log_dir as set_engine_log_dir
from grasp_ctrl.sim.oracle import OracleEstimator, is_oracle, parse_oracle
from grasp_ctrl.sim.registry import BackendFactory, WorldFactory, simulated_backend, world_params
from grasp_ctrl.sim.variation import NOMINAL, Variation
from grasp_ctrl.sim.world import WorldParams
from grasp_ctrl.sim.world_api import World
from grasp_ctrl.storage import (
    RUN_FILE,
    SUMMARY_FILE,
    check_object_name,
    commit_temp,
    is_temp_file,
    record_path,
    safe_name,
    temp_path,
    ticks_path,
    write_json,
)
from grasp_ctrl.trials.episode.mock_tick import MockTick
from grasp_ctrl.trials.episode.outcome import judge
from grasp_ctrl.trials.runs.fingerprint import stamp, sync_manifest
from grasp_ctrl.trials.runs.manifest import RunManifest, read_manifest
from grasp_ctrl.trials.runs.planned import why_unplanned
from grasp_ctrl.trials.runs.progress import Progress
from grasp_ctrl.trials.runs.records import canonical_order, load_records, record_files
from grasp_ctrl.trials.runs.runlock import RunLock
from grasp_ctrl.trials.runs.summary import summarize
from grasp_ctrl.trials.runs.workers import ignore_interrupts

MAX_TRIAL_S = 60.0
SETTLE_S = 0.5
RECORD_FORMAT = 1


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
    backend: str = "mock"
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


EstimatorFactory = Callable[[World], ForceEstimator]
# The hand and sensor backends of a trial on a world: the mock's own, or the real
# backends on emulators (emulators/world_rig.py, ``run --backend dynamixel --emulate``).
# The world of a trial: the mock world, or MuJoCo's (``run --backend mujoco``, sim/mujoco_world.py).


def world_for_backend(
    backend: str, make_world: WorldFactory | None = None, make_backends: BackendFactory | None = None
) -> tuple[WorldFactory, BackendFactory]:
    """A trial's world and hand/sensor backends: those given, the rest from the simulated backend
    ``backend`` names (sim/registry.py; a one-line error when it names none)."""
    if make_world is None or make_backends is None:
        entry = simulated_backend(backend)
        make_world, make_backends = make_world or entry.make_world, make_backends or entry.make_backends
    return make_world, make_backends


def estimator_factory(spec: str, hand: HandConfig, threads: int = 1) -> EstimatorFactory:
    """Oracles read each trial's world; other policies are loaded once and shared."""
    if is_oracle(spec):
        scale = parse_oracle(spec)
        return lambda world: OracleEstimator(world, scale, name=spec)
    est = load_policy(spec, hand, threads)
    return lambda world: est


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


def trial_settings(hand: HandConfig, obj: ObjectProfile, settings: ControllerSettings | None) -> dict[str, Any]:
    return {
        "tau_n": obj.tau_n,
        "release_threshold_n": obj.release_threshold_n,
        "release_debounce": obj.release_debounce,
        "lift_height_m": obj.lift_height_m,
        "hold_s": obj.hold_s,
        "on_fault": hand.safety.on_fault,
        "max_fingertip_force_n": hand.safety.max_fingertip_force_n,
        "controller": dataclasses.asdict(settings or ControllerSettings()),
        "squeeze": squeeze_mode(hand, (settings or ControllerSettings()).stiffness_aware_squeeze),
    }


def run_sim_trial(
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
    on_tick: Callable[[World, GraspController], None] | None = None,
    make_backends: BackendFactory | None = None,
    backend: str = "mock",
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
    kin = kin or HandKinematics(hand)
    make_world, make_backends = world_for_backend(backend, make_world, make_backends)
    world = make_world(hand, obj, seed, world_params)
    hand_backend, sensors = make_backends(world, hand)
    arm = MockArm(world, hand)
    try:
        hand_backend.connect()
        arm.connect()
        sensors.start()
    except BaseException:
        _close_all(hand_backend, arm, sensors, raise_error=False)
        raise
    estimator = make_estimator(world)
    pipeline = SensingPipeline(hand, kin, estimator)
    ctrl = make_controller(hand, obj, world.reach_pose_world(), settings, kin)
    names = pipeline.names
    grasp = np.array([f.grasp for f in hand.fingers])
    log = TickLog(log_path, names, len(hand.joints), truth=True, raw_frames=raw_frames) if log_path else None
    # realtime: the backends' clock (or one of the world's time base) paces the loop and stamps the ticks
    clock: TrialClock | None = None
    if realtime:
        clock = getattr(hand_backend, "trial_clock", None) or TrialClock(world.t)
    loop = WallClockLoop(hand.dt, world.dt, clock=clock.now) if clock is not None else None
    # the generic tick's reads, for the log's currents (realtime: its bus time too)
    tap = CurrentTap(hand_backend if loop is None else TimedHand(hand_backend, loop))
    step_world = _world_stepper(world, hand_backend, sensors)
    n = len(names)
    peaks = np.zeros((3, n))
    # the peak of |f_sensor|^2 (its root at the end is the peak of |f_sensor|), of the grip and the true force
    tip_force_sq, tip_grip, tip_true = peaks
    # On the mock world's own backends the tick's input and output halves run fused (mock_tick.py).
    fast = (
        MockTick(world, hand_backend, sensors, arm, pipeline, log, peaks)
        if loop is None and MockTick.usable(world, hand_backend, sensors, arm, pipeline, log)
        else None
    )
    settle_ticks = int(round(SETTLE_S / hand.dt))
    if clock is not None and loop is not None:  # the trial's time runs on the wall clock from here
        clock.start()
        loop.start()
    try:
        while world.t < MAX_TRIAL_S:
            if fast is not None:  # the same step and tick, peaks and log row
                fast.tick(ctrl)
                if log:
                    # The fused tick reads no JointState. The mock hand's read is what the tick saw:
                    # the world has not stepped since, and its velocity estimate is already at q.
                    log.set_current(hand_backend.read().current_a)
            else:
                if loop is None:
                    world.step()
                    now = world.t
                else:  # sleep until the tick's release, then the world catches up with the wall clock
                    loop.wait_for_release()
                    loop.step_world(step_world)
                    now = loop.clock()
                world.set_phase(ctrl.state)
                snap, cmd, raw = control_tick(tap, arm, sensors, pipeline, ctrl, now)
                if jit.JIT:
                    track_peaks(snap.f_sensor, snap.grip_n, world.normal_n, tip_force_sq, tip_grip, tip_true)
                else:
                    f = snap.f_sensor
                    np.maximum(tip_force_sq, np.add.reduce(f * f, axis=1), out=tip_force_sq)
                    np.maximum(tip_grip, snap.grip_n, out=tip_grip)
                    np.maximum(tip_true, world.normal_n, out=tip_true)
                if log:
                    log.append(
                        ctrl.state,
                        snap,
                        cmd,
                        pipeline.tared,
                        world.f_sensor,
                        world.obj_z,
                        world.table_n,
                        raw=raw,
                        grip_target_n=ctrl.tau,
                        current_a=tap.take(),
                    )
                if loop is not None:
                    loop.tick_done()
            if on_tick:
                on_tick(world, ctrl)
            if ctrl.terminal:
                settle_ticks -= 1
                if settle_ticks <= 0:
                    break
        else:
            if not ctrl.terminal:
                ctrl.fail(reason="aborted", detail=f"trial longer than {MAX_TRIAL_S:g} s of simulated time")
    finally:
        if log:
            log.close()
        # A close error must not hide the error that ended the trial.
        _close_all(hand_backend, arm, sensors, raise_error=sys.exc_info()[0] is None)
    # The peaks over the grasping fingers follow from the per-fingertip peaks.
    tip_force = np.sqrt(tip_force_sq)  # = np.linalg.norm(f, axis=1), at its peak
    peak_est = max(0.0, float(np.max(tip_grip[grasp], initial=0.0)))
    peak_true = max(0.0, float(np.max(tip_true[grasp], initial=0.0)))
    success, reason = judge(world, ctrl)
    wall = time.perf_counter() - wall0
    timings = state_timings(ctrl.history, world.t)
    if loop is not None:
        bus = getattr(hand_backend, "bus_figures", None)
        timings["loop"] = {**loop.figures(), **(bus() if bus is not None else {})}
    return TrialResult(
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
        variation_draw=getattr(world, "draw", None),
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


def _world_stepper(world: World, *backends: Any) -> Callable[[], None]:
    """One world step with the backends' realtime hooks around it (those that have them)."""
    before = [f for b in backends if (f := getattr(b, "before_world_step", None)) is not None]
    after = [f for b in backends if (f := getattr(b, "after_world_step", None)) is not None]

    def step() -> None:
        for f in before:
            f()
        world.step()
        for f in after:
            f()

    return step


def _close_all(*parts: Any, raise_error: bool = True) -> None:
    """Close every backend even when one fails; the first error is raised after (if asked)."""
    error: BaseException | None = None
    for part in parts:
        try:
            part.close()
        except Exception as exc:  # noqa: BLE001 - keep closing the rest
            error = error or exc
    if error is not None and raise_error:
        raise error


# A trial runner for one (policy, object, trial index, seed): returns the JSON record.
TrialFn = Callable[[str, ObjectProfile, int, int, "Path | None"], dict[str, Any]]


def sim_trial_fn(
    hand: HandConfig,
    policies: Sequence[str],
    settings: ControllerSettings | None = None,
    threads: int = 1,
    make_backends: BackendFactory | None = None,
    backend: str = "mock",
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
    make_world, make_backends = world_for_backend(backend, make_world, make_backends)
    params = world_params(backend, variation)

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


# Worker-process side of ``run_series(jobs=N)``: each worker loads the policies once.
_WORKER_TRIAL_FN: TrialFn | None = None


def _init_worker(
    hand: HandConfig,
    policies: list[str],
    settings: ControllerSettings,
    threads: int,
    backend: str = "mock",
    variation: Variation | None = None,
    raw_frames: bool = False,
) -> None:
    global _WORKER_TRIAL_FN
    ignore_interrupts()
    _WORKER_TRIAL_FN = sim_trial_fn(
        hand, policies, settings, threads, backend=backend, variation=variation, raw_frames=raw_frames
    )


def _worker_trial(policy: str, obj: ObjectProfile, trial: int, seed: int, log_path: Path | None) -> dict[str, Any]:
    assert _WORKER_TRIAL_FN is not None
    return _WORKER_TRIAL_FN(policy, obj, trial, seed, log_path)


TrialTask = tuple[str, ObjectProfile, int, int, "Path | None"]  # policy, object, trial, seed, tick log


def parallel_trials(
    jobs: int,
    hand: HandConfig,
    policies: Sequence[str],
    settings: ControllerSettings | None,
    threads: int,
    tasks: Sequence[TrialTask],
    backend: str = "mock",
    variation: Variation | None = None,
    raw_frames: bool = False,
) -> Iterator[tuple[int, dict[str, Any]]]:
    """Simulated trials in ``jobs`` processes: yields (task index, record) as each finishes."""
    from concurrent.futures import FIRST_COMPLETED, wait
    from concurrent.futures.process import BrokenProcessPool

    from grasp_ctrl.trials.runs.process_cleanup import spawn_guard, start_pool

    pool = start_pool(
        jobs,
        _init_worker,
        (hand, list(policies), settings or ControllerSettings(), threads, backend, variation, raw_frames),
    )
    finished_cleanly = False
    try:
        todo = iter(enumerate(tasks))
        running: dict[Any, int] = {}
        for i, task in itertools.islice(todo, 2 * jobs):  # a short queue: Ctrl-C loses little
            with spawn_guard():  # a submit may start a worker (process_cleanup.spawn_guard)
                running[pool.submit(_worker_trial, *task)] = i
        while running:
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for fut in finished:
                i = running.pop(fut)
                try:
                    rec = fut.result()
                except BrokenProcessPool:
                    raise WorkerError("a trial worker process ended abruptly (killed, or out of memory?)") from None
                yield i, rec
                nxt = next(todo, None)
                if nxt is not None:
                    with spawn_guard():
                        running[pool.submit(_worker_trial, *nxt[1])] = nxt[0]
        finished_cleanly = True
    finally:
        if finished_cleanly:
            try:
                pool.shutdown(wait=True)
            except BaseException:  # Ctrl-C while the workers finish: they are stopped
                _stop_workers(pool)
                raise
        else:
            _stop_workers(pool)


def _stop_workers(pool: Any) -> None:
    """After Ctrl-C or an error: the trials in progress are abandoned (they run again on
    resume), so the workers are stopped now rather than waited for, and with them the fork
    server, a worker it forked that the pool never recorded (a start cut short) and the
    resource tracker; each is reaped before this returns (process_cleanup.abort_pool)."""
    from grasp_ctrl.trials.runs.process_cleanup import abort_pool

    abort_pool(pool)


class WorkerError(GraspCtrlError):
    """A worker process of ``run --jobs N`` died; the finished trials are on disk."""


def _warn(msg: str) -> None:
    print(f"warning: {msg}", file=sys.stderr, flush=True)


def run_series(
    hand: HandConfig,
    objects: Sequence[ObjectProfile],
    policies: Sequence[str],
    trials: int,
    seed: int,
    run_dir: Path,
    settings: ControllerSettings | None = None,
    progress: bool | Progress = True,
    tick_logs: bool = True,
    threads: int = 1,
    *,
    resume: bool = False,
    manifest: RunManifest | None = None,
    trial_fn: TrialFn | None = None,
    after_trial: Callable[[dict[str, Any]], None] | None = None,
    backend: str = "mock",
    warn: Callable[[str], None] = _warn,
    jobs: int = 1,
    executor: str = "local",
    address: str | None = None,
    variation: Variation | None = None,
    raw_frames: bool = False,
) -> dict[str, Any]:
    """objects x policies x trials with shared seeds; returns the summary (docs/design.md 5.2).

    ``resume``: keep the valid records already in ``run_dir`` (the run's
    parameters must match its ``run.json``) and run only the missing trials.
    ``after_trial(record)`` is called once each new record is on disk.
    ``jobs``: simulated trials in that many worker processes (records arrive out of
    order; the summary does not depend on it). ``executor="ray"``: the trials are
    Ray tasks instead (``address``: a running cluster; else a local instance of
    ``jobs`` CPUs), see ray_executor.py. ``variation``: the simulated world's per-trial
    draws of a new run without ``manifest`` (default: nominal, the worlds' own).
    ``raw_frames``: the tick logs of a new run without ``manifest`` keep every raw frame
    whole (a manifest's own ``raw_frames`` rules otherwise; a ``trial_fn`` is made with it).
    """
    if len(set(safe_name(p) for p in policies)) != len(policies):
        raise UsageError("--policy: two policies would share one log directory; give each once")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise UsageError(f"--seed: a non-negative integer (got {seed!r})")
    if jobs < 1:
        raise UsageError("--jobs: must be at least 1")
    if jobs > 1 and trial_fn is not None:
        raise UsageError("--jobs: trials on real hardware run one at a time")
    if executor != "local" and trial_fn is not None:
        raise UsageError("--executor: trials on real hardware run here, one at a time")
    plan = manifest or RunManifest(
        backend=backend,
        hand=hand.name,
        seed=seed,
        trials=trials,
        policies=list(policies),
        objects=list(objects),
        tick_logs=tick_logs,
        raw_frames=raw_frames,
        settings=settings or ControllerSettings(),
        variation=variation or NOMINAL,
    )
    # Everything that can be checked is checked before the first file is touched.
    for obj in plan.objects:
        check_object_name(obj.name)
    # on resume the profiles come from run.json, on a new run from the object file
    source = str(run_dir / RUN_FILE) if resume or not plan.object_file else plan.object_file
    check_objects_for_hand(plan.objects, hand, source)
    kin = HandKinematics(hand)
    for obj in plan.objects:  # the reach postures (preshape, a cap the finger must reach) fit this hand
        try:
            make_controller(hand, obj, np.zeros(3), plan.settings, kin)
        except ConfigError as exc:
            raise ConfigError(source, f"object {obj.name!r}: {exc.key}", exc.expected) from None
    other_world = {} if plan.backend == "mock" else {"backend": plan.backend}  # e.g. mujoco
    run_trial = trial_fn or sim_trial_fn(
        hand, policies, plan.settings, threads, **other_world, variation=plan.variation, raw_frames=plan.raw_frames
    )  # bad policies fail here

    created = not run_dir.exists()
    if run_dir.exists() and not run_dir.is_dir():
        raise UsageError(f"{run_dir}: exists and is not a directory; choose another --out")
    started = False
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
        with RunLock(run_dir, warn):
            existing = read_manifest(run_dir)
            if existing is not None and not resume:
                raise UsageError(
                    f"{run_dir} already holds a run; continue it with 'run --resume {run_dir}' or choose another --out"
                )
            if existing is None and record_files(run_dir):
                raise UsageError(f"{run_dir} holds trial records but no run.json; choose another --out")
            if existing is not None and not existing.same_plan(plan):
                raise UsageError(
                    f"{run_dir}/run.json describes other trials than these parameters; resume with its own parameters"
                )
            for tmp in stale_temp_files(run_dir):  # left by a writer that died; we hold the lock
                tmp.unlink(missing_ok=True)
            sync_manifest(run_dir, plan, existing)  # new run, or a resume that recorded --force
            started = True
            return _run_locked(
                hand,
                plan,
                policies,
                trials,
                seed,
                run_dir,
                progress,
                resume,
                run_trial,
                after_trial,
                warn,
                jobs,
                threads,
                executor,
                address,
            )
    except BaseException:
        if created and not started:  # a failed start leaves nothing that blocks the retry
            shutil.rmtree(run_dir, ignore_errors=True)
        raise


def stale_temp_files(run_dir: Path) -> list[Path]:
    """Temporary files of interrupted writes (``.NAME.PID.RANDOM.tmp``) in the run's tree."""
    return [p for p in run_dir.rglob(".*.tmp") if is_temp_file(p)]


def _run_locked(
    hand: HandConfig,
    plan: RunManifest,
    policies: Sequence[str],
    trials: int,
    seed: int,
    run_dir: Path,
    progress: bool | Progress,
    resume: bool,
    run_trial: TrialFn,
    after_trial: Callable[[dict[str, Any]], None] | None,
    warn: Callable[[str], None],
    jobs: int,
    threads: int,
    executor: str = "local",
    address: str | None = None,
) -> dict[str, Any]:
    done: dict[tuple[str, str, int], dict[str, Any]] = {}
    if resume:
        loaded = load_records(run_dir)
        for path, why in loaded.problems:
            warn(f"skipping {path}: {why}; that trial will run again")
        for rec in loaded.records:
            key = (rec["policy"], rec["object"], rec["trial"])
            why = why_unplanned(rec, plan)
            if why is None:
                done[key] = rec
            else:
                warn(f"ignoring {record_path(run_dir, *key)}: not a trial of this run ({why})")

    reporter = progress if isinstance(progress, Progress) else Progress(plan.total, enabled=bool(progress))
    reporter.resumed(canonical_order(list(done.values()), list(policies), plan.object_names))
    pending = []
    tick_logs: dict[tuple[str, str, int], tuple[Path, Path]] = {}  # key -> (temporary, final) tick log
    for policy in policies:
        for obj in plan.objects:
            for k in range(trials):
                if (policy, obj.name, k) not in done:
                    record_path(run_dir, policy, obj.name, k).parent.mkdir(parents=True, exist_ok=True)
                    log = None
                    if plan.tick_logs:
                        final = ticks_path(run_dir, policy, obj.name, k)
                        log = temp_path(final)  # renamed onto ``final`` just before the record is written
                        tick_logs[(policy, obj.name, k)] = (log, final)
                    pending.append((policy, obj, k, trial_seed(seed, obj.name, k), log))

    def finish(rec: dict[str, Any]) -> None:
        key = (rec["policy"], rec["object"], rec["trial"])
        if key in tick_logs and tick_logs[key][0].exists():
            commit_temp(*tick_logs[key])
        write_json(record_path(run_dir, *key), stamp(rec, plan))
        done[key] = rec
        reporter.trial_done(rec)
        if after_trial:
            after_trial(rec)

    set_engine_log_dir(run_dir)  # MuJoCo's warnings of in-process trials: the run directory, not ./
    try:
        if executor == "ray" and pending:
            from grasp_ctrl.trials.runs.ray_executor import ray_trials

            with contextlib.closing(
                ray_trials(
                    address,
                    jobs,
                    hand,
                    policies,
                    plan.settings,
                    threads,
                    pending,
                    plan.backend,
                    plan.variation,
                    plan.raw_frames,
                )
            ) as results:
                for _, rec in results:
                    finish(rec)
        elif jobs > 1 and len(pending) > 1:
            try:
                # closing: the workers are stopped at once on Ctrl-C or an error, not when collected.
                with contextlib.closing(
                    parallel_trials(
                        min(jobs, len(pending)),
                        hand,
                        policies,
                        plan.settings,
                        threads,
                        pending,
                        plan.backend,
                        plan.variation,
                        plan.raw_frames,
                    )
                ) as results:
                    for _, rec in results:
                        finish(rec)
            except WorkerError as exc:
                raise WorkerError(
                    f"{exc}; {len(done)} of {plan.total} trials are recorded in {run_dir}; "
                    f"continue with: grasp-ctrl run --resume {run_dir}"
                ) from None
        else:
            for args in pending:
                finish(run_trial(*args))
    finally:
        set_engine_log_dir(None)
        reporter.close()
        for tmp, _final in tick_logs.values():  # the trial in progress when interrupted
            tmp.unlink(missing_ok=True)
    records = canonical_order(list(done.values()), list(policies), plan.object_names)
    summary = summarize(records, str(run_dir), plan.backend, plan.hand, plan.seed)
    write_json(run_dir / SUMMARY_FILE, summary)
    return summary
