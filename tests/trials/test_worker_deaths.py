"""A worker that dies is one WorkerError, wherever the pool finds out: at a trial's result or at
the next submit (the pool can break between the two)."""

from __future__ import annotations

from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool

import pytest

from grasp_ctrl.trials.runs import series, workers
from grasp_ctrl.trials.runs.workers import WorkerError, worker_deaths_as_errors
from grasp_ctrl.trials.tuning.tune_executors import ProcessExecutor


class _PoolThatBreaksAfter:
    """A process pool whose first ``ok`` submits finish at once; later ones find it broken."""

    def __init__(self, ok: int, result_breaks: bool = False) -> None:
        self.ok = ok
        self.result_breaks = result_breaks
        self.submits = 0

    def submit(self, fn, *args):  # noqa: ANN001, ANN201
        self.submits += 1
        if self.submits > self.ok:
            raise BrokenProcessPool("A child process terminated abruptly")
        fut: Future = Future()
        if self.result_breaks:
            fut.set_exception(BrokenProcessPool("A child process terminated abruptly"))
        else:
            fut.set_result({"task": args})
        return fut


def test_a_broken_pool_is_a_worker_error():
    with pytest.raises(WorkerError, match="ended abruptly"), worker_deaths_as_errors():
        raise BrokenProcessPool("boom")


def test_other_errors_pass_unchanged():
    with pytest.raises(ValueError), worker_deaths_as_errors():
        raise ValueError("not a dead worker")


@pytest.mark.parametrize("result_breaks", [False, True])
def test_parallel_trials_turn_a_broken_pool_into_one_worker_error(monkeypatch, result_breaks):
    pool = _PoolThatBreaksAfter(ok=2, result_breaks=result_breaks)
    stopped = []
    monkeypatch.setattr(workers, "start_pool", lambda *a: pool)
    monkeypatch.setattr(series, "_stop_workers", stopped.append)
    tasks = [("oracle", None, k, k, None) for k in range(6)]
    got = []
    with pytest.raises(WorkerError, match="ended abruptly"):
        for i, _ in series.parallel_trials(1, None, tasks):
            got.append(i)
    # The pool broke at the third submit (after one trial's result) or at the first result.
    assert len(got) == (0 if result_breaks else 1)
    assert stopped == [pool]  # the workers are stopped, not waited for


def test_the_tuning_executor_turns_a_broken_pool_into_one_worker_error():
    executor = ProcessExecutor.__new__(ProcessExecutor)  # no real pool
    executor.pool = _PoolThatBreaksAfter(ok=1)
    executor.running = {}
    executor.settings = None
    executor.submit(0, ("oracle", None, 0, 0, None))
    assert executor.next_done()[0] == 0
    with pytest.raises(WorkerError, match="ended abruptly"):
        executor.submit(1, ("oracle", None, 1, 1, None))
