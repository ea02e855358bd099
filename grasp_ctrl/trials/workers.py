"""Where the worker processes of ``run --jobs N`` (and ``tune --jobs N``) come from.

Workers are forked from a fork server that has imported the trial code and
loaded the compiled kernels (worker_preload.py), so each starts at once; where
there is no fork server (Windows) they are spawned. Never forked from the
command's own process: no inherited inference sessions or threads.
"""

from __future__ import annotations

import multiprocessing
from typing import Any

PRELOAD = ["grasp_ctrl.trials.worker_preload"]


def worker_context() -> Any:
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(PRELOAD)
        return ctx
    return multiprocessing.get_context("spawn")
