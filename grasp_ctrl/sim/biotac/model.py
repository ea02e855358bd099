"""A BioTac forward model: contact (location, force on the skin) -> raw frame.

Physically shaped (a fluid layer between a rigid core and an elastic skin) and
anchored to real data; every parameter, its value and its evidence is in
``docs/mock_world.md`` ("The BioTac forward model"). Per contact, with ``F_n``
the normal load and ``f_t`` the tangential force on the skin:

- pdc (fluid pressure) RISES nonlinearly with the load, ``F_n + k_t |f_t|``,
  saturating; part of the rise is slow (hysteresis) and outlives the release,
  leaving a pdc offset that decays over tens of seconds;
- electrodes under the contact DROP (the skin squeezes the fluid away): a
  footprint that widens with the load (Hertz-like contact radius), with a peak
  that grows sub-linearly with the load and saturates;
- the displaced fluid inflates the free skin: electrodes away from the contact
  RISE with pdc (saturating), more on the upper sides where the skin is free;
- shear drags the skin and the fluid under it: electrodes ahead of the contact
  along the tangential force rise, those behind drop, over a range three
  footprints wide. This is what distinguishes shear from a moved contact, whose
  pattern is only a shifted footprint. Two smaller terms load the electrodes
  whose normal points along the force and skew the footprint itself;
- pac: a decaying burst at contact onset and noise growing with slip speed;
- tdc drifts slowly (warm-up) and drags the electrode and pdc baselines;
- each simulated sensor has its own baselines, an overall gain and
  per-electrode gains; noise levels are those measured at rest on a real sensor.

All parameters live in ``BioTacParams``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grasp_ctrl.config.sensor_layout import COUNT_MAX, ELECTRODES, FRAME_LEN, PAC, PDC, TAC, TDC
from grasp_ctrl.numeric.jit import njit
from grasp_ctrl.tactile.geometry import ELECTRODE_NORMALS_SENSOR, ELECTRODE_POSITIONS_SENSOR

PAC_START = PAC.start


@dataclass(frozen=True)
class BioTacParams:
    """Every parameter of the forward model (counts, N, m, s). Evidence: docs/mock_world.md."""

    # baselines (counts), per simulated sensor
    e_baseline_range: tuple[float, float] = (3000.0, 3500.0)
    pdc_baseline_range: tuple[float, float] = (1900.0, 2500.0)
    pac_baseline: float = 2048.0
    tdc_baseline_range: tuple[float, float] = (2300.0, 2700.0)
    tac_baseline: float = 2000.0
    # pdc: rise = pdc_max_rise * tanh(pdc_gain * load^pdc_exponent / pdc_max_rise)
    pdc_gain: float = 257.0  # counts per N^pdc_exponent
    pdc_exponent: float = 1.1
    pdc_max_rise: float = 3000.0
    shear_load: float = 0.0  # tangential force's share of the load that pressurises the fluid
    # local drop under the contact: peak = e_drop_gain * F_n^e_drop_exponent, saturating
    e_drop_gain: float = 600.0  # counts per N^e_drop_exponent
    e_drop_exponent: float = 0.871
    e_drop_max: float = 1200.0
    footprint_m: float = 2.58e-3  # footprint width of a light touch
    contact_radius_m_per_n3: float = 0.99e-3  # Hertz-like contact radius at 1 N (grows as F^1/3)
    tip_sensitivity: float = 0.7  # local drop factor on the tip cap (x > 0)
    side_sensitivity: float = 1.41  # local drop factor on the sides of the cylinder
    # bulge of the free skin: rise = bulge_per_pdc * pdc_rise * side weight * distance weight
    bulge_per_pdc: float = 0.2
    bulge_side_weight: float = 2.52  # upper-side electrodes (|n_y| ~ 1) rise this much more than pad ones
    bulge_distance_m: float = 4.0e-3  # the bulge grows over this distance from the contact
    bulge_max: float = 67.0  # the skin stiffens as it inflates: rises saturate (counts)
    # per-electrode rise weights (19, e1..e19) replacing the side weight; None = the side weight
    rise_weights: tuple[float, ...] | None = None
    # shear: global skin stretch (counts per N) fading over shear_range_m, and a local footprint skew
    e_shear_global: float = 15.3
    shear_range_m: float = 6.0e-3
    e_shear_local: float = 34.6  # counts per N at one footprint width
    # shear: fluid dragged along with the skin piles up ahead of the contact and thins behind it
    e_shear_drag: float = 100.0  # counts per N at one drag range ahead of the contact
    drag_range_m: float = 8.0e-3
    # hysteresis: a slow share of the load (time constants up / down), left over after release
    hysteresis_share: float = 0.02
    hysteresis_up_s: float = 0.5
    hysteresis_down_s: float = 30.0
    # pac
    pac_onset_amp: float = 300.0
    pac_slip_amp: float = 150.0  # per m/s of slip speed, capped below
    pac_decay_s: float = 0.03
    # temperature: tdc warms up, baselines follow it
    tdc_drift_per_s: float = 0.2
    pdc_per_tdc: float = 0.05
    e_per_tdc: float = -0.02
    # noise at rest (counts, sd) and spreads between sensors / electrodes
    noise_e: float = 0.36  # with the rounding to counts: 0.46 sd, as measured at rest
    noise_pdc: float = 0.36
    noise_pac: float = 6.0
    noise_t: float = 1.0
    gain_spread: float = 0.1  # relative sd of a sensor's overall gain
    electrode_gain_spread: float = 0.05  # relative sd of each electrode's gain


DEFAULT_PARAMS = BioTacParams()

# Per-sensor state columns (BioTacSensorModel.state).
ST_BURST, ST_SLOW_LOAD, ST_WAS_IN_CONTACT = range(3)
N_STATE = 3
# Per-sensor gain columns (BioTacSensorModel.gain): 19 electrodes, then pdc.
GAIN_PDC = 19
N_GAIN = 20


class BioTacSensorModel:
    """State of n simulated fingertip sensors (baselines, gains, burst, hysteresis, drift).

    ``noise_block``: random draws are made for this many frames at a time (the
    mock world uses a block of frames; one-off callers keep 1). Frames are
    deterministic from the generator either way.
    """

    def __init__(
        self, n_tips: int, rng: np.random.Generator, params: BioTacParams = DEFAULT_PARAMS, noise_block: int = 1
    ) -> None:
        p = params
        self.p = p
        self.n = n_tips
        self.rng = rng
        base = np.empty((n_tips, FRAME_LEN))
        base[:, ELECTRODES] = rng.uniform(*p.e_baseline_range, size=(n_tips, 19))
        base[:, PDC] = rng.uniform(*p.pdc_baseline_range, size=n_tips)
        base[:, PAC] = p.pac_baseline
        base[:, TDC] = rng.uniform(*p.tdc_baseline_range, size=n_tips)
        base[:, TAC] = p.tac_baseline
        self.baseline = base
        overall = 1.0 + p.gain_spread * rng.standard_normal(n_tips).clip(-2.5, 2.5)
        each = 1.0 + p.electrode_gain_spread * rng.standard_normal((n_tips, N_GAIN)).clip(-2.5, 2.5)
        self.gain = np.ascontiguousarray(overall[:, None] * each)
        self.state = np.zeros((n_tips, N_STATE))
        self.t = 0.0
        std = np.empty(FRAME_LEN)
        std[ELECTRODES] = p.noise_e
        std[PDC] = p.noise_pdc
        std[PAC] = p.noise_pac
        std[TDC] = p.noise_t
        std[TAC] = p.noise_t
        self._noise_std = std
        self.noise_block = max(1, int(noise_block))
        self._noisy_base = np.empty((0, n_tips, FRAME_LEN))
        self._next = 0
        self.consts = pack_params(p)

    def advance(self, dt: float) -> np.ndarray:
        """Step the clock by ``dt``; this frame's noisy baselines (n, 44), which the
        frame is built on in place (a new block of noise when one is spent)."""
        self.t += dt
        if self._next >= len(self._noisy_base):
            # In place, the same numbers as noise_std * standard_normal(...) + baseline; the
            # block's rows are handed out once each, so a new block can reuse the buffer.
            block = self._noisy_base
            if block.shape != (self.noise_block, self.n, FRAME_LEN):
                block = np.empty((self.noise_block, self.n, FRAME_LEN))
            self.rng.standard_normal(out=block)
            block *= self._noise_std
            block += self.baseline
            self._noisy_base = block
            self._next = 0
        i = self._next
        self._next += 1
        return self._noisy_base[i]

    def frames(
        self,
        p_contact_sensor: np.ndarray,
        f_sensor: np.ndarray,
        n_out_sensor: np.ndarray,
        in_contact: np.ndarray,
        slip_speed_m_s: np.ndarray,
        dt: float,
    ) -> np.ndarray:
        """Advance by ``dt`` and return (n, 44) raw frames as integer counts."""
        return frames_kernel(
            self.advance(dt),
            np.ascontiguousarray(p_contact_sensor, dtype=float),
            np.ascontiguousarray(f_sensor, dtype=float),
            np.ascontiguousarray(n_out_sensor, dtype=float),
            np.ascontiguousarray(in_contact, dtype=np.bool_),
            np.ascontiguousarray(slip_speed_m_s, dtype=float),
            self.state,
            self.gain,
            self.consts,
            self.t,
            dt,
        )


# Constants of the kernels, packed in this order for the compiled code.
_PACKED = (
    "pdc_gain",
    "pdc_exponent",
    "pdc_max_rise",
    "shear_load",
    "e_drop_gain",
    "e_drop_exponent",
    "e_drop_max",
    "footprint_m",
    "contact_radius_m_per_n3",
    "tip_sensitivity",
    "side_sensitivity",
    "bulge_per_pdc",
    "bulge_side_weight",
    "bulge_distance_m",
    "bulge_max",
    "e_shear_global",
    "shear_range_m",
    "e_shear_local",
    "e_shear_drag",
    "drag_range_m",
    "hysteresis_share",
    "hysteresis_up_s",
    "hysteresis_down_s",
    "pac_onset_amp",
    "pac_slip_amp",
    "pac_decay_s",
    "tdc_drift_per_s",
    "pdc_per_tdc",
    "e_per_tdc",
    "pac_baseline",
    "noise_pac",
)
(
    PDC_GAIN,
    PDC_EXP,
    PDC_MAX,
    SHEAR_LOAD,
    DROP_GAIN,
    DROP_EXP,
    DROP_MAX,
    FOOTPRINT,
    RADIUS_1N,
    TIP_SENS,
    SIDE_SENS,
    BULGE,
    BULGE_SIDE,
    BULGE_DIST,
    BULGE_MAX,
    SHEAR_GLOBAL,
    SHEAR_RANGE,
    SHEAR_LOCAL,
    SHEAR_DRAG,
    DRAG_RANGE,
    HYST_SHARE,
    HYST_UP,
    HYST_DOWN,
    PAC_ONSET,
    PAC_SLIP,
    PAC_DECAY_S,
    TDC_DRIFT,
    PDC_PER_TDC,
    E_PER_TDC,
    PAC_BASELINE,
    NOISE_PAC,
) = range(len(_PACKED))

_ELECTRODES_XYZ = np.ascontiguousarray(ELECTRODE_POSITIONS_SENSOR, dtype=float)
_ELECTRODES_NORMAL = np.ascontiguousarray(ELECTRODE_NORMALS_SENSOR, dtype=float)


# After the scalars: each electrode's weight of the free-skin rise.
RISE_WEIGHT0 = len(_PACKED)


def rise_weights_of(p: BioTacParams) -> np.ndarray:
    """Each electrode's weight of the free-skin rise: the given ``rise_weights``, or
    the side weight (upper-side electrodes, abs(n_y) ~ 1, rise ``bulge_side_weight`` times more)."""
    if p.rise_weights is None:
        ny = _ELECTRODES_NORMAL[:, 1]
        return 1.0 + (p.bulge_side_weight - 1.0) * ny * ny
    weights = np.asarray(p.rise_weights, dtype=float)
    if weights.shape != (19,) or not np.all(np.isfinite(weights)) or np.any(weights < 0.0):
        raise ValueError("rise_weights: need 19 finite values >= 0 (e1..e19)")
    return weights


def pack_params(p: BioTacParams) -> np.ndarray:
    return np.concatenate([[float(getattr(p, name)) for name in _PACKED], rise_weights_of(p)])


@njit
def pdc_rise_of(load_n: float, c: np.ndarray) -> float:
    """pdc rise (counts, unit gain) of a load (N): a saturating power law."""
    if load_n <= 0.0:
        return 0.0
    return c[PDC_MAX] * math.tanh(c[PDC_GAIN] * load_n ** c[PDC_EXP] / c[PDC_MAX])


@njit
def split_force(f: np.ndarray, n_out: np.ndarray) -> tuple[float, float, float, float]:
    """The pressing part ``F_n`` (N, >= 0) of the force ``f`` on the skin and its
    tangential part (x, y, z) at a contact with outward skin normal ``n_out``."""
    f_n = max(-(f[0] * n_out[0] + f[1] * n_out[1] + f[2] * n_out[2]), 0.0)
    return f_n, f[0] + f_n * n_out[0], f[1] + f_n * n_out[1], f[2] + f_n * n_out[2]


@njit
def contact_load(f: np.ndarray, n_out: np.ndarray, c: np.ndarray) -> float:
    """The load that pressurises the fluid (N): ``F_n + shear_load |f_t|``."""
    f_n, ft0, ft1, ft2 = split_force(f, n_out)
    return f_n + c[SHEAR_LOAD] * math.sqrt(ft0 * ft0 + ft1 * ft1 + ft2 * ft2)


@njit
def contact_response(
    p: np.ndarray,
    n_out: np.ndarray,
    f: np.ndarray,
    slow_load: float,
    gain: np.ndarray,
    c: np.ndarray,
    e_out: np.ndarray,
) -> float:
    """Electrode changes ``e_out`` (19, counts) and the pdc rise (returned) of one
    contact at ``p`` (sensor frame, outward skin normal ``n_out``) under the force
    ``f`` on the skin, with ``slow_load`` the hysteretic part of the load (N)."""
    f_n, ft0, ft1, ft2 = split_force(f, n_out)
    load = f_n + c[SHEAR_LOAD] * math.sqrt(ft0 * ft0 + ft1 * ft1 + ft2 * ft2)
    share = c[HYST_SHARE]
    pdc = pdc_rise_of((1.0 - share) * load + share * slow_load, c) * gain[GAIN_PDC]
    # footprint widens with the contact radius (Hertz: a ~ F^1/3)
    a = c[RADIUS_1N] * f_n ** (1.0 / 3.0)
    width2 = c[FOOTPRINT] * c[FOOTPRINT] + a * a
    width = math.sqrt(width2)
    region = c[TIP_SENS] if p[0] > 0.0 else 1.0 + (c[SIDE_SENS] - 1.0) * min(abs(n_out[1]) / 0.87, 1.0)
    peak = c[DROP_GAIN] * region * f_n ** c[DROP_EXP]
    bulge_d2 = c[BULGE_DIST] * c[BULGE_DIST]
    inflation = c[BULGE_MAX] * math.tanh(c[BULGE] * pdc / c[BULGE_MAX])
    range2 = c[SHEAR_RANGE] * c[SHEAR_RANGE]
    drag_range = c[DRAG_RANGE]
    for e in range(19):
        dx = _ELECTRODES_XYZ[e, 0] - p[0]
        dy = _ELECTRODES_XYZ[e, 1] - p[1]
        dz = _ELECTRODES_XYZ[e, 2] - p[2]
        d2 = dx * dx + dy * dy + dz * dz
        w = math.exp(-d2 / (2.0 * width2))
        along = dx * ft0 + dy * ft1 + dz * ft2  # how far ahead of the contact, along f_t
        # local drop (skewed toward where the tangential force drags the skin)
        skew = c[SHEAR_LOCAL] * w * along / width
        drop = peak * w + skew
        # bulge of the free skin, away from the contact
        rise = inflation * c[RISE_WEIGHT0 + e] * (1.0 - math.exp(-d2 / (2.0 * bulge_d2))) * (1.0 - w)
        # skin stretch: electrodes facing along the tangential force are loaded
        facing = _ELECTRODES_NORMAL[e, 0] * ft0 + _ELECTRODES_NORMAL[e, 1] * ft1 + _ELECTRODES_NORMAL[e, 2] * ft2
        stretch = c[SHEAR_GLOBAL] * facing * math.exp(-d2 / (2.0 * range2))
        # fluid dragged along with the skin: more ahead of the contact (along f_t), less behind
        drag = c[SHEAR_DRAG] * along / drag_range * math.exp(-d2 / (2.0 * drag_range * drag_range))
        value = rise - drop - stretch + drag
        # the electrode reading cannot fall below the fluid-free floor: drops saturate
        if value < 0.0:
            value = -c[DROP_MAX] * math.tanh(-value / c[DROP_MAX])
        e_out[e] = value * gain[e]
    return pdc


@njit
def static_frames(p: np.ndarray, n_out: np.ndarray, f: np.ndarray, gain: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Noise-free tared responses (m, 20: 19 electrodes, pdc) of m steady contacts
    (no hysteresis lag: the slow load equals the load). For fitting and analysis."""
    m = p.shape[0]
    out = np.zeros((m, 20))
    e = np.empty(19)
    for i in range(m):
        fi = f[i]
        if fi[0] == 0.0 and fi[1] == 0.0 and fi[2] == 0.0:
            continue
        out[i, 19] = contact_response(p[i], n_out[i], fi, contact_load(fi, n_out[i], c), gain[i], c, e)
        for k in range(19):
            out[i, k] = e[k]
    return out


@njit
def frames_kernel(
    out: np.ndarray,
    p_contact: np.ndarray,
    f_sensor: np.ndarray,
    n_out: np.ndarray,
    in_contact: np.ndarray,
    slip: np.ndarray,
    state: np.ndarray,
    gain: np.ndarray,
    c: np.ndarray,
    t: float,
    dt: float,
) -> np.ndarray:
    """One frame per sensor (n, 44 counts) from its noisy baseline ``out`` (modified
    in place); updates the sensors' state (pac burst, slow load, contact flag).
    Also called from the world's step."""
    n = out.shape[0]
    e = np.empty(19)
    decay = math.exp(-dt / c[PAC_DECAY_S])
    up = 1.0 - math.exp(-dt / c[HYST_UP])
    down = 1.0 - math.exp(-dt / c[HYST_DOWN])
    tdc_rise = c[TDC_DRIFT] * t
    frame = np.empty((n, FRAME_LEN), dtype=np.int64)
    for i in range(n):
        f = f_sensor[i]
        nn = n_out[i]
        load = contact_load(f, nn, c) if in_contact[i] else 0.0
        slow = state[i, ST_SLOW_LOAD]
        slow += (load - slow) * (up if load > slow else down)
        state[i, ST_SLOW_LOAD] = slow
        if in_contact[i]:
            pdc = contact_response(p_contact[i], nn, f, slow, gain[i], c, e)
            for k in range(19):
                out[i, k] += e[k]
            out[i, PDC] += pdc
        else:
            # after release the slow share lingers: a pdc offset that decays
            out[i, PDC] += pdc_rise_of(c[HYST_SHARE] * slow, c) * gain[i, GAIN_PDC]
        # pac: a decaying burst at contact onset plus noise growing with slip speed,
        # which widen its noise (standard deviation sqrt(noise^2 + amp^2)).
        was = state[i, ST_WAS_IN_CONTACT] > 0.5
        state[i, ST_BURST] = state[i, ST_BURST] * decay + (c[PAC_ONSET] if in_contact[i] and not was else 0.0)
        state[i, ST_WAS_IN_CONTACT] = 1.0 if in_contact[i] else 0.0
        amp = state[i, ST_BURST] + min(c[PAC_SLIP] * abs(slip[i]) * 100.0, 500.0)
        if amp > 1e-3:
            widen = math.sqrt(c[NOISE_PAC] ** 2 + amp * amp) / c[NOISE_PAC]
            for k in range(22):
                out[i, PAC_START + k] = c[PAC_BASELINE] + (out[i, PAC_START + k] - c[PAC_BASELINE]) * widen
        # warm-up: tdc drifts and drags the pressure and electrode baselines
        out[i, TDC] += tdc_rise
        out[i, PDC] += c[PDC_PER_TDC] * tdc_rise
        for k in range(19):
            out[i, k] += c[E_PER_TDC] * tdc_rise
        for k in range(FRAME_LEN):
            v = np.rint(out[i, k])  # half to even, like numpy elsewhere
            frame[i, k] = 0 if v < 0.0 else (COUNT_MAX if v > COUNT_MAX else int(v))
    return frame


# ----- The MuJoCo world's per-tick reading (sim/mujoco/world.py) -----------------------------
