"""Where a study's trials run: here one at a time, in worker processes, or as Ray tasks.

A study keeps one trial of each setting in flight (a setting's trials run in
order, so it can be pruned after any of them) and up to ``--jobs`` settings at
once. ``submit(key, task)`` hands over one trial; ``next_done()`` returns
``(key, record)`` of a finished one, in any order; ``close(abort)`` stops the
workers (at once after Ctrl-C or an error: trials in progress are dropped).
"""

from __future__ import annotations

import collections
import uuid
from collections.abc import Callable, Hashable
from typing import Any, Protocol

from grasp_ctrl.trials.episode.runner import TrialTask

_CACHE: dict[Any, Any] = {}  # per Ray worker: the trial function of the current study


class TrialExecutor(Protocol):
    def submit(self, key: Hashable, task: TrialTask) -> None: ...
    def next_done(self) -> tuple[Hashable, dict[str, Any]]: ...
    def close(self, abort: bool) -> None: ...


class SerialExecutor:
    """Here, one trial at a time (the real hand, or ``--jobs 1``)."""

    def __init__(self, trial_fn: Callable[..., dict[str, Any]]) -> None:
        self.trial_fn = trial_fn
        self.queue: collections.deque[tuple[Hashable, TrialTask]] = collections.deque()

    def submit(self, key: Hashable, task: TrialTask) -> None:
        self.queue.append((key, task))

    def next_done(self) -> tuple[Hashable, dict[str, Any]]:
        key, task = self.queue.popleft()
        return key, self.trial_fn(*task)

    def close(self, abort: bool) -> None:
        self.queue.clear()


class ProcessExecutor:
    """Worker processes from the fork server of ``run --jobs N`` (runner.parallel_trials)."""

    def __init__(self, jobs: int, hand: Any, policy: str, backend: str, variation: Any = None) -> None:
        from concurrent.futures import ProcessPoolExecutor

        from grasp_ctrl.controller.settings import ControllerSettings
        from grasp_ctrl.trials.episode.runner import _init_worker
        from grasp_ctrl.trials.runs.workers import worker_context

        self.pool = ProcessPoolExecutor(
            jobs,
            mp_context=worker_context(),
            initializer=_init_worker,
            initargs=(hand, [policy], ControllerSettings(), 1, backend, variation),
        )
        self.running: dict[Any, Hashable] = {}

    def submit(self, key: Hashable, task: TrialTask) -> None:
        from grasp_ctrl.trials.episode.runner import _worker_trial

        self.running[self.pool.submit(_worker_trial, *task)] = key

    def next_done(self) -> tuple[Hashable, dict[str, Any]]:
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        from grasp_ctrl.trials.episode.runner import WorkerError

        done, _ = wait(list(self.running), return_when=FIRST_COMPLETED)
        fut = next(iter(done))
        key = self.running.pop(fut)
        try:
            return key, fut.result()
        except BrokenProcessPool:
            raise WorkerError("a trial worker process ended abruptly (killed, or out of memory?)") from None

    def close(self, abort: bool) -> None:
        from grasp_ctrl.trials.episode.runner import _stop_workers

        if abort:
            _stop_workers(self.pool)
        else:
            self.pool.shutdown(wait=True)


def _tune_trial_in_worker(
    token: str, hand: Any, policy: str, backend: str, variation: Any, task: TrialTask
) -> dict[str, Any]:
    """One trial in a Ray worker (its world drawn under ``variation``); the policy is loaded once
    per worker and study (``token``)."""
    from grasp_ctrl.trials.episode.runner import sim_trial_fn

    key = ("tune", token)
    if key not in _CACHE:
        _CACHE.clear()
        _CACHE[key] = sim_trial_fn(hand, [policy], backend=backend, variation=variation)
    return _CACHE[key](*task)


class RayExecutor:
    """Ray tasks (the ``ray`` extra): a local instance of ``jobs`` CPUs, or the cluster at ``address``."""

    def __init__(
        self, address: str | None, jobs: int | None, hand: Any, policy: str, backend: str, variation: Any = None
    ) -> None:
        from grasp_ctrl.trials.runs.ray_executor import ray_session

        self._session = ray_session(address, jobs)
        self.ray = self._session.__enter__()
        self.remote = self.ray.remote(num_cpus=1)(_tune_trial_in_worker)
        self.shared = (uuid.uuid4().hex, self.ray.put(hand), policy, backend, variation)
        self.running: dict[Any, Hashable] = {}

    def submit(self, key: Hashable, task: TrialTask) -> None:
        self.running[self.remote.remote(*self.shared, task)] = key

    def next_done(self) -> tuple[Hashable, dict[str, Any]]:
        ready, _ = self.ray.wait(list(self.running), num_returns=1)
        key = self.running.pop(ready[0])
        try:
            return key, self.ray.get(ready[0])
        except self.ray.exceptions.RayTaskError as exc:
            raise exc.as_instanceof_cause() from None

    def close(self, abort: bool) -> None:
        for ref in self.running:
            self.ray.cancel(ref, force=True)
        self.running.clear()
        self._session.__exit__(None, None, None)
