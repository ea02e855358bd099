"""One benchmark figure and helpers to time a function."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Figure:
    median: float
    p99: float
    unit: str

    @classmethod
    def single(cls, value: float, unit: str) -> Figure:
        return cls(value, value, unit)

    @classmethod
    def rate(cls, samples: Sequence[float] | np.ndarray, unit: str) -> Figure:
        """A throughput (higher is better): the median, and as ``p99`` its slow tail,
        the rate that 99 % of the measurements beat (the 1st percentile), so a rate's
        p99 is never above its median, as a time's is never below."""
        r = np.asarray(samples, dtype=float)
        return cls(float(np.median(r)), float(np.percentile(r, 1)), unit)


def time_ms(
    fn: Callable[[], object], repeats: int, warmup: int = 20, timer: Callable[[], float] = time.perf_counter
) -> Figure:
    """Median and p99 of ``fn``'s time in milliseconds, after warm-up. ``timer``:
    wall clock by default; ``time.thread_time`` gives the CPU time of this thread."""
    for _ in range(warmup):
        fn()
    samples = np.empty(repeats)
    for i in range(repeats):
        t0 = timer()
        fn()
        samples[i] = (timer() - t0) * 1e3
    return Figure(float(np.median(samples)), float(np.percentile(samples, 99)), "ms")
