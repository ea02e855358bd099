"""A BioTac forward model: contact (location, force on the skin) -> raw frame.

Calibrated in shape and magnitude against the real recordings in
``shared/data/robotic_finger`` (baselines 3000-3500 counts, electrode drops up
to ~2000 counts, pdc rises of 40-500 counts):

- electrodes near the contact DROP with normal load (Gaussian footprint of
  width ``footprint_m``) and shift asymmetrically with shear (the leading side
  of the drag drops more); drops saturate at ``e_drop_max`` counts;
- pdc RISES with the force magnitude, saturating;
- pac carries a decaying burst at contact onset and during slip;
- tdc drifts slowly, tac is noise around its baseline;
- every channel has Gaussian noise; each simulated sensor has its own
  baselines and a gain spread, drawn from the seed.

All parameters live in ``BioTacParams``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasp_ctrl.tactile.geometry import ELECTRODE_POSITIONS_SENSOR
from grasp_ctrl.tactile.layout import COUNT_MAX, ELECTRODES, FRAME_LEN, PAC, PDC, TAC, TDC


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
    """State of n simulated fingertip sensors (baselines, burst timers, drift)."""

    def __init__(self, n_tips: int, rng: np.random.Generator, params: BioTacParams = DEFAULT_PARAMS) -> None:
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

    def tared_electrodes(self, p_contact_sensor: np.ndarray, f_sensor: np.ndarray, n_out_sensor: np.ndarray) -> np.ndarray:
        """Noise-free electrode changes (n, 19) for contacts at ``p_contact_sensor``
        with force ``f_sensor`` on the skin and outward surface normal ``n_out_sensor``."""
        p = self.p
        d = ELECTRODE_POSITIONS_SENSOR[None, :, :] - p_contact_sensor[:, None, :]       # (n, 19, 3)
        w = np.exp(-np.einsum("nij,nij->ni", d, d) / (2.0 * p.footprint_m**2))        # (n, 19)
        f_normal = np.maximum(-np.einsum("ni,ni->n", f_sensor, n_out_sensor), 0.0)     # pressing in
        f_tangent = f_sensor + f_normal[:, None] * n_out_sensor
        shear = np.einsum("nij,nj->ni", d, f_tangent) / p.footprint_m                  # (n, 19)
        drop = w * (p.e_gain_normal * f_normal[:, None] + p.e_gain_shear * shear)
        drop *= self.gain[:, None]
        # Saturating, and only drops: the fluid under a pressed pad cannot pull an electrode up much.
        return -p.e_drop_max * np.tanh(np.maximum(drop, -0.1 * p.e_drop_max) / p.e_drop_max)

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
        p = self.p
        rng = self.rng
        self.t += dt
        out = self.baseline.copy()
        f_sensor = np.where(in_contact[:, None], f_sensor, 0.0)
        out[:, ELECTRODES] += self.tared_electrodes(p_contact_sensor, f_sensor, n_out_sensor)
        f_mag = np.linalg.norm(f_sensor, axis=1) * self.gain
        out[:, PDC] += p.pdc_max_rise * np.tanh(p.pdc_gain * f_mag / p.pdc_max_rise)

        onset = in_contact & ~self.was_in_contact
        self.was_in_contact = in_contact.copy()
        self.burst = self.burst * np.exp(-dt / p.pac_decay_s) + onset * p.pac_onset_amp
        slip_amp = np.minimum(p.pac_slip_amp * np.abs(slip_speed_m_s) * 100.0, 500.0)
        amp = self.burst + slip_amp
        out[:, PAC] += amp[:, None] * rng.standard_normal((self.n, 22))  # bursts
        out[:, TDC] += p.tdc_drift_per_s * self.t

        noise = self._noise_std * rng.standard_normal((self.n, FRAME_LEN))
        out += noise
        return np.clip(np.rint(out), 0, COUNT_MAX).astype(np.int64)
