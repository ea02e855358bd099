"""The authors' network's direction error against the tilt of the force from the pad normal.

Anchor (a) pools all presses into one median. This splits it by how far the force
points away from the pad normal (+z of the sensor frame), on a real BioTac and on the
simulated one, so that one can see where the simulated sensor is read unlike a real one.

- Real: the two long trials of ``robotic_finger_tidy.csv``, with the protocol of
  ``evaluate-direction`` (``direction.evaluate``: tare, contact gate, one rotation and label
  sign fitted on one trial and tested on the other, both ways). The label is the plate normal; its tilt is
  taken in the sensor frame the fitted rotation gives. The hand-held plate tilts up to
  about 80 deg, mostly toward the tip cap.
- Simulated: the anchor's rigid-ft and ball-ft presses; the tilt of the true force.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from grasp_ctrl.evaluation.direction import angles_deg, evaluate, gate_trial, policy_directions

if TYPE_CHECKING:
    from grasp_ctrl.estimators.base import ForceEstimator
    from grasp_ctrl.evaluation.robotic_finger import Trial

#: Tilt bins (deg) of the force from the pad normal. The real recordings have no force
#: beyond 90 deg; simulated ball-ft contacts above the equator do.
TILT_BINS_DEG = ((0.0, 15.0), (15.0, 30.0), (30.0, 45.0), (45.0, 60.0), (60.0, 90.0), (90.0, 180.0))
MIN_BIN_SAMPLES = 20
PAD_NORMAL_INWARD = np.array([0.0, 0.0, 1.0])  # +z: a press straight on the pad


@dataclass(frozen=True)
class TiltProfile:
    """Median direction error (deg) and sample count per ``TILT_BINS_DEG`` bin (nan under 20 samples)."""

    samples: tuple[int, ...]
    median_error_deg: tuple[float, ...]


def tilt_deg(directions: np.ndarray) -> np.ndarray:
    """(n, 3) directions -> angle (deg) from +z, the pad normal pointing into the finger."""
    d = np.asarray(directions, dtype=float)
    return angles_deg(d, np.broadcast_to(PAD_NORMAL_INWARD, d.shape))


def profile(errors_deg: np.ndarray, tilts_deg: np.ndarray) -> TiltProfile:
    counts, medians = [], []
    last_hi = TILT_BINS_DEG[-1][1]
    for lo, hi in TILT_BINS_DEG:
        # the last bin is closed: a force straight away from the pad reads 180 deg
        below_hi = tilts_deg <= hi if hi == last_hi else tilts_deg < hi
        inside = (tilts_deg >= lo) & below_hi
        counts.append(int(inside.sum()))
        medians.append(float(np.median(errors_deg[inside])) if inside.sum() >= MIN_BIN_SAMPLES else float("nan"))
    return TiltProfile(tuple(counts), tuple(medians))


def real_tilt_profile(trials: Sequence[Trial], estimator: ForceEstimator) -> TiltProfile:
    """Held-out errors of ``estimator`` on the real ``trials`` (every train / test pair, as
    ``evaluate-direction``), binned by the test label's tilt in the fitted sensor frame."""
    samples = {t.trial_id: gate_trial(t) for t in trials}
    results = evaluate("tilt", list(samples.values()), policy_directions(estimator))
    errors, tilts = [], []
    for r in results:
        assert r.rotation is not None  # a policy's directions: a fitted rotation, no gains
        errors.append(r.angles)
        # the label in the sensor frame: the fitted rotation maps sensor -> mount
        tilts.append(tilt_deg(r.rotation.inv().apply(r.label_sign * samples[r.test].labels)))
    return profile(np.concatenate(errors), np.concatenate(tilts))


def simulated_tilt_profile(f_est: np.ndarray, f_true: np.ndarray) -> TiltProfile:
    """Errors of network estimates ``f_est`` against the true forces, binned by the true force's tilt."""
    return profile(angles_deg(f_est, f_true), tilt_deg(f_true))


def format_tilt_profiles(real: TiltProfile, simulated: TiltProfile) -> str:
    lines = [
        "its direction error against the tilt of the force from the pad normal (median deg, samples):",
        f"  {'tilt (deg)':12s} {'real (plate presses)':>22s} {'simulated (rigid-ft + ball-ft)':>32s}",
    ]
    for (lo, hi), n_r, e_r, n_s, e_s in zip(
        TILT_BINS_DEG, real.samples, real.median_error_deg, simulated.samples, simulated.median_error_deg
    ):
        lines.append(f"  {f'{lo:.0f}-{hi:.0f}':12s} {e_r:14.1f} ({n_r:5d}) {e_s:24.1f} ({n_s:5d})")
    return "\n".join(lines)


__all__ = [
    "TILT_BINS_DEG",
    "TiltProfile",
    "format_tilt_profiles",
    "profile",
    "real_tilt_profile",
    "simulated_tilt_profile",
    "tilt_deg",
]
