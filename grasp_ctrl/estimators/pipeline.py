"""Raw frames -> per-fingertip f_sensor: validate, tare, gate contact, estimate.

One call per control tick for all fingertips (docs/design.md 3). The estimator runs
once, batched, on the fingertips in contact; the others get zero force (and
zero variance), as the paper did.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.sensor_layout import FRAME_LEN
from grasp_ctrl.estimators.base import ForceEstimator
from grasp_ctrl.numeric import jit
from grasp_ctrl.tactile.frames import validate_frames
from grasp_ctrl.tactile.tare import ContactGate, Tare, scatter_rows, tare_and_gate_bits

_FLOAT64 = np.dtype(np.float64)


class TipForces(NamedTuple):
    """One tick's tactile results (an immutable tuple: cheap to make every tick)."""

    tared: np.ndarray  # (n_tips, 44) counts
    in_contact: np.ndarray  # (n_tips,) bool
    f_sensor: np.ndarray  # (n_tips, 3) N, zero where not in contact
    variance: np.ndarray | None  # (n_tips, 3) N^2 when the estimator provides it


class TactilePipeline:
    def __init__(
        self,
        estimator: ForceEstimator,
        fingers: Sequence[str],
        threshold: float = 10.0,
        frames: int = 10,
        validate: bool = True,
    ) -> None:
        self.estimator = estimator
        self.fingers = tuple(fingers)
        self.tare = Tare(len(self.fingers))
        self.gate = ContactGate(len(self.fingers), threshold, frames)
        self.validate = validate
        n = len(self.fingers)
        self._frame_shape = (n, FRAME_LEN)
        self._all_bits = (1 << n) - 1
        # contact bits -> (rows in contact, their names): a handful of subsets, each made once
        self._subsets: dict[int, tuple[np.ndarray, tuple[str, ...]]] = {}

    @classmethod
    def from_hand(cls, hand: HandConfig, estimator: ForceEstimator, validate: bool = True) -> TactilePipeline:
        return cls(
            estimator,
            [f.name for f in hand.fingers],
            hand.tactile.contact_pdc_threshold,
            hand.tactile.contact_frames,
            validate,
        )

    def set_baseline(self, frames: np.ndarray) -> None:
        """(k, n_tips, 44) raw no-contact frames; also resets the contact gate."""
        frames = np.asarray(frames, dtype=float)
        if self.validate:
            validate_frames(frames.reshape(-1, frames.shape[-1]) if frames.ndim == 3 else frames)
        self.tare.set_baseline(frames)
        self.gate.reset()

    def _subset(self, bits: int) -> tuple[np.ndarray, tuple[str, ...]]:
        got = self._subsets.get(bits)
        if got is None:
            idx = np.array([i for i in range(len(self.fingers)) if bits >> i & 1], dtype=np.intp)
            got = self._subsets[bits] = (idx, tuple(self.fingers[i] for i in idx.tolist()))
        return got

    def step(self, raw: np.ndarray) -> TipForces:
        """One raw frame per fingertip (n_tips, 44) -> tared signals, contact flags, forces."""
        tared, contact, bits = self.gate_frames(raw)
        return TipForces(tared, contact, *self.forces(tared, bits))

    def gate_frames(self, raw: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
        """Validate, tare and gate one raw frame per fingertip (the gate's counters
        advance): ``(tared, in_contact, bits)``, bit i of ``bits`` set when fingertip i
        is in contact."""
        n = len(self.fingers)
        tared = np.empty((n, FRAME_LEN))
        contact = np.empty(n, dtype=bool)
        bits = -1
        if (
            jit.JIT
            and self.validate
            and type(raw) is np.ndarray
            and raw.dtype is _FLOAT64
            and raw.shape == self._frame_shape
            and raw.flags.c_contiguous
            and n <= 62
        ):
            bits = tare_and_gate_bits(
                raw, self.tare.baseline, self.gate.count, self.gate.threshold, self.gate.frames, tared, contact
            )
        if bits < 0:  # the numpy path (and the one that names a bad value)
            raw = validate_frames(raw, self.fingers) if self.validate else np.asarray(raw, dtype=float)
            tared = self.tare.apply(raw)
            contact = self.gate.update(tared)
            bits = sum(1 << i for i in np.flatnonzero(contact).tolist())
        return tared, contact, bits

    def forces(
        self,
        tared: np.ndarray,
        bits: int,
        touching: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """``(f_sensor, variance)`` of the fingertips: one batched estimate for those in
        contact (``bits``, from ``gate_frames``), zero for the others. ``touching``, when
        given, holds their tared rows in order in its first rows (``tared[idx]``, already
        gathered: the policy gets a view of them)."""
        n = len(self.fingers)
        variance = np.zeros((n, 3)) if self.estimator.has_variance else None
        if bits == self._all_bits and n:
            # Every fingertip in contact: no gather, no scatter.
            est = self.estimator.estimate(tared, self.fingers)
            f_sensor = np.array(est.f_sensor, dtype=float)  # own copy, as the scatter below makes
            if f_sensor.shape != (n, 3):  # let the scatter broadcast or name the bad shape
                f_sensor = np.zeros((n, 3))
                f_sensor[:] = est.f_sensor
            if variance is not None and est.variance is not None:
                variance[:] = est.variance
        else:
            f_sensor = np.zeros((n, 3))
            if bits:
                idx, names = self._subset(bits)
                est = self.estimator.estimate(tared[idx] if touching is None else touching[: len(idx)], names)
                rows = est.f_sensor
                if (
                    jit.JIT
                    and type(rows) is np.ndarray
                    and rows.dtype is _FLOAT64
                    and rows.shape == (len(idx), 3)
                    and rows.flags.c_contiguous
                ):
                    scatter_rows(rows, bits, f_sensor)
                else:
                    f_sensor[idx] = rows
                if variance is not None and est.variance is not None:
                    variance[idx] = est.variance
        return f_sensor, variance
