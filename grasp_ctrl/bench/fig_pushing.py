"""Planar-pushing ground truth throughput: samples solved per second (docs/design.md 5.6).

Each measurement solves whole simulated pushes from tracked (noisy) poses:
Savitzky-Golay differentiation, 80-particle friction and the least squares,
i.e. what ``pushing-gt`` does per trajectory (file I/O excluded); only
samples that get a force (moving, in contact) are counted as solved.
"""

from __future__ import annotations

import time

import numpy as np

from grasp_ctrl.bench.figure import Figure
from grasp_ctrl.pushing.kinematics import planar_motion
from grasp_ctrl.pushing.simulate import PAPER_BOX, simulate_push
from grasp_ctrl.pushing.solver import pusher_forces


def _pushes(n: int) -> list:
    rng = np.random.default_rng(7)
    return [simulate_push(rng).tracked(rng, 3e-4, 3e-3) for _ in range(n)]


def _throughput(method: str, quick: bool) -> Figure:
    pushes = _pushes(2 if quick else 8)
    repeats = 1 if quick else (5 if method == "slsqp" else 30)
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        solved = 0
        for p in pushes:
            m = planar_motion(p.t, p.x, p.y, p.theta)
            f = pusher_forces(m, p.contact_object, p.in_contact, PAPER_BOX, method=method)
            solved += int(np.sum(~np.isnan(f.f_world[:, 0])))  # samples with a force
        rates.append(solved / (time.perf_counter() - t0))
    return Figure.rate(rates, "samples/s")


FIGURES = {
    "pushing_gt_closed_form_per_s": lambda quick: _throughput("closed-form", quick),
    "pushing_gt_slsqp_per_s": lambda quick: _throughput("slsqp", quick),
}
