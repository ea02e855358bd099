"""Per-sensor calibration: a small correction fitted on top of a force policy.

Every BioTac differs (electrode gains, skin, fluid), so a policy trained on one sensor reads
another with a direction bias and a wrong scale. A few minutes of labelled presses fix most of
it with a correction of the policy's output, fitted by least squares (see
``grasp_ctrl.estimators.calibrated`` for how it is applied):

- ``gains``: f = R diag(g) f_base, a rotation and per-axis gains (6 numbers);
- ``linear``: f = A f_base (9 numbers: gains, rotation and axis coupling);
- ``affine``: f = A f_base + b;
- ``residual``: f = A f_base + W e + b, plus a ridge-regularised linear term in the 19 tared
  electrodes: it also corrects patterns the base policy reads wrongly (63 + 3 numbers).

Labels come in two kinds:
- force labels (dataset files of docs/learning.md, F/T sensor, N, sensor frame): the
  correction maps f_base onto them;
- direction-only labels (``robotic_finger_tidy.csv``-style plate normals in a frame fixed to
  the mount, unknown rotation and sign): the mount frame is first estimated as the rotation
  (and sign) that best aligns the base policy's directions with the labels, the labels are
  brought into the sensor frame with it, and the correction maps f_base onto label direction x
  |f_base| (the magnitude stays the base policy's: it cannot be calibrated without magnitudes).
"""

from __future__ import annotations

import csv
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from grasp_ctrl.config.sensor_layout import ELECTRODES
from grasp_ctrl.errors import UsageError
from grasp_ctrl.evaluation.direction import angles_deg, fit_rotation, unit

MODELS = ("gains", "linear", "affine", "residual")
MIN_LABEL_N = 0.05  # labels below this are clamped in the relative weight (as in the training loss)
PLATE_COLUMNS = ("nx", "ny", "nz", "in_paper_trial")


@dataclass
class CalibrationData:
    trial_id: np.ndarray  # (n,) str
    tared: np.ndarray  # (n, 44) counts, in contact
    labels: np.ndarray  # (n, 3): force labels (N, sensor frame) or unit plate normals (mount frame)
    direction_only: bool
    notes: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.tared)

    def select(self, trial_ids: Sequence[str], what: str) -> CalibrationData:
        known = list(dict.fromkeys(self.trial_id.tolist()))
        unknown = [t for t in trial_ids if t not in known]
        if unknown:
            raise UsageError(
                f"{what}: unknown trial id {unknown[0]!r} (the file has {', '.join(known[:6])}"
                f"{', ...' if len(known) > 6 else ''})"
            )
        m = np.isin(self.trial_id, list(trial_ids))
        return CalibrationData(self.trial_id[m], self.tared[m], self.labels[m], self.direction_only, self.notes)


def is_plate_recording(path: Path) -> bool:
    """True for the robotic-finger format (plate normals), False for the dataset format."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            head = next(csv.reader(fh), [])
    except (OSError, UnicodeDecodeError, csv.Error):
        return False
    return all(c in [h.strip() for h in head] for c in PLATE_COLUMNS)


def load_data(
    path: Path, tare_frames: int | None = None, min_pdc: float = 50.0, skip_bad_rows: bool = False
) -> CalibrationData:
    """Labelled in-contact frames from a dataset file or a plate-normal recording.

    ``tare_frames``: dataset RAW files: minimum tare rows per trial (default 10); plate
    recordings: frames at each trial's start used as its baseline (default 50). ``min_pdc``:
    plate recordings only, also require tared pdc >= this (drops post-release drift frames).
    """
    if is_plate_recording(path):
        from grasp_ctrl.evaluation.direction import gate_trial
        from grasp_ctrl.evaluation.robotic_finger import read_trials

        parts = [gate_trial(t, tare_frames or 50, 10.0, 10, min_pdc) for t in read_trials(path, skip_bad_rows)]
        parts = [p for p in parts if len(p.tared)]
        if not parts:
            raise UsageError(f"{path}: no frames in contact")
        return CalibrationData(
            np.concatenate([np.full(len(p.tared), p.trial_id) for p in parts]),
            np.concatenate([p.tared for p in parts]),
            np.concatenate([p.labels for p in parts]),
            direction_only=True,
        )
    from grasp_ctrl.learning.dataset import read_dataset

    ds, _ = read_dataset(path, tare_frames or 10)
    notes = []
    if ds.projected.any():
        notes.append(f"{int(ds.projected.sum())} planar-pushing samples left out (only their in-plane part is a label)")
        ds = ds.subset(~ds.projected)
    if len(ds) == 0:
        raise UsageError(f"{path}: no samples with a full 3D force label")
    return CalibrationData(ds.trial_id, ds.tared, ds.f_sensor, direction_only=False, notes=notes)


@dataclass(frozen=True)
class LabelFrame:
    """Direction-only labels: R maps sensor-frame directions into the label frame, up to a sign."""

    rotation: Rotation
    sign: float

    def to_sensor(self, labels: np.ndarray) -> np.ndarray:
        return self.rotation.inv().apply(self.sign * unit(labels))


def estimate_label_frame(f_base: np.ndarray, labels: np.ndarray) -> LabelFrame:
    fit = fit_rotation(f_base, unit(labels))
    return LabelFrame(fit.rotation, fit.label_sign)


def targets(data: CalibrationData, f_base: np.ndarray, frame: LabelFrame | None) -> np.ndarray:
    """What the corrected policy should output, sensor frame."""
    if not data.direction_only:
        return data.labels
    assert frame is not None
    return frame.to_sensor(data.labels) * np.linalg.norm(f_base, axis=1, keepdims=True)


@dataclass
class Correction:
    model: str
    matrix: np.ndarray  # (3, 3)
    electrode_weights: np.ndarray | None  # (3, 19) N/count
    bias: np.ndarray  # (3,) N

    def apply(self, f_base: np.ndarray, tared: np.ndarray) -> np.ndarray:
        out = f_base @ self.matrix.T + self.bias
        if self.electrode_weights is not None:
            out = out + tared[:, ELECTRODES] @ self.electrode_weights.T
        return out

    def describe(self) -> dict[str, object]:
        """The fitted numbers, plus the matrix split into a rotation and a stretch (A = R S)."""
        u, s, vt = np.linalg.svd(self.matrix)
        d = np.sign(np.linalg.det(u @ vt)) or 1.0
        r = u @ np.diag([1.0, 1.0, d]) @ vt
        stretch = r.T @ self.matrix
        rotvec = Rotation.from_matrix(r).as_rotvec()
        return {
            "model": self.model,
            "formula": "f_sensor = matrix @ f_base + electrode_weights_n_per_count @ e + bias_n "
            "(e: the 19 tared electrodes, counts)",
            "matrix": self.matrix.tolist(),
            "electrode_weights_n_per_count": None
            if self.electrode_weights is None
            else self.electrode_weights.tolist(),
            "bias_n": self.bias.tolist(),
            "polar_rotation_deg": float(np.degrees(np.linalg.norm(rotvec))),
            "polar_rotation_axis": (rotvec / (np.linalg.norm(rotvec) or 1.0)).tolist(),
            "polar_stretch": stretch.tolist(),
        }


def fit_correction(
    f_base: np.ndarray, tared: np.ndarray, target: np.ndarray, model: str = "residual", ridge: float = 1e-3
) -> Correction:
    """Least squares of ``target ~ correction(f_base, tared)``, relative errors
    (each residual divided by |target|, at least MIN_LABEL_N: the paper's Q_3d), so light
    touches count as much as firm presses."""
    n = len(f_base)
    if model not in MODELS:
        raise ValueError(f"model: one of {', '.join(MODELS)}")
    weight = 1.0 / np.maximum(np.linalg.norm(target, axis=1), MIN_LABEL_N)[:, None]
    if model == "gains":

        def residual(x: np.ndarray) -> np.ndarray:
            m = Rotation.from_rotvec(x[:3]).as_matrix() @ np.diag(np.exp(x[3:]))
            return ((f_base @ m.T - target) * weight).ravel()

        x = least_squares(residual, np.zeros(6), method="lm" if n * 3 >= 6 else "trf").x
        m = Rotation.from_rotvec(x[:3]).as_matrix() @ np.diag(np.exp(x[3:]))
        return Correction(model, m, None, np.zeros(3))
    cols = [f_base]
    if model == "residual":
        cols.append(tared[:, ELECTRODES])
    if model in ("affine", "residual"):
        cols.append(np.ones((n, 1)))
    x = np.hstack(cols)
    # scale the columns so that one ridge strength fits any sensor; the force columns are not shrunk
    scale = np.r_[np.full(3, np.std(f_base) or 1.0), np.full(x.shape[1] - 3, 1.0)]
    if model == "residual":
        scale[3:22] = np.std(tared[:, ELECTRODES]) or 1.0
    xs = x / scale * weight
    penalty = np.zeros(x.shape[1])
    if model == "residual":
        penalty[3:22] = ridge * float(np.sum(weight**2))
    coef = (
        np.linalg.solve(xs.T @ xs + np.diag(penalty) + 1e-12 * np.eye(x.shape[1]), xs.T @ (target * weight))
        / scale[:, None]
    )
    m = coef[:3].T
    w = coef[3:22].T if model == "residual" else None
    b = coef[-1] if model in ("affine", "residual") else np.zeros(3)
    return Correction(model, m, w, b)


def error_summary(f_est: np.ndarray, data: CalibrationData, frame: LabelFrame | None) -> dict[str, float]:
    """Angle to the labels (deg: median, p75, p90) and, for force labels, |f_est| / |f| (median)."""
    if data.direction_only:
        assert frame is not None
        ang = angles_deg(frame.rotation.apply(unit(f_est)), frame.sign * unit(data.labels))
    else:
        ang = angles_deg(f_est, data.labels)
    out = {
        "n": int(len(ang)),
        "median_deg": float(np.median(ang)),
        "p75_deg": float(np.percentile(ang, 75)),
        "p90_deg": float(np.percentile(ang, 90)),
    }
    if not data.direction_only:
        ratio = np.linalg.norm(f_est, axis=1) / np.maximum(np.linalg.norm(data.labels, axis=1), 1e-9)
        out["magnitude_ratio_median"] = float(np.median(ratio))
        out["magnitude_error_n_median"] = float(
            np.median(np.abs(np.linalg.norm(f_est, axis=1) - np.linalg.norm(data.labels, axis=1)))
        )
    return out


@dataclass
class CalibrationResult:
    correction: Correction
    frame: LabelFrame | None
    metrics: dict[str, dict[str, dict[str, float]]]  # fit/test -> before/after -> summary


def calibrate(
    base_directions: Callable[[np.ndarray], np.ndarray],
    fit: CalibrationData,
    test: CalibrationData | None,
    model: str = "residual",
    ridge: float = 1e-3,
) -> CalibrationResult:
    """Fit the correction on ``fit``; report errors before and after on ``fit`` (and ``test``).

    ``base_directions``: tared (m, 44) -> the base policy's f_sensor (m, 3)."""
    f_fit = base_directions(fit.tared)
    frame = estimate_label_frame(f_fit, fit.labels) if fit.direction_only else None
    corr = fit_correction(f_fit, fit.tared, targets(fit, f_fit, frame), model, ridge)
    metrics = {
        "fit": {
            "before": error_summary(f_fit, fit, frame),
            "after": error_summary(corr.apply(f_fit, fit.tared), fit, frame),
        }
    }
    if test is not None and len(test):
        f_test = base_directions(test.tared)
        metrics["test"] = {
            "before": error_summary(f_test, test, frame),
            "after": error_summary(corr.apply(f_test, test.tared), test, frame),
        }
    return CalibrationResult(corr, frame, metrics)
