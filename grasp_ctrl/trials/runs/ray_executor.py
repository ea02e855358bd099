"""Sweeps beyond one machine: trials and training runs as Ray tasks (``--executor ray``).

Ray (the ``ray`` extra) is an existing distributed engine: ``--address`` joins a
running cluster (``ray start --head`` on one machine, ``ray start --address ...``
on the others); without it a local Ray instance is started with ``--jobs`` CPUs
and shut down afterwards. Each task runs one trial (or trains one model) exactly
as a local worker process does, and returns its record to this process, which
writes it: same records, same summary, same ``--resume``. Tick logs are written
by the task to the run directory's path, so on a multi-machine cluster that
directory must be on a shared filesystem (or run with ``--no-tick-logs``).
"""

from __future__ import annotations

import contextlib
import logging
import os
import uuid
from collections.abc import Callable, Generator, Iterator, Sequence
from typing import TYPE_CHECKING, Any

from grasp_ctrl.errors import UsageError

if TYPE_CHECKING:
    from grasp_ctrl.trials.episode.runner import TrialSetup

EXECUTORS = ("local", "ray")
_CACHE: dict[Any, Any] = {}  # per Ray worker process: trial functions, built once


def require_ray() -> Any:
    try:
        import ray
    except ImportError:
        raise UsageError("--executor ray needs Ray: pip install -e '.[ray]'") from None
    return ray


def check_executor(executor: str, address: str | None) -> None:
    if executor not in EXECUTORS:
        raise UsageError(f"--executor: one of {', '.join(EXECUTORS)} (got {executor!r})")
    if address and executor != "ray":
        raise UsageError("--address: only with --executor ray")
    if executor == "ray":
        require_ray()


@contextlib.contextmanager
def ray_session(address: str | None, cpus: int | None) -> Iterator[Any]:
    """Ray connected (to ``address``, or a local instance of ``cpus`` CPUs started here)."""
    from grasp_ctrl.trials.runs.process_cleanup import interrupts_held

    ray = require_ray()
    started = not ray.is_initialized()
    try:
        if started:
            kwargs: dict[str, Any] = {
                "include_dashboard": False,
                "log_to_driver": False,
                "logging_level": logging.WARNING,
            }
            if address:
                kwargs["address"] = address
            else:
                kwargs["num_cpus"] = cpus or os.cpu_count() or 1
            try:
                ray.init(**kwargs)
            except (ConnectionError, RuntimeError, ValueError) as exc:
                raise UsageError(
                    f"--address {address}: cannot connect to Ray ({exc})"
                    if address
                    else f"cannot start a local Ray instance ({exc})"
                ) from None
        yield ray
    finally:
        # Also after Ctrl-C inside ray.init: the local instance's processes may have started.
        # A second Ctrl-C does not cut the shutdown short.
        if started:
            with interrupts_held():
                ray.shutdown()


def _trial_in_worker(token: str, setup: TrialSetup, task: tuple) -> dict[str, Any]:
    """One trial of ``setup`` in a Ray worker; its policies are loaded once per worker and
    sweep (``token``)."""
    key = ("trial", token)
    if key not in _CACHE:
        _CACHE.clear()  # a worker of a long-lived cluster keeps only the current sweep's
        _CACHE[key] = setup.trial_fn()
    return _CACHE[key](*task)


def _fan_out(
    ray: Any, remote_fn: Any, args_list: Sequence[tuple], in_flight: int
) -> Generator[tuple[int, Any], None, None]:
    """(index, result) as the tasks finish, at most ``in_flight`` submitted at once (a
    short queue: Ctrl-C or an error cancels little)."""
    pending = iter(enumerate(args_list))
    running: dict[Any, int] = {}
    try:
        for i, args in pending:
            running[remote_fn.remote(*args)] = i
            if len(running) >= in_flight:
                break
        while running:
            ready, _ = ray.wait(list(running), num_returns=1)
            ref = ready[0]
            i = running.pop(ref)
            try:
                result = ray.get(ref)
            except ray.exceptions.RayTaskError as exc:
                cause = exc.as_instanceof_cause()
                raise cause from None
            yield i, result
            nxt = next(pending, None)
            if nxt is not None:
                running[remote_fn.remote(*nxt[1])] = nxt[0]
    finally:
        from grasp_ctrl.trials.runs.process_cleanup import interrupts_held

        with interrupts_held():
            for ref in running:
                ray.cancel(ref, force=True)


def ray_trials(
    address: str | None, jobs: int | None, setup: TrialSetup, tasks: Sequence[tuple]
) -> Generator[tuple[int, dict[str, Any]], None, None]:
    """Trials of ``setup`` as Ray tasks: yields (task index, record) as each finishes."""
    with ray_session(address, jobs) as ray:
        remote = ray.remote(num_cpus=1)(_trial_in_worker)
        shared = (uuid.uuid4().hex, ray.put(setup))
        parallel = jobs or int(ray.cluster_resources().get("CPU", 1))
        yield from _fan_out(ray, remote, [(*shared, task) for task in tasks], 2 * max(parallel, 1))


def ray_map(
    address: str | None,
    jobs: int | None,
    fn: Callable[..., Any],
    args_list: Sequence[tuple],
    shared: tuple = (),
    cpus_per_task: int = 1,
) -> Generator[tuple[int, Any], None, None]:
    """``fn(*shared, *args)`` for every args as Ray tasks: yields (index, result) as each
    finishes. ``shared`` (e.g. a dataset) goes to the object store once."""
    with ray_session(address, jobs) as ray:
        remote = ray.remote(num_cpus=cpus_per_task)(fn)
        refs = tuple(ray.put(x) for x in shared)
        parallel = jobs or int(ray.cluster_resources().get("CPU", 1))
        yield from _fan_out(ray, remote, [(*refs, *args) for args in args_list], 2 * max(parallel // cpus_per_task, 1))
