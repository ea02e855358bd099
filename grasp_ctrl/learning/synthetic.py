"""Synthetic datasets of the three sources from a BioTac forward model.

The forward model is any callable ``forward(contact_point_sensor (n, 3), f_sensor (n, 3), rng)
-> raw (n, 44)``; one call is one trial of consecutive samples of one sensor at 100 Hz (a zero
force means no contact). ``mock_biotac_forward`` adapts the mock world's model.

Character of each source (paper II-B, III-A):
- rigid-ft: presses on the pad, large (1-12 N) mostly normal forces; the label is the true force
  plus force/torque-sensor noise with a per-trial standard deviation of 0.01-0.1 N;
- ball-ft: contacts all over the sensor (random sensor orientations relative to the ball), large
  tangential parts; labels are rotated by a small per-trial orientation error (tracking) plus F/T
  noise. Given recorded grasp contacts (``sim/biotac/grasp_contacts.py``: where the LEAP Hand's grasps
  load a fingertip in MuJoCo), half of the ball-ft trials press at one of those contacts along its
  force's direction (or with its shear reversed) instead: the paper's robot pressed the ball with
  its own hand, so its contacts were the hand's;
- planar-pushing: a 0.65 kg box with mu = 0.1 pushed by the fingertip (0.1-2 N); the label is the
  pusher force recovered by the planar-pushing solver from noisy tracked poses, rotated into the
  sensor frame, projected (the fingertip also feels an unmodelled vertical force).

Only force samples enter a dataset: those where the contact gate (tared pdc > 10 counts for 10
samples) is on, as on the robot. ``generate_trials`` also keeps each trial's whole raw stream
(tare window and ungated frames) for RAW dataset files (``launch.py synth --raw``); the reader
picks the same samples from it as ``generate`` does.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from grasp_ctrl.config.sensor_layout import PDC
from grasp_ctrl.learning.dataset import SOURCES, Dataset, RawTrial
from grasp_ctrl.learning.features import surface_point_and_normal
from grasp_ctrl.learning.gate import GateRule, contact_gate
from grasp_ctrl.pushing.kinematics import planar_motion
from grasp_ctrl.pushing.simulate import PAPER_BOX, simulate_push
from grasp_ctrl.pushing.solver import plane_force_to_sensor, pusher_forces
from grasp_ctrl.sim.biotac.grasp_contacts import GraspContacts
from grasp_ctrl.sim.biotac.presses import reverse_shear
from grasp_ctrl.tactile.geometry import SURFACE_RADIUS_M

if TYPE_CHECKING:
    from grasp_ctrl.sim.biotac.model import BioTacParams

ForwardModel = Callable[[np.ndarray, np.ndarray, np.random.Generator], np.ndarray]
TARE_FRAMES = 20
RATE_HZ = 100.0


@dataclass
class SimTrial:
    """One simulated trial: the whole raw stream and what the dataset keeps of it."""

    trial_id: str
    source: str
    raw: np.ndarray  # (TARE_FRAMES + n, 44) counts: the contact-free tare window, then the stream
    label: np.ndarray  # (n, 3) N, f_sensor label; NaN where the source gives none (unsolved push)
    keep: np.ndarray  # (n,) bool: force samples (contact gate on, non-zero label)
    projected: np.ndarray  # (n,) bool
    rotation: np.ndarray  # (n, 3, 3) R_world_sensor

    def tared(self) -> np.ndarray:
        """(n, 44) stream tared on the mean of the tare window."""
        return (self.raw - self.raw[:TARE_FRAMES].mean(axis=0))[TARE_FRAMES:]

    def dataset(self) -> Dataset:
        keep = self.keep
        n = int(keep.sum())
        return Dataset(
            trial_id=np.full(n, self.trial_id),
            source=np.full(n, self.source),
            t=np.flatnonzero(keep) / RATE_HZ,
            tared=self.tared()[keep],
            f_sensor=self.label[keep],
            projected=self.projected[keep],
            r_world_sensor=self.rotation[keep],
        )

    def raw_rows(self) -> RawTrial:
        """The RAW file rows: tare window labelled 0 0 0, then every stream frame (t = 0 at its start)."""
        n = len(self.label)
        label = np.vstack([np.zeros((TARE_FRAMES, 3)), self.label])
        # a stream frame without a usable label is written unlabelled, never "0 0 0", which would
        # extend the tare window when it is the first frame after it
        stream_label = label[TARE_FRAMES:]
        stream_label[~(np.linalg.norm(np.nan_to_num(stream_label), axis=1) > 0)] = np.nan
        return RawTrial(
            trial_id=self.trial_id,
            source=self.source,
            t=np.arange(-TARE_FRAMES, n) / RATE_HZ,
            raw=self.raw,
            f_sensor=label,
            projected=np.r_[np.full(TARE_FRAMES, self.projected[0] if n else False), self.projected],
            r_world_sensor=np.vstack(
                [np.repeat(self.rotation[:1] if n else np.eye(3)[None], TARE_FRAMES, axis=0), self.rotation]
            ),
        )


def mock_biotac_forward(params: BioTacParams | None = None) -> ForwardModel:
    """The mock world's BioTac model (grasp_ctrl.sim.biotac.model) as a forward callable:
    a fresh simulated sensor (own baselines and gains) per call, stepped at 100 Hz."""
    from grasp_ctrl.sim.biotac.model import DEFAULT_PARAMS, BioTacSensorModel

    def forward(p_sensor: np.ndarray, f_sensor: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        model = BioTacSensorModel(1, rng, params or DEFAULT_PARAMS)
        _, n_out = surface_point_and_normal(p_sensor)
        out = np.empty((len(p_sensor), 44))
        for i in range(len(p_sensor)):
            touching = np.array([np.linalg.norm(f_sensor[i]) > 0])
            out[i] = model.frames(
                p_sensor[i : i + 1], f_sensor[i : i + 1], n_out[i : i + 1], touching, np.zeros(1), 1.0 / RATE_HZ
            )[0]
        return out

    return forward


def _sensor_trial(
    forward: ForwardModel, p: np.ndarray, f: np.ndarray, rng: np.random.Generator, rule: GateRule
) -> tuple[np.ndarray, np.ndarray]:
    """Raw frames for a trial after a no-contact tare window; (raw (TARE_FRAMES + n, 44), gate (n,))."""
    p_all = np.vstack([np.repeat(p[:1], TARE_FRAMES, axis=0), p])
    f_all = np.vstack([np.zeros((TARE_FRAMES, 3)), f])
    raw = np.asarray(forward(p_all, f_all, rng), dtype=float)
    tared = raw - raw[:TARE_FRAMES].mean(axis=0)
    tared = tared[TARE_FRAMES:]
    return raw, contact_gate(tared[:, PDC], rule)


def _pad_point(rng: np.random.Generator, x_range: tuple[float, float], max_angle_rad: float) -> np.ndarray:
    """A point on the cylinder part, at an angle from the pad centre (-z)."""
    a = rng.uniform(-max_angle_rad, max_angle_rad)
    x = rng.uniform(*x_range)
    return np.array([x, SURFACE_RADIUS_M * np.sin(a), -SURFACE_RADIUS_M * np.cos(a)])


def _any_point(rng: np.random.Generator) -> np.ndarray:
    """Anywhere a ball can touch: the sides and the pad of the cylinder, or the tip cap."""
    if rng.uniform() < 0.25:
        d = rng.standard_normal(3)
        d[0] = abs(d[0])
        d[2] = -abs(d[2])  # the lower half of the cap
        return SURFACE_RADIUS_M * d / np.linalg.norm(d)
    return _pad_point(rng, (-0.014, 0.0), np.deg2rad(100))


def _tangent_basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = np.cross(n, a)
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(n, t1)


def _press_profile(rng: np.random.Generator, peak: float) -> np.ndarray:
    """A press: ramp up, hold with wobble, release; 0.6-1.5 s at 100 Hz."""
    n = int(rng.uniform(0.6, 1.5) * RATE_HZ)
    u = np.linspace(0, 1, n)
    shape = np.sin(np.pi * u) ** rng.uniform(0.5, 1.5)
    wobble = 1 + 0.1 * np.sin(2 * np.pi * rng.uniform(0.5, 2.0) * u * n / RATE_HZ + rng.uniform(0, 6.3))
    return peak * shape * wobble


def _random_rotation(rng: np.random.Generator, sigma_rad: float) -> np.ndarray:
    w = sigma_rad * rng.standard_normal(3)
    th = np.linalg.norm(w)
    if th < 1e-12:
        return np.eye(3)
    k = w / th
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * kx + (1 - np.cos(th)) * kx @ kx


#: Share of the ball-ft trials that press at a recorded grasp contact (when contacts are given).
GRASP_SHARE = 0.5


def _ft_trial(
    forward: ForwardModel,
    rng: np.random.Generator,
    source: str,
    rule: GateRule,
    contacts: GraspContacts | None = None,
):
    mags_peak = rng.uniform(1.0, 12.0) if source == "rigid-ft" else rng.uniform(0.5, 8.0)
    mags = _press_profile(rng, mags_peak)
    n = len(mags)
    if source == "ball-ft" and contacts is not None and rng.uniform() < GRASP_SHARE:
        return _grasp_contact_trial(forward, rng, rule, contacts, mags)
    if source == "rigid-ft":
        # a human presses objects on the pad: the contact wanders a little, mostly normal force
        ends = [_pad_point(rng, (-0.012, 0.002), np.deg2rad(35)) for _ in range(2)]
        tangential = rng.uniform(0.0, 0.2)
        label_rotation = np.eye(3)  # the mount is rigid and known
    else:
        # the hand rolls the fingertip over the ball: contacts all over the sensor
        p0 = _any_point(rng)
        ends = [p0, p0 + rng.normal(0.0, 2.5e-3, 3)]
        tangential = rng.uniform(0.0, 0.8)
        label_rotation = _random_rotation(rng, np.deg2rad(3.0))  # tracked sensor orientation error
    u = np.linspace(0.0, 1.0, n)[:, None]
    points, n_out = surface_point_and_normal((1 - u) * ends[0] + u * ends[1])
    t1, t2 = zip(*(_tangent_basis(v) for v in n_out))
    t1, t2 = np.array(t1), np.array(t2)
    phase = rng.uniform(0, 2 * np.pi) + np.linspace(0, rng.uniform(-1.5, 1.5), n)
    direction = -n_out + tangential * (np.cos(phase)[:, None] * t1 + np.sin(phase)[:, None] * t2)
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    f_true = mags[:, None] * direction
    raw, gate = _sensor_trial(forward, points, f_true, rng, rule)
    sigma = rng.uniform(0.01, 0.1)
    label = f_true @ label_rotation.T + sigma * rng.standard_normal(f_true.shape)
    return (
        raw,
        label,
        gate & (np.linalg.norm(label, axis=1) > 0),
        np.zeros(n, bool),
        np.repeat(np.eye(3)[None], n, axis=0),
    )


def _grasp_contact_trial(
    forward: ForwardModel, rng: np.random.Generator, rule: GateRule, contacts: GraspContacts, mags: np.ndarray
):
    """A ball-ft press at a recorded grasp contact: the contact point wanders up to a
    millimetre or so, the force keeps the recorded direction (tilted by up to a few degrees),
    for half of them with the shear reversed (``sim/presses.reverse_shear``)."""
    n = len(mags)
    k = int(contacts.sample(1, rng)[0])
    p0 = contacts.p_sensor[k]
    ends = [p0, p0 + rng.normal(0.0, 1.0e-3, 3)]
    u = np.linspace(0.0, 1.0, n)[:, None]
    points, _ = surface_point_and_normal((1 - u) * ends[0] + u * ends[1])
    f_rec = reverse_shear(contacts.f_sensor[k : k + 1], contacts.n_sensor[k : k + 1], rng.uniform(size=1) < 0.5)[0]
    f_dir = _random_rotation(rng, np.deg2rad(3.0)) @ (f_rec / np.linalg.norm(f_rec))
    f_true = mags[:, None] * f_dir[None, :]
    raw, gate = _sensor_trial(forward, points, f_true, rng, rule)
    label_rotation = _random_rotation(rng, np.deg2rad(3.0))  # tracked sensor orientation error
    sigma = rng.uniform(0.01, 0.1)
    label = f_true @ label_rotation.T + sigma * rng.standard_normal(f_true.shape)
    return (
        raw,
        label,
        gate & (np.linalg.norm(label, axis=1) > 0),
        np.zeros(n, bool),
        np.repeat(np.eye(3)[None], n, axis=0),
    )


def _rotation_aligning(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A rotation R with R a = b (unit vectors)."""
    v = np.cross(a, b)
    c = float(a @ b)
    if np.linalg.norm(v) < 1e-9:
        if c > 0:
            return np.eye(3)
        t1, _ = _tangent_basis(a)
        return 2 * np.outer(t1, t1) - np.eye(3)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1 + c)


def _axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    k = axis / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def _push_trial(forward: ForwardModel, rng: np.random.Generator, rule: GateRule):
    push = simulate_push(rng, PAPER_BOX)
    seen = push.tracked(rng, 3e-4, 3e-3)
    motion = planar_motion(seen.t, seen.x, seen.y, seen.theta)
    est = pusher_forces(motion, seen.contact_object, seen.in_contact, PAPER_BOX)
    # fingertip orientation: its outward normal at the contact points into the pushed face
    point = _pad_point(rng, (-0.012, 0.003), np.deg2rad(60))
    _, n_out = surface_point_and_normal(point[None])
    mid = len(push.t) // 2
    face_in_world = np.array([np.cos(push.theta[mid]), np.sin(push.theta[mid]), 0.0])
    r_ws = _axis_rotation(face_in_world, rng.uniform(-np.pi, np.pi)) @ _rotation_aligning(n_out[0], face_in_world)
    # truth on the skin: reaction of the pusher force plus an unmodelled vertical part
    f_world3 = np.zeros((len(push.t), 3))
    f_world3[:, :2] = -push.f_world_true
    f_world3[:, 2] = rng.uniform(-0.3, 0.3) * np.linalg.norm(push.f_world_true, axis=1)
    f_true = f_world3 @ r_ws  # R^T f, row-wise
    p = np.repeat(point[None], len(push.t), axis=0)
    raw, gate = _sensor_trial(forward, p, f_true, rng, rule)
    solved = ~np.isnan(est.f_world[:, 0])
    label = np.full((len(push.t), 3), np.nan)
    label[solved] = plane_force_to_sensor(est.f_world[solved], r_ws)
    keep = gate & solved & (np.linalg.norm(np.nan_to_num(label), axis=1) > 0)
    return raw, label, keep, np.ones(len(push.t), bool), np.repeat(r_ws[None], len(push.t), axis=0)


def simulate_trials(
    source: str,
    n_samples: int,
    forward: ForwardModel,
    rng: np.random.Generator,
    rule: GateRule = GateRule(),
    trial_prefix: str = "",
    contacts: GraspContacts | None = None,
) -> list[SimTrial]:
    """Trials of one source until at least ``n_samples`` force samples are collected (trials
    without any force sample included: their stream is still recorded). ``contacts``: recorded
    grasp contacts for the ball-ft source (module doc)."""
    if source not in SOURCES:
        raise ValueError(f"source must be one of {', '.join(SOURCES)}")
    trials: list[SimTrial] = []
    count = 0
    k = 0
    while count < n_samples:
        if source == "planar-pushing":
            raw, label, keep, proj, rot = _push_trial(forward, rng, rule)
        else:
            raw, label, keep, proj, rot = _ft_trial(forward, rng, source, rule, contacts)
        trials.append(SimTrial(f"{trial_prefix}{source}-{k:04d}", source, raw, label, keep, proj, rot))
        count += int(keep.sum())
        k += 1
    return trials


def generate_source(
    source: str,
    n_samples: int,
    forward: ForwardModel,
    rng: np.random.Generator,
    rule: GateRule = GateRule(),
    trial_prefix: str = "",
) -> Dataset:
    """Force samples of one source, at least ``n_samples``."""
    trials = simulate_trials(source, n_samples, forward, rng, rule, trial_prefix)
    return Dataset.concat([tr.dataset() for tr in trials if tr.keep.any()])


def generate_trials(
    n_per_source: int,
    seed: int = 0,
    forward: ForwardModel | None = None,
    sources: tuple[str, ...] = SOURCES,
    contacts: GraspContacts | None = None,
) -> list[SimTrial]:
    """The trials behind ``generate`` (same seed, same draws), with their whole raw streams."""
    rng = np.random.default_rng(seed)
    fwd = forward or mock_biotac_forward()
    return [tr for s in sources for tr in simulate_trials(s, n_per_source, fwd, rng, contacts=contacts)]


def generate(
    n_per_source: int,
    seed: int = 0,
    forward: ForwardModel | None = None,
    sources: tuple[str, ...] = SOURCES,
    contacts: GraspContacts | None = None,
) -> Dataset:
    trials = generate_trials(n_per_source, seed, forward, sources, contacts)
    return Dataset.concat([tr.dataset() for tr in trials if tr.keep.any()])
