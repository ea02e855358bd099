"""Imported once by the fork server of ``run --jobs N`` (see series.parallel_trials).

Importing the trial code and loading its compiled kernels take about as long as
a few trials; done here once (trials/episode/warm_up.py), every worker process forked
from the server starts with both ready.

First of all the server asks to die with the command that started it, and each worker
with the server (process_cleanup.forkserver_dies_with_command): a command killed
outright leaves no fork server still importing, nor workers waiting for work.
"""

from __future__ import annotations

from grasp_ctrl.trials.runs.process_cleanup import forkserver_dies_with_command

forkserver_dies_with_command()  # before the seconds of importing and compiling below

from grasp_ctrl.trials.episode.warm_up import warm_kernels_once  # noqa: E402 (after the line above)

warm_kernels_once()  # a missing default file, say: the workers then load the kernels themselves
