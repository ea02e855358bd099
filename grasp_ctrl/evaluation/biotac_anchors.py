"""How real the simulated BioTac looks: the anchor figures of docs/mock_world.md.

Two kinds of evidence, both from material no one here wrote:

(a) the authors' real-data network (``icra19_official``, trained on a real
    BioTac) reading simulated rigid-ft and ball-ft presses: median angle error,
    magnitude ratio per source and the correlation of magnitudes; and its error
    against the force's tilt from the pad normal, real beside simulated
    (``tilt_profile``);
(b) simulated in-contact electrode patterns against the real recordings of
    ``robotic_finger_tidy.csv`` (long trials A and B): share of the simulated
    variance inside real A's top-5 principal components, best scaled match of
    real frames among simulated ones, rising electrodes, largest drop over pdc
    and its log-log slope, rest noise.

``python launch.py biotac-anchors`` prints them; tests assert the bounds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from scipy.stats import spearmanr

from grasp_ctrl.config.sensor_layout import ELECTRODES, FRAME_LEN, PDC
from grasp_ctrl.evaluation.robotic_finger import Trial, read_trials
from grasp_ctrl.evaluation.tilt_profile import (
    TiltProfile,
    format_tilt_profiles,
    real_tilt_profile,
    simulated_tilt_profile,
)

if TYPE_CHECKING:
    from grasp_ctrl.estimators.base import ForceEstimator
    from grasp_ctrl.sim.biotac.model import BioTacParams

#: The two long trials of the real recordings (A: 7,106 rows, B: 6,469 rows).
TRIAL_A = "15330_1571242563995"
TRIAL_B = "15834_1571243162016"
REAL_TARE_ROWS = 50
PRESSED_PDC = 50.0  # tared pdc above which a frame counts as pressed
RISE_COUNTS = 20.0


@dataclass(frozen=True)
class PatternFigures:
    """Electrode-pattern statistics of one set of pressed frames."""

    frames: int
    variance_in_real_a_top5: float  # centred, share of this set's variance
    best_match_residual_median: float  # real B frames matched among this set's frames
    rising_electrodes_median: float  # electrodes with tared value > 20 counts
    max_rise_median: float  # counts, at tared pdc 300-400
    largest_drop_over_pdc_median: float
    drop_vs_pdc_loglog_slope: float
    rest_noise_sd: float  # counts, electrodes at rest


@dataclass(frozen=True)
class NetFigures:
    """The authors' network on simulated presses of one or more sources."""

    samples: int
    median_angle_deg: float
    magnitude_ratio_median: float
    magnitude_corr: float


def anchor_trials(path: str | Path, trial_ids: Sequence[str]) -> list[Trial]:
    """The real trials ``trial_ids`` of ``path``, in that order (the file is read once)."""
    trials = {t.trial_id: t for t in read_trials(path)}
    missing = [t for t in trial_ids if t not in trials]
    if missing:
        raise KeyError(f"{path}: no trial {missing[0]}")
    return [trials[t] for t in trial_ids]


def real_pressed(trials: Sequence[Trial]) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Per trial, (tared electrodes (k, 19), tared pdc (k,), electrode rest sd) of its
    pressed frames; tare = mean of its first 50 rows."""
    out = []
    for trial in trials:
        raw = trial.raw
        rest = raw[:REAL_TARE_ROWS]
        tared = raw - rest.mean(axis=0)
        pressed = tared[:, PDC] > PRESSED_PDC
        rest_sd = float(rest[:, ELECTRODES].std(axis=0).mean())
        out.append((tared[pressed][:, ELECTRODES], tared[pressed][:, PDC], rest_sd))
    return out


def top_components(e: np.ndarray, k: int = 5) -> np.ndarray:
    centred = e - e.mean(axis=0)
    return np.linalg.svd(centred, full_matrices=False)[2][:k]


def variance_share(e: np.ndarray, components: np.ndarray) -> float:
    centred = e - e.mean(axis=0)
    return float(np.sum((centred @ components.T) ** 2) / np.sum(centred**2))


def best_match_residuals(targets: np.ndarray, library: np.ndarray) -> np.ndarray:
    """Per target frame, min over library frames s and scales c >= 0 of |b - c s| / |b|."""
    lib_norm = np.linalg.norm(library, axis=1)
    lib = library[lib_norm > 0] / lib_norm[lib_norm > 0, None]
    unit_targets = targets / np.linalg.norm(targets, axis=1)[:, None]
    cos = np.empty(len(targets))
    # in blocks: a full targets x library product of large sets would not fit in memory
    block = max(1, 20_000_000 // max(1, len(lib)))
    for start in range(0, len(targets), block):
        cos[start : start + block] = np.clip(unit_targets[start : start + block] @ lib.T, 0.0, None).max(axis=1)
    return np.sqrt(np.clip(1.0 - cos**2, 0.0, None))


def pattern_figures(
    e: np.ndarray,
    pdc: np.ndarray,
    rest_sd: float,
    real_a: np.ndarray,
    real_b: np.ndarray,
    library: np.ndarray | None = None,
    max_targets: int = 1500,
) -> PatternFigures:
    """Figures of pressed frames ``e`` (k, 19) with tared ``pdc`` (k,) against real A and B;
    real B's frames are matched among ``library`` (default: the frames ``e`` themselves)."""
    keep = pdc > PRESSED_PDC
    e, pdc = e[keep], pdc[keep]
    step = max(1, len(real_b) // max_targets)
    matched_among = e if library is None else library
    drop = np.maximum(-e.min(axis=1), 1.0)
    mid = (pdc > 300) & (pdc < 400)
    return PatternFigures(
        frames=int(len(e)),
        variance_in_real_a_top5=variance_share(e, top_components(real_a)),
        best_match_residual_median=float(np.median(best_match_residuals(real_b[::step], matched_among))),
        rising_electrodes_median=float(np.median((e > RISE_COUNTS).sum(axis=1))),
        max_rise_median=float(np.median(e[mid].max(axis=1))) if mid.any() else float("nan"),
        largest_drop_over_pdc_median=float(np.median(drop / pdc)),
        drop_vs_pdc_loglog_slope=float(np.polyfit(np.log(pdc), np.log(drop), 1)[0]),
        rest_noise_sd=rest_sd,
    )


def net_figures(f_est: np.ndarray, f_true: np.ndarray) -> NetFigures:
    mag_est = np.linalg.norm(f_est, axis=1)
    mag_true = np.linalg.norm(f_true, axis=1)
    ok = (mag_est > 1e-9) & (mag_true > 1e-9)
    cos = np.sum(f_est[ok] * f_true[ok], axis=1) / (mag_est[ok] * mag_true[ok])
    angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    return NetFigures(
        samples=int(ok.sum()),
        median_angle_deg=float(np.median(angle)),
        magnitude_ratio_median=float(np.median(mag_est[ok] / mag_true[ok])),
        magnitude_corr=float(np.corrcoef(mag_est[ok], mag_true[ok])[0, 1]),
    )


#: Tared pdc bins (counts) of the pressure response, the range the real recordings cover.
PRESSURE_BINS = ((50.0, 100.0), (100.0, 200.0), (200.0, 300.0), (300.0, 400.0), (400.0, 500.0))
MIN_BIN_FRAMES = 10


@dataclass(frozen=True)
class PressureResponse:
    """How a network's force magnitude follows tared pdc on one set of pressed frames."""

    frames: int
    median_n_by_bin: tuple[float, ...]  # median |f_est| (N) per PRESSURE_BINS; nan under 10 frames
    rank_corr: float  # Spearman correlation of |f_est| with tared pdc, pdc 50-500

    @property
    def rise(self) -> float:
        """Median |f_est| at pdc 400-500 over that at pdc 50-100."""
        return self.median_n_by_bin[-1] / self.median_n_by_bin[0]


def pressure_response(f_est: np.ndarray, pdc: np.ndarray) -> PressureResponse:
    mag = np.linalg.norm(f_est, axis=1)
    medians = []
    for lo, hi in PRESSURE_BINS:
        inside = (pdc >= lo) & (pdc < hi)
        medians.append(float(np.median(mag[inside])) if inside.sum() >= MIN_BIN_FRAMES else float("nan"))
    # over the bins' range only: the real recordings reach pdc 500-700, simulated presses 3000
    span = (pdc >= PRESSURE_BINS[0][0]) & (pdc < PRESSURE_BINS[-1][1])
    return PressureResponse(
        frames=int(span.sum()),
        median_n_by_bin=tuple(medians),
        rank_corr=float(spearmanr(mag[span], pdc[span]).statistic),
    )


def tared_frames(e: np.ndarray, pdc: np.ndarray) -> np.ndarray:
    """(k, 44) tared frames holding only electrodes and pdc (what the networks read)."""
    frames = np.zeros((len(e), FRAME_LEN))
    frames[:, ELECTRODES] = e
    frames[:, PDC] = pdc
    return frames


@dataclass(frozen=True)
class AnchorReport:
    per_source: dict[str, NetFigures]
    pooled: NetFigures
    simulated: PatternFigures
    real_b: PatternFigures  # the real-to-real reference (B against A)
    # (d): the network's magnitude against tared pdc: real A, real B, simulated rigid-ft
    pressure: dict[str, PressureResponse]
    # (b) split by where the skin is pressed (``location_shares``)
    location_share: LocationShare
    # (a) split by the tilt of the force from the pad normal: real plate presses, simulated presses
    tilt_real: TiltProfile
    tilt_simulated: TiltProfile


ANCHOR_SOURCES = ("rigid-ft", "ball-ft")


def rest_noise_sd(params: BioTacParams | None = None, frames: int = 200, seed: int = 0) -> float:
    """Electrode noise sd (counts) of simulated sensors at rest, measured as on the real data."""
    from grasp_ctrl.sim.biotac.model import DEFAULT_PARAMS, BioTacSensorModel

    model = BioTacSensorModel(4, np.random.default_rng(seed), params or DEFAULT_PARAMS)
    zeros = np.zeros((4, 3))
    raw = np.stack([model.frames(zeros, zeros, zeros, np.zeros(4, bool), np.zeros(4), 0.01) for _ in range(frames)])
    return float(raw[:, :, ELECTRODES].std(axis=0).mean())


@dataclass(frozen=True)
class RealAnchors:
    """What ``anchor_report`` reads off the real recordings alone, the same for every simulated
    model: compute it once (``real_anchors``) to report on several ``params``."""

    policy: str
    trials: list[Trial]
    real_a: np.ndarray  # tared pressed electrodes of trial A (k, 19)
    real_b: np.ndarray
    pressure: dict[str, PressureResponse]  # "real A", "real B"
    real_b_figures: PatternFigures  # real B against A
    tilt_real: TiltProfile


def real_anchors(
    real_path: str | Path, policy: str = "icra19_official", net: ForceEstimator | None = None
) -> RealAnchors:
    """The real-data side of the anchor figures (trials A and B of ``real_path``, read by
    ``policy``; ``net``: that policy already loaded)."""
    from grasp_ctrl.estimators.registry import load_policy

    trials = anchor_trials(real_path, (TRIAL_A, TRIAL_B))
    (real_a, pdc_a, _), (real_b, pdc_b, rest_b) = real_pressed(trials)
    net = net or load_policy(policy)
    pressure = {
        name: pressure_response(net.estimate(tared_frames(e, pdc), ["real"] * len(e)).f_sensor, pdc)
        for name, e, pdc in (("real A", real_a, pdc_a), ("real B", real_b, pdc_b))
    }
    return RealAnchors(
        policy=policy,
        trials=trials,
        real_a=real_a,
        real_b=real_b,
        pressure=pressure,
        # real B against A (matched among A's frames: among its own it would be 0)
        real_b_figures=pattern_figures(real_b, pdc_b, rest_b, real_a, real_b, library=real_a),
        tilt_real=real_tilt_profile(trials, net),
    )


def anchor_report(
    real_path: str | Path,
    n_per_source: int = 20000,
    seed: int = 7,
    params: BioTacParams | None = None,
    policy: str = "icra19_official",
    real: RealAnchors | None = None,
) -> AnchorReport:
    """All anchor figures of the simulated BioTac (``params``, default: the model's defaults)
    on ``n_per_source`` synthetic force samples of rigid-ft and ball-ft; ``real``: the real-data
    side already computed (``real_anchors`` of ``real_path`` and ``policy``)."""
    from grasp_ctrl.estimators.registry import load_policy
    from grasp_ctrl.learning.synthetic import generate_source, mock_biotac_forward

    net = load_policy(policy)
    if real is None:
        real = real_anchors(real_path, policy, net)
    elif real.policy != policy:
        raise ValueError(f"anchor_report: real anchors read by {real.policy!r}, not {policy!r}")
    real_a, real_b = real.real_a, real.real_b
    pressure = dict(real.pressure)
    forward = mock_biotac_forward(params)
    rng = np.random.default_rng(seed)
    per_source: dict[str, NetFigures] = {}
    tared_all, est_all, label_all = [], [], []
    for source in ANCHOR_SOURCES:
        data = generate_source(source, n_per_source, forward, rng)
        est = net.estimate(data.tared, ["sim"] * len(data.tared)).f_sensor
        per_source[source] = net_figures(est, data.f_sensor)
        if source == "rigid-ft":  # pad presses, as the real plate presses
            pressure["simulated rigid-ft"] = pressure_response(est, data.tared[:, PDC])
        tared_all.append(data.tared)
        est_all.append(est)
        label_all.append(data.f_sensor)
    tared = np.vstack(tared_all)
    simulated = pattern_figures(tared[:, ELECTRODES], tared[:, PDC], rest_noise_sd(params), real_a, real_b)
    return AnchorReport(
        per_source=per_source,
        pooled=net_figures(np.vstack(est_all), np.vstack(label_all)),
        simulated=simulated,
        real_b=real.real_b_figures,
        pressure=pressure,
        location_share=location_shares(real_a, params),
        tilt_real=real.tilt_real,
        tilt_simulated=simulated_tilt_profile(np.vstack(est_all), np.vstack(label_all)),
    )


def format_report(report: AnchorReport) -> str:
    lines = [
        "the authors' network (icra19_official) on simulated presses:",
        f"  {'source':10s} {'samples':>7s} {'median angle':>12s} {'|f_est|/|f|':>11s} {'corr':>6s}",
    ]
    for name, fig in [*report.per_source.items(), ("pooled", report.pooled)]:
        lines.append(
            f"  {name:10s} {fig.samples:7d} {fig.median_angle_deg:10.1f} deg {fig.magnitude_ratio_median:11.2f} "
            f"{fig.magnitude_corr:6.2f}"
        )
    lines.append("electrode patterns of pressed frames (tared pdc > 50):")
    lines.append(f"  {'figure':40s} {'simulated':>10s} {'real B':>10s}")
    for key in PatternFigures.__dataclass_fields__:
        sim, real = getattr(report.simulated, key), getattr(report.real_b, key)
        lines.append(f"  {key:40s} {sim:10.3g} {real:10.3g}")
    lines.append("its force magnitude against the fluid pressure: median |f_est| (N) per tared pdc bin:")
    bins = "".join(f"{f'{lo:.0f}-{hi:.0f}':>9s}" for lo, hi in PRESSURE_BINS)
    lines.append(f"  {'frames':20s} {bins}   rise  rank corr")
    for name, resp in report.pressure.items():
        cells = "".join(f"{m:9.2f}" for m in resp.median_n_by_bin)
        lines.append(f"  {name:20s} {cells} {resp.rise:6.2f} {resp.rank_corr:10.2f}")
    lines.append(format_tilt_profiles(report.tilt_real, report.tilt_simulated))
    return "\n".join(lines)


#: Normal presses along the pad's midline (sensor x, m) and their forces (N) for ``pad_press_ratios``;
#: -3 mm is the pad point the fingertip IK and the mock world's pad-centre contact use.
PAD_SCAN_X_M = (-0.012, -0.009, -0.006, -0.003, 0.0, 0.003)
PAD_SCAN_FORCES_N = (0.5, 1.0, 2.0, 3.0)


def pad_press_ratios(
    params: BioTacParams | None = None, policy: str = "icra19_official", hold_s: float = 1.0, seed: int = 0
) -> np.ndarray:
    """|f_est| / |f| of ``policy`` for steady normal presses on the simulated pad: rows
    PAD_SCAN_X_M, columns PAD_SCAN_FORCES_N. A grasp presses the pad near one spot with
    about tau = 2 N, so this is the read the controller gets; the pooled anchor figures
    average it over the press locations of the training sources."""
    from grasp_ctrl.estimators.registry import load_policy
    from grasp_ctrl.kinematics.fingertip import SKIN_RADIUS_M
    from grasp_ctrl.sim.biotac.model import DEFAULT_PARAMS, BioTacSensorModel

    net = load_policy(policy)
    model = BioTacSensorModel(1, np.random.default_rng(seed), params or DEFAULT_PARAMS)
    dt, zeros, free = 0.01, np.zeros((1, 3)), np.zeros(1, dtype=bool)
    steps = max(1, int(round(hold_s / dt)))
    rest = np.mean([model.frames(zeros, zeros, zeros, free, np.zeros(1), dt) for _ in range(50)], axis=0)
    normal_sensor = np.array([[0.0, 0.0, -1.0]])
    ratios = np.empty((len(PAD_SCAN_X_M), len(PAD_SCAN_FORCES_N)))
    for i, x in enumerate(PAD_SCAN_X_M):
        for j, force in enumerate(PAD_SCAN_FORCES_N):
            point = np.array([[x, 0.0, -SKIN_RADIUS_M]])
            f_sensor = np.array([[0.0, 0.0, force]])
            for _ in range(steps):
                frame = model.frames(point, f_sensor, normal_sensor, ~free, np.zeros(1), dt)
            est = net.estimate(frame - rest, ["sim"]).f_sensor[0]
            ratios[i, j] = float(np.linalg.norm(est)) / force
            for _ in range(3 * steps):  # let the slow part of the load decay before the next press
                model.frames(zeros, zeros, zeros, free, np.zeros(1), dt)
    return ratios


def format_pad_scan(ratios: np.ndarray, policy: str = "icra19_official") -> str:
    forces = "  ".join(f"{f:>5.1f} N" for f in PAD_SCAN_FORCES_N)
    lines = [
        f"{policy} on steady normal pad presses, |f_est| / |f| (sensor x along the pad midline):",
        f"  x (mm)   {forces}",
    ]
    for x, row in zip(PAD_SCAN_X_M, ratios):
        lines.append(f"  {x * 1000:+6.0f}   " + "  ".join(f"{r:7.2f}" for r in row))
    within = float(np.mean((ratios >= 0.5) & (ratios <= 2.0)))
    lines.append(f"  median {np.median(ratios):.2f}; within 0.5-2: {within:.0%}")
    return "\n".join(lines)


#: Press locations of the location scan (sensor x along the pad, m): from the back of the pad to the
#: tip cap. The real recordings press at the front: their drop-weighted electrode centroid has
#: median x = 1.4 mm, quartiles 0 to 3 mm, which simulated contacts at x = 0 to +5 mm reproduce.
LOCATION_SCAN_X_M = (-0.012, -0.008, -0.004, 0.0, 0.003, 0.006)
LOCATION_SCAN_PRESSES = 400


@dataclass(frozen=True)
class LocationShare:
    """Share of simulated pressed-frame variance inside real A's top-5 components, per press location."""

    x_m: tuple[float, ...]
    share: tuple[float, ...]
    real_centroid_x_m: tuple[float, float, float]  # real A's drop centroid: quartiles (m)


def drop_centroid_x(e: np.ndarray) -> np.ndarray:
    """Sensor x (m) of the drop-weighted electrode centroid of each tared frame (k, 19)."""
    from grasp_ctrl.tactile.geometry import ELECTRODE_POSITIONS_SENSOR

    w = np.clip(-e, 0.0, None)
    total = w.sum(axis=1)
    x = np.full(len(e), np.nan)
    x[total > 0] = (w[total > 0] @ ELECTRODE_POSITIONS_SENSOR[:, 0]) / total[total > 0]
    return x


def location_shares(real_a: np.ndarray, params: BioTacParams | None = None, seed: int = 0) -> LocationShare:
    """How much of the variance of steady presses at each LOCATION_SCAN_X_M (up to 60 degrees to
    either side of the pad centre, 0.5-6 N, tangential part up to 0.3 of the normal force) the
    top-5 principal components of real A's pressed electrodes ``real_a`` (k, 19) capture. The
    anchor figure pools the training sources' press locations; this splits it by where the skin
    is pressed."""
    from grasp_ctrl.learning.features import surface_point_and_normal
    from grasp_ctrl.sim.biotac.model import DEFAULT_PARAMS, N_GAIN, pack_params, static_frames
    from grasp_ctrl.sim.biotac.presses import sheared_forces
    from grasp_ctrl.tactile.geometry import SURFACE_RADIUS_M

    components = top_components(real_a)
    constants = pack_params(params or DEFAULT_PARAMS)
    rng = np.random.default_rng(seed)
    n = LOCATION_SCAN_PRESSES
    shares = []
    for x in LOCATION_SCAN_X_M:
        angle = rng.uniform(-np.pi / 3, np.pi / 3, n)
        radial = np.stack([x + rng.normal(0.0, 1e-3, n), np.sin(angle), -np.cos(angle)], axis=1)
        radial[:, 1:] *= SURFACE_RADIUS_M
        points, normals = surface_point_and_normal(radial)
        magnitude = np.exp(rng.uniform(np.log(0.5), np.log(6.0), n))
        f_sensor = sheared_forces(normals, magnitude, rng.uniform(0.0, 0.3, n), rng)
        out = static_frames(
            np.ascontiguousarray(points),
            np.ascontiguousarray(normals),
            np.ascontiguousarray(f_sensor),
            np.ones((n, N_GAIN)),
            constants,
        )
        pressed = out[:, 19] > PRESSED_PDC
        shares.append(variance_share(out[pressed, :19], components))
    quartiles = np.nanpercentile(drop_centroid_x(real_a), [25, 50, 75])
    return LocationShare(
        x_m=LOCATION_SCAN_X_M,
        share=tuple(shares),
        real_centroid_x_m=(float(quartiles[0]), float(quartiles[1]), float(quartiles[2])),
    )


def format_location_shares(scan: LocationShare) -> str:
    q = [v * 1000 for v in scan.real_centroid_x_m]
    lines = [
        "variance of simulated presses inside real A's top-5 components, by press location (real B: see above):",
        "  x (mm)  " + "".join(f"{x * 1000:>7.0f}" for x in scan.x_m),
        "  share   " + "".join(f"{s:7.2f}" for s in scan.share),
        f"  real A presses at the front: drop centroid x quartiles {q[0]:.1f} / {q[1]:.1f} / {q[2]:.1f} mm",
    ]
    return "\n".join(lines)
