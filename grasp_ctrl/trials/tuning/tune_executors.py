"""Where a study's trials run: here one at a time, in worker processes, or as Ray tasks.

A study keeps one trial of each setting in flight (a setting's trials run in
order, so it can be pruned after any of them) and up to ``--jobs`` settings at
once. ``submit(key, task, settings)`` hands over one trial (``key``: the study's
trial number; ``settings``: the setting's controller settings, None: the executor's
own); ``next_done()`` returns ``(key, record)`` of a finished one, in any order;
``close(abort)`` stops the workers (at once after Ctrl-C or an error: trials in
progress are dropped).
"""

from __future__ import annotations

import collections
import uuid
from collections.abc import Callable, Hashable
from typing import Any, Protocol

from grasp_ctrl.trials.runs.series import TrialTask

_CACHE: dict[Any, Any] = {}  # per worker: the trial functions of the current study, per controller settings
MAX_TRIAL_FNS = 8  # trial functions kept per worker (each holds its policy): one per settings in flight


class TrialExecutor(Protocol):
    def submit(self, key: int, task: TrialTask, settings: Any = None) -> None: ...
    def next_done(self) -> tuple[int, dict[str, Any]]: ...
    def close(self, abort: bool) -> None: ...


def _cached_fn(cache: dict[Any, Any], key: Hashable, make: Callable[[], Any]) -> Any:
    if key not in cache:
        while len(cache) >= MAX_TRIAL_FNS:
            cache.pop(next(iter(cache)))
        cache[key] = make()
    return cache[key]


class SerialExecutor:
    """Here, one trial at a time (the real hand, or ``--jobs 1``). ``trial_fn_for(settings)``
    makes the trial function of other controller settings (``tune --param setting.NAME=...``)."""

    def __init__(
        self,
        trial_fn: Callable[..., dict[str, Any]],
        trial_fn_for: Callable[[Any], Callable[..., dict[str, Any]]] | None = None,
        settings: Any = None,
    ) -> None:
        self.trial_fn = trial_fn
        self.trial_fn_for = trial_fn_for
        self.settings = settings  # those trial_fn runs with
        self.fns: dict[Any, Any] = {}
        self.queue: collections.deque[tuple[int, TrialTask, Any]] = collections.deque()

    def submit(self, key: int, task: TrialTask, settings: Any = None) -> None:
        self.queue.append((key, task, settings))

    def next_done(self) -> tuple[int, dict[str, Any]]:
        key, task, settings = self.queue.popleft()
        if settings is None or settings == self.settings or self.trial_fn_for is None:
            return key, self.trial_fn(*task)
        make = self.trial_fn_for
        return key, _cached_fn(self.fns, settings, lambda: make(settings))(*task)

    def close(self, abort: bool) -> None:
        self.queue.clear()


_WORKER: dict[str, Any] = {}  # per worker process: the study's hand, policy, backend, variation


def _init_tune_worker(hand: Any, policy: str, backend: str, variation: Any, settings: Any) -> None:
    """A worker process of ``tune --jobs N``: the trial function of the study's settings, loaded once."""
    from grasp_ctrl.trials.runs.workers import ignore_interrupts

    ignore_interrupts()
    _WORKER["study"] = (hand, policy, backend, variation)
    _CACHE.clear()
    _worker_fn(settings)


def _worker_fn(settings: Any) -> Any:
    from grasp_ctrl.trials.episode.runner import sim_trial_fn

    hand, policy, backend, variation = _WORKER["study"]
    return _cached_fn(
        _CACHE, settings, lambda: sim_trial_fn(hand, [policy], settings, backend=backend, variation=variation)
    )


def _tune_worker_trial(settings: Any, *task: Any) -> dict[str, Any]:
    """One trial in a worker process, with the setting's controller settings."""
    return _worker_fn(settings)(*task)


class ProcessExecutor:
    """Worker processes from the fork server of ``run --jobs N`` (series.parallel_trials)."""

    def __init__(
        self, jobs: int, hand: Any, policy: str, backend: str, variation: Any = None, settings: Any = None
    ) -> None:
        from grasp_ctrl.controller.registry import default_settings
        from grasp_ctrl.trials.runs.workers import start_pool

        self.settings = settings or default_settings()
        self.pool = start_pool(jobs, _init_tune_worker, (hand, policy, backend, variation, self.settings))
        self.running: dict[Any, int] = {}
        self.closed = False

    def submit(self, key: int, task: TrialTask, settings: Any = None) -> None:
        from grasp_ctrl.trials.runs.process_cleanup import spawn_guard
        from grasp_ctrl.trials.runs.workers import worker_deaths_as_errors

        # a submit may start a worker (process_cleanup.spawn_guard), or find the pool broken
        with spawn_guard(), worker_deaths_as_errors():
            self.running[self.pool.submit(_tune_worker_trial, settings or self.settings, *task)] = key

    def next_done(self) -> tuple[int, dict[str, Any]]:
        from concurrent.futures import FIRST_COMPLETED, wait

        from grasp_ctrl.trials.runs.workers import worker_deaths_as_errors

        done, _ = wait(list(self.running), return_when=FIRST_COMPLETED)
        fut = next(iter(done))
        key = self.running.pop(fut)
        with worker_deaths_as_errors():
            return key, fut.result()

    def close(self, abort: bool) -> None:
        """Stop the workers (at once with ``abort``, and with them the fork server:
        process_cleanup.abort_pool); closing again does nothing."""
        from grasp_ctrl.trials.runs.process_cleanup import abort_pool

        if self.closed:
            return
        self.closed = True
        if abort:
            abort_pool(self.pool)
            return
        try:
            self.pool.shutdown(wait=True)
        except BaseException:  # Ctrl-C while the workers finish: they are stopped
            abort_pool(self.pool)
            raise


def _tune_trial_in_worker(
    token: str, hand: Any, policy: str, backend: str, variation: Any, task: TrialTask, settings: Any = None
) -> dict[str, Any]:
    """One trial in a Ray worker (its world drawn under ``variation``, its controller ``settings``);
    the policy is loaded once per worker, study (``token``) and settings."""
    from grasp_ctrl.trials.episode.runner import sim_trial_fn

    if _WORKER.get("token") != token:
        _WORKER["token"] = token
        _CACHE.clear()

    def make() -> Any:
        return sim_trial_fn(hand, [policy], settings, backend=backend, variation=variation)

    return _cached_fn(_CACHE, settings, make)(*task)


class RayExecutor:
    """Ray tasks (the ``ray`` extra): a local instance of ``jobs`` CPUs, or the cluster at ``address``."""

    def __init__(
        self,
        address: str | None,
        jobs: int | None,
        hand: Any,
        policy: str,
        backend: str,
        variation: Any = None,
        settings: Any = None,
    ) -> None:
        from grasp_ctrl.trials.runs.ray_executor import ray_session

        self.settings = settings
        self._session: Any = ray_session(address, jobs)
        self.ray = self._session.__enter__()
        self.remote = self.ray.remote(num_cpus=1)(_tune_trial_in_worker)
        self.shared = (uuid.uuid4().hex, self.ray.put(hand), policy, backend, variation)
        self.running: dict[Any, int] = {}

    def submit(self, key: int, task: TrialTask, settings: Any = None) -> None:
        self.running[self.remote.remote(*self.shared, task, settings or self.settings)] = key

    def next_done(self) -> tuple[int, dict[str, Any]]:
        ready, _ = self.ray.wait(list(self.running), num_returns=1)
        key = self.running.pop(ready[0])
        try:
            return key, self.ray.get(ready[0])
        except self.ray.exceptions.RayTaskError as exc:
            raise exc.as_instanceof_cause() from None

    def close(self, abort: bool) -> None:
        from grasp_ctrl.trials.runs.process_cleanup import interrupts_held

        if self._session is None:
            return
        session, self._session = self._session, None
        with interrupts_held():  # a second Ctrl-C does not cut the shutdown short
            try:
                for ref in self.running:
                    self.ray.cancel(ref, force=True)
                self.running.clear()
            finally:
                session.__exit__(None, None, None)
