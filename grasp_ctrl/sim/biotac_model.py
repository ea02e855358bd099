"""A BioTac forward model: contact (location, force on the skin) -> raw frame.

Calibrated in shape and magnitude against the real recordings in
``shared/data/robotic_finger`` (baselines 3000-3500 counts, electrode drops up
to ~2000 counts, pdc rises of 40-500 counts):

- electrodes near the contact DROP with normal load (Gaussian footprint of
  width ``footprint_m``) and shift asymmetrically with shear (the leading side
  of the drag drops more); drops saturate at ``e_drop_max`` counts;
- pdc RISES with the force magnitude, saturating;
- pac carries a decaying burst at contact onset and during slip (its noise
  widens);
- tdc drifts slowly, tac is noise around its baseline;
- every channel has Gaussian noise; each simulated sensor has its own
  baselines and a gain spread, drawn from the seed.

All parameters live in ``BioTacParams``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grasp_ctrl.jit import njit
from grasp_ctrl.tactile.geometry import ELECTRODE_POSITIONS_SENSOR
from grasp_ctrl.tactile.layout import COUNT_MAX, ELECTRODES, FRAME_LEN, PAC, PDC, TAC, TDC

PAC_START = PAC.start


@dataclass(frozen=True)
class BioTacParams:
    e_baseline_range: tuple[float, float] = (3000.0, 3500.0)
    pdc_baseline_range: tuple[float, float] = (1900.0, 2500.0)
    pac_baseline: float = 2048.0
    tdc_baseline_range: tuple[float, float] = (2300.0, 2700.0)
    tac_baseline: float = 2000.0
    e_gain_normal: float = 320.0      # counts/N at the electrode under the contact
    e_gain_shear: float = 160.0       # counts/N at one footprint width from the contact
    e_drop_max: float = 2000.0        # saturation of electrode drops
    footprint_m: float = 4.5e-3       # Gaussian width of the pressed region
    pdc_gain: float = 70.0            # counts/N of force magnitude
    pdc_max_rise: float = 1500.0
    pac_onset_amp: float = 300.0
    pac_slip_amp: float = 150.0       # per m/s of slip speed, capped below
    pac_decay_s: float = 0.03
    tdc_drift_per_s: float = 0.2
    noise_e: float = 3.0
    noise_pdc: float = 1.5
    noise_pac: float = 6.0
    noise_t: float = 1.0
    gain_spread: float = 0.1          # relative std of per-sensor gains


DEFAULT_PARAMS = BioTacParams()


class BioTacSensorModel:
    """State of n simulated fingertip sensors (baselines, burst timers, drift).

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
        self.gain = 1.0 + p.gain_spread * rng.standard_normal(n_tips).clip(-2.5, 2.5)
        self.burst = np.zeros(n_tips)
        self.was_in_contact = np.zeros(n_tips, dtype=bool)
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
        self.consts = _pack(p)

    def advance(self, dt: float) -> np.ndarray:
        """Step the clock by ``dt``; this frame's noisy baselines (n, 44), which the
        frame is built on in place (a new block of noise when one is spent)."""
        self.t += dt
        if self._next >= len(self._noisy_base):
            noise = self._noise_std * self.rng.standard_normal((self.noise_block, self.n, FRAME_LEN))
            self._noisy_base = noise + self.baseline
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
            self.advance(dt), np.ascontiguousarray(p_contact_sensor, dtype=float), np.ascontiguousarray(f_sensor, dtype=float),
            np.ascontiguousarray(n_out_sensor, dtype=float), np.ascontiguousarray(in_contact, dtype=np.bool_),
            np.ascontiguousarray(slip_speed_m_s, dtype=float), self.burst, self.was_in_contact, self.gain,
            self.consts, self.t, dt,
        )


# Constants of frames_kernel, packed for the compiled kernel.
(E_DROP_MAX, PDC_GAIN, PDC_MAX_RISE, PAC_ONSET, PAC_SLIP, PAC_DECAY_S, TDC_DRIFT,
 E_GAIN_NORMAL, E_GAIN_SHEAR, FOOTPRINT, PAC_BASELINE, NOISE_PAC) = range(12)
_ELECTRODES_XYZ = np.ascontiguousarray(ELECTRODE_POSITIONS_SENSOR, dtype=float)


def _pack(p: BioTacParams) -> np.ndarray:
    return np.array([p.e_drop_max, p.pdc_gain, p.pdc_max_rise, p.pac_onset_amp, p.pac_slip_amp,
                     p.pac_decay_s, p.tdc_drift_per_s, p.e_gain_normal, p.e_gain_shear, p.footprint_m,
                     p.pac_baseline, p.noise_pac])


@njit
def _electrode_map(p: np.ndarray, n_out: np.ndarray, gain: float, c: np.ndarray, maps: np.ndarray) -> None:
    """maps (4, 19) of one contact at ``p`` (sensor frame, outward normal ``n_out``):
    drop = w * (g_n * f_normal + g_s * d.f_tangent / footprint), with w the Gaussian
    footprint at electrode offset d and f_tangent = f + f_normal * n, which is
    linear in (f_normal, f)."""
    width = c[FOOTPRINT]
    for e in range(19):
        dx = _ELECTRODES_XYZ[e, 0] - p[0]
        dy = _ELECTRODES_XYZ[e, 1] - p[1]
        dz = _ELECTRODES_XYZ[e, 2] - p[2]
        w = math.exp(-(dx * dx + dy * dy + dz * dz) / (2.0 * width * width))
        shear = gain * w * c[E_GAIN_SHEAR] / width
        maps[0, e] = gain * w * c[E_GAIN_NORMAL] + shear * (dx * n_out[0] + dy * n_out[1] + dz * n_out[2])
        maps[1, e] = shear * dx
        maps[2, e] = shear * dy
        maps[3, e] = shear * dz


@njit
def _electrode_drops(maps: np.ndarray, f: np.ndarray, n_out: np.ndarray, e_max: float, out: np.ndarray) -> None:
    """Electrode changes (19,) of one contact: [f_normal, f] @ maps, saturating, and
    only drops (the fluid under a pressed pad cannot pull an electrode up much)."""
    f_normal = max(-(f[0] * n_out[0] + f[1] * n_out[1] + f[2] * n_out[2]), 0.0)
    for e in range(19):
        drop = f_normal * maps[0, e] + f[0] * maps[1, e] + f[1] * maps[2, e] + f[2] * maps[3, e]
        out[e] = -e_max * math.tanh(max(drop, -0.1 * e_max) / e_max)


@njit
def frames_kernel(
    out: np.ndarray, p_contact: np.ndarray, f_sensor: np.ndarray, n_out: np.ndarray,
    in_contact: np.ndarray, slip: np.ndarray, burst: np.ndarray, was_in_contact: np.ndarray,
    gain: np.ndarray, c: np.ndarray, t: float, dt: float,
) -> np.ndarray:
    """One frame per sensor (n, 44 counts) from its noisy baseline ``out`` (modified
    in place); updates the pac burst state. Also called from the world's step."""
    n = out.shape[0]
    drops = np.empty(19)
    maps = np.empty((4, 19))
    decay = math.exp(-dt / c[PAC_DECAY_S])
    frame = np.empty((n, FRAME_LEN), dtype=np.int64)
    for i in range(n):
        if in_contact[i]:
            _electrode_map(p_contact[i], n_out[i], gain[i], c, maps)
            _electrode_drops(maps, f_sensor[i], n_out[i], c[E_DROP_MAX], drops)
            for e in range(19):
                out[i, e] += drops[e]
            f = f_sensor[i]
            f_mag = math.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) * gain[i]
            out[i, PDC] += c[PDC_MAX_RISE] * math.tanh(c[PDC_GAIN] * f_mag / c[PDC_MAX_RISE])
        # pac: a decaying burst at contact onset plus noise growing with slip speed,
        # which widen its noise (standard deviation sqrt(noise^2 + amp^2)).
        burst[i] = burst[i] * decay + (c[PAC_ONSET] if in_contact[i] and not was_in_contact[i] else 0.0)
        was_in_contact[i] = in_contact[i]
        amp = burst[i] + min(c[PAC_SLIP] * abs(slip[i]) * 100.0, 500.0)
        if amp > 1e-3:
            widen = math.sqrt(c[NOISE_PAC] ** 2 + amp * amp) / c[NOISE_PAC]
            for k in range(22):
                out[i, PAC_START + k] = c[PAC_BASELINE] + (out[i, PAC_START + k] - c[PAC_BASELINE]) * widen
        out[i, TDC] += c[TDC_DRIFT] * t
        for k in range(FRAME_LEN):
            v = np.rint(out[i, k])      # half to even, like numpy elsewhere
            frame[i, k] = 0 if v < 0.0 else (COUNT_MAX if v > COUNT_MAX else int(v))
    return frame
