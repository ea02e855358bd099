"""Figure ``estimate_4tips_ms``: validate + tare + contact gate + features + one
batched inference of the official ICRA 2019 network for 4 fingertips, 1 thread.

All four fingertips are pressed (the worst case: every tip goes through the
network); the frames vary from call to call so no cache can help.

``estimate_4tips_cpu_ms`` is the same tick measured in thread CPU time: on a
shared, loaded machine the wall-clock p99 is set by the scheduler (a time
slice lost to another process), not by this code; the CPU-time figure shows
the code's own tail. ``estimate_4tips_dropout_ms`` runs the 10-head dropout
variant (force + variance) instead.
"""

from __future__ import annotations

import time

import numpy as np

from grasp_ctrl.bench.figure import Figure, time_ms
from grasp_ctrl.config.sensor_layout import ELECTRODES, FRAME_LEN, PDC
from grasp_ctrl.estimators.pipeline import TactilePipeline
from grasp_ctrl.estimators.registry import load_policy

FINGERS = ("index", "middle", "ring", "thumb")


def _frames(rng: np.random.Generator, k: int, pressed: bool) -> np.ndarray:
    base = np.full((k, len(FINGERS), FRAME_LEN), 2000.0)
    base[..., ELECTRODES] = 3300.0
    base[..., PDC] = 2450.0
    base += rng.normal(0.0, 2.0, base.shape)
    if pressed:
        depth = rng.uniform(50, 300, (k, len(FINGERS), 1))
        base[..., ELECTRODES] -= depth * rng.uniform(0.0, 1.0, (k, len(FINGERS), 19))
        base[..., PDC] += depth[..., 0]
    return np.rint(base)


def _measure(policy: str, quick: bool, clock: str = "wall") -> Figure:
    estimator = load_policy(policy, hand=None, threads=1)
    pipe = TactilePipeline(estimator, FINGERS)
    rng = np.random.default_rng(0)
    pipe.set_baseline(_frames(rng, 50, pressed=False))
    frames = _frames(rng, 256, pressed=True)
    i = 0

    def tick() -> None:
        nonlocal i
        pipe.step(frames[i % len(frames)])
        i += 1

    for _ in range(pipe.gate.frames):  # get past the contact debounce first
        tick()
    if not pipe.gate.update(pipe.tare.apply(frames[0])).all():
        raise RuntimeError("estimate_4tips_ms: the synthetic presses do not pass the contact gate")
    timer = time.perf_counter if clock == "wall" else time.thread_time
    return time_ms(tick, repeats=300 if quick else 5000, warmup=50 if quick else 500, timer=timer)


def measure_estimate_4tips(quick: bool) -> Figure:
    return _measure("icra19_official", quick)


def measure_estimate_4tips_cpu(quick: bool) -> Figure:
    return _measure("icra19_official", quick, clock="cpu")


def measure_estimate_4tips_dropout(quick: bool) -> Figure:
    return _measure("icra19_dropout_official", quick)


FIGURES = {
    "estimate_4tips_ms": measure_estimate_4tips,
    "estimate_4tips_cpu_ms": measure_estimate_4tips_cpu,
    "estimate_4tips_dropout_ms": measure_estimate_4tips_dropout,
}
