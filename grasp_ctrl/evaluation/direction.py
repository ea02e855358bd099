"""Force-direction agreement with labelled plate normals on real BioTac data.

For each trial: tare on its first no-contact frames (``value - baseline``), run
the pdc contact gate frame by frame (the same :class:`ContactGate` the
controller uses), and estimate a force direction in the sensor frame for the
frames in contact. The label is the plate normal in a frame fixed to the BioTac
mount, related to the sensor frame by an unknown fixed rotation and with an
unknown global sign. So one rotation (Kabsch / orthogonal Procrustes, proper,
via scipy) and one label sign are fitted on one long trial and the angle to the
labels is measured on the other trial, both ways.

Direction estimators:
- ``policy:NAME``: any policy of the registry (e.g. the official network); its
  ``f_sensor`` direction.
- ``analytic``: the Lin et al. linear model, direction of ``S * sum_i e_i n_i``.
  Only relative gains matter for a direction; they are fitted on the training
  trial together with the rotation (2 gain ratios + rotation, minimising the
  mean 1 - cos). ``analytic-unit`` uses S = (1, 1, 1).
- ``surface-normal``: minus the outward surface normal at the contact point
  (a purely normal force pressing on the skin).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

from grasp_ctrl.config.sensor_layout import PDC
from grasp_ctrl.estimators.analytic import electrode_normal_sums
from grasp_ctrl.estimators.base import ForceEstimator
from grasp_ctrl.evaluation.robotic_finger import Trial
from grasp_ctrl.tactile.features import contact_points, surface_normals
from grasp_ctrl.tactile.tare import ContactGate, Tare

PERCENTILES = (50, 75, 90)


@dataclass(frozen=True)
class ContactSamples:
    trial_id: str
    tared: np.ndarray  # (m, 44) tared frames in contact
    labels: np.ndarray  # (m, 3) unit plate normals (mount frame)
    onset: int | None  # index of the first gated contact frame in the trial


def gate_trial(
    trial: Trial, tare_frames: int = 50, threshold: float = 10.0, frames: int = 10, min_pdc: float = 0.0
) -> ContactSamples:
    """Tare on the first ``tare_frames`` frames, gate contact, keep contact frames.

    ``min_pdc``: additionally require tared pdc >= this (drops the drift-only
    frames after a release, where pdc stays 15..25 counts above the baseline).
    """
    tare = Tare(1)
    tare.set_baseline(trial.raw[:tare_frames, None, :])
    gate = ContactGate(1, threshold, frames)
    tared = tare.apply(trial.raw)
    flags = np.array([gate.update(tared[i : i + 1])[0] for i in range(len(trial))])
    keep = flags & (tared[:, PDC] >= min_pdc)
    labels = trial.normals[keep]
    labels = labels / np.linalg.norm(labels, axis=1, keepdims=True)
    onset = int(np.argmax(flags)) if flags.any() else None
    return ContactSamples(trial.trial_id, tared[keep], labels, onset)


def unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def angles_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(np.sum(unit(a) * unit(b), axis=1), -1.0, 1.0)))


@dataclass(frozen=True)
class Fit:
    rotation: Rotation  # sensor frame -> mount frame
    label_sign: float  # +1 or -1 applied to the labels
    gains: np.ndarray | None = None


def fit_rotation(dirs: np.ndarray, labels: np.ndarray) -> Fit:
    """Best proper rotation dirs -> sign * labels, the sign chosen by fit quality."""
    best: Fit | None = None
    best_cost = np.inf
    for sign in (1.0, -1.0):
        rot, _ = Rotation.align_vectors(sign * labels, unit(dirs))
        cost = float(np.mean(1.0 - np.sum(rot.apply(unit(dirs)) * sign * labels, axis=1)))
        if cost < best_cost:
            best, best_cost = Fit(rot, sign), cost
    assert best is not None
    return best


def held_out_angles(fit: Fit, dirs: np.ndarray, labels: np.ndarray) -> np.ndarray:
    return angles_deg(fit.rotation.apply(unit(dirs)), fit.label_sign * labels)


# ---- direction estimators: tared (m, 44) -> (m, 3) directions, sensor frame ----


def policy_directions(estimator: ForceEstimator, batch: int = 1024) -> Callable[[np.ndarray], np.ndarray]:
    def run(tared: np.ndarray) -> np.ndarray:
        out = [
            estimator.estimate(tared[i : i + batch], ["finger"] * len(tared[i : i + batch])).f_sensor
            for i in range(0, len(tared), batch)
        ]
        return np.concatenate(out) if out else np.zeros((0, 3))

    return run


def surface_normal_directions(tared: np.ndarray) -> np.ndarray:
    return -surface_normals(contact_points(tared))


def fit_analytic_gains(tared: np.ndarray, labels: np.ndarray) -> Fit:
    """Relative per-axis gains (z fixed at 1) and the rotation, jointly."""
    s = electrode_normal_sums(tared)

    def fit_for(log_ratio: np.ndarray) -> tuple[Fit, float]:
        g = np.array([np.exp(log_ratio[0]), np.exp(log_ratio[1]), 1.0])
        f = fit_rotation(s * g, labels)
        cost = float(np.mean(1.0 - np.cos(np.radians(held_out_angles(f, s * g, labels)))))
        return Fit(f.rotation, f.label_sign, g), cost

    res = minimize(
        lambda x: fit_for(x)[1],
        x0=np.zeros(2),
        method="Nelder-Mead",
        options={"xatol": 1e-3, "fatol": 1e-7, "maxiter": 400},
    )
    return fit_for(res.x)[0]


@dataclass(frozen=True)
class DirectionResult:
    estimator: str
    train: str
    test: str
    n_train: int
    n_test: int
    percentiles: dict[int, float]
    label_sign: float
    gains: list[float] | None
    angles: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False, compare=False)  # (n_test,) deg
    rotation: Rotation | None = field(default=None, repr=False, compare=False)  # fitted sensor -> mount


def pooled_percentiles(results: Sequence[DirectionResult]) -> tuple[int, dict[int, float]]:
    """The two-fold figure: percentiles over the test errors of all folds together (n, {p: deg})."""
    ang = np.concatenate([r.angles for r in results]) if results else np.zeros(0)
    if len(ang) == 0:
        raise ValueError("no test angles to pool")
    return len(ang), {p: float(np.percentile(ang, p)) for p in PERCENTILES}


def evaluate(
    name: str, samples: Sequence[ContactSamples], directions: Callable[[np.ndarray], np.ndarray] | None
) -> list[DirectionResult]:
    """Train on each trial, test on each other trial. ``directions=None`` = analytic with fitted gains."""
    results = []
    dirs = {} if directions is None else {s.trial_id: directions(s.tared) for s in samples}
    for tr in samples:
        for te in samples:
            if te is tr:
                continue
            if directions is None:
                fit = fit_analytic_gains(tr.tared, tr.labels)
                d_test = electrode_normal_sums(te.tared) * fit.gains
            else:
                fit = fit_rotation(dirs[tr.trial_id], tr.labels)
                d_test = dirs[te.trial_id]
            ang = held_out_angles(fit, d_test, te.labels)
            results.append(
                DirectionResult(
                    name,
                    tr.trial_id,
                    te.trial_id,
                    len(tr.tared),
                    len(te.tared),
                    {p: float(np.percentile(ang, p)) for p in PERCENTILES},
                    fit.label_sign,
                    None if fit.gains is None else [float(g) for g in fit.gains],
                    ang,
                    fit.rotation,
                )
            )
    return results
