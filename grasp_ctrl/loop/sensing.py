"""One control tick's sensing: raw frames -> (tactile pipeline: validate, tare,
contact gate, estimator) -> forces in sensor, hand and world frames -> Snapshot
(docs/design.md 3)."""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.controller.snapshot import Snapshot
from grasp_ctrl.errors import FrameError, SensorStaleError
from grasp_ctrl.estimators.base import ForceEstimator
from grasp_ctrl.estimators.pipeline import TactilePipeline
from grasp_ctrl.hardware.base import JointState, SensorBackend, TactileFrame
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.pad_ik import shared_pad_ik
from grasp_ctrl.loop.loop_kernels import place_forces, sense_forces, sense_inputs
from grasp_ctrl.numeric.finite import all_finite

_FLOAT64 = np.dtype(np.float64)


class SensingPipeline:
    def __init__(self, hand: HandConfig, kin: HandKinematics, estimator: ForceEstimator) -> None:
        self.hand = hand
        self.kin = kin
        self.fast_kin = shared_pad_ik(kin)  # sensor rotations, compiled with numba
        self._compiled = self.fast_kin.compiled  # the compiled halves of a snapshot (loop/loop_kernels.py)
        self._geometry, self._layout = self.fast_kin.geometry, self.fast_kin.layout
        self.estimator = estimator
        self.names = [f.name for f in hand.fingers]
        self.sensor_ids = [f.sensor_id for f in hand.fingers]
        n = len(self.names)
        self.tactile = TactilePipeline.from_hand(hand, estimator)
        self._tare_window: list[np.ndarray] = []
        self.frame_len = hand.tactile.layout.frame_len  # values per frame of this sensor type
        self._frame_shape = (n, self.frame_len)
        self._stale_after_s = hand.tactile.stale_after_s
        self.raw = np.zeros(self._frame_shape)
        self.tared = np.zeros(self._frame_shape)
        self.joint_names = [j.name for j in hand.joints]
        # the last finite joint angles and palm position (used when a reading is not finite)
        self._last_q = np.array([j.open_rad for j in hand.joints])
        self._last_palm = np.zeros(3)
        self._tips: dict[int, tuple[np.ndarray, tuple[str, ...]]] = {}  # contact bits -> (rows, finger names)

    def read_frames(self, sensors: SensorBackend, now: float) -> np.ndarray:
        """(n_tips, 44) raw counts in finger order from ``sensors``: ``frames_matrix`` of
        ``read_latest``, or the same matrix in one piece from a backend that offers
        ``latest_matrix`` (the mock's sensors); a missing or old frame is a fault."""
        latest_matrix = getattr(sensors, "latest_matrix", None)
        if latest_matrix is not None:
            got = latest_matrix(self.sensor_ids)
            if got is not None and now - got[1] <= self._stale_after_s:
                return got[0]  # (a stale one goes the long way, which names the fingertip)
        return self.frames_matrix(sensors.read_latest(), now)

    def frames_matrix(self, frames: dict[int, TactileFrame], now: float) -> np.ndarray:
        """(n_tips, 44) raw counts in finger order; a missing or old frame is a fault."""
        stale_after = self.hand.tactile.stale_after_s
        raw = np.empty(self._frame_shape)
        for i, sid in enumerate(self.sensor_ids):
            frame = frames.get(sid)
            if frame is None:
                raise SensorStaleError(f"fingertip {self.names[i]!r} (sensor {sid}): no frame received")
            age = now - frame.t_recv
            if age > stale_after:
                raise SensorStaleError(
                    f"fingertip {self.names[i]!r} (sensor {sid}): last frame {age * 1000:.0f} ms old "
                    f"(stale after {stale_after * 1000:.0f} ms)"
                )
            try:
                raw[i] = frame.values
            except (ValueError, TypeError) as exc:
                raise FrameError(f"fingertip {self.names[i]!r} (sensor {sid}): malformed frame ({exc})") from None
        return raw

    def collect_tare(self, raw: np.ndarray) -> bool:
        """Add one free-space frame to the tare window; True once the baseline is set."""
        if self.tactile.tare.ready:
            return True
        self._tare_window.append(raw.copy())
        if len(self._tare_window) >= self.hand.tactile.tare_frames:
            self.tactile.set_baseline(np.stack(self._tare_window))
            self._tare_window.clear()
        return self.tactile.tare.ready

    def snapshot(
        self,
        raw: np.ndarray,
        joints: JointState,
        p_palm_world: np.ndarray,
        collecting_tare: bool,
        fault: str | None = None,
        fault_detail: str | None = None,
        pac_spread: np.ndarray | None = None,
    ) -> Snapshot:
        """Non-finite or malformed inputs and outputs become the snapshot's fault
        (``sensor_invalid``, ``estimate_invalid``; the first one found is kept) and are
        replaced by finite values (zero force, the last good joint angles) so the safe
        action stays finite. ``pac_spread``: the snapshot's (``Snapshot.pac_spread``)."""
        n = len(self.names)
        q = np.asarray(joints.q, dtype=float)
        if not q.flags.writeable:  # a hand's shared state (the CAN hand's): the kernels take one
            q = q.copy()  # array type whatever the backend, so none loads a second variant mid-trial
        p_palm_world = np.asarray(p_palm_world, dtype=float)
        tactile = self.tactile
        gated = None
        nd = np.ndarray
        if (
            self._compiled
            and not collecting_tare
            and tactile.tare.ready
            and tactile.validate
            and q.shape == self._last_q.shape
            and p_palm_world.shape == (3,)
            and type(raw) is nd
            and raw.dtype is _FLOAT64
            and raw.shape == self._frame_shape
            and raw.flags.c_contiguous
        ):
            # The usual tick in one compiled call: inputs finite, frames tared and gated.
            tared, in_contact = np.empty(self._frame_shape), np.empty(n, dtype=bool)
            touching = np.empty(self._frame_shape)
            bits = sense_inputs(
                q,
                p_palm_world,
                raw,
                tactile.tare.baseline,
                tactile.gate.count,
                tactile.gate.threshold,
                tactile.gate.frames,
                tared,
                in_contact,
                touching,
            )
            if bits >= 0:
                gated = tared, in_contact, bits, touching
        if gated is None:  # the long way, which also names what is wrong
            q, p_palm_world, fault, fault_detail = self._checked_pose(q, p_palm_world, fault, fault_detail)
        return self._snapshot(
            raw, q, p_palm_world, joints.t, gated, collecting_tare, fault, fault_detail, pac_spread=pac_spread
        )

    def _snapshot(
        self,
        raw: np.ndarray,
        q: np.ndarray,
        p_palm_world: np.ndarray,
        t: float,
        gated: tuple[np.ndarray, np.ndarray, int, np.ndarray] | None,
        collecting_tare: bool,
        fault: str | None,
        fault_detail: str | None,
        estimated: np.ndarray | None = None,
        pac_spread: np.ndarray | None = None,
    ) -> Snapshot:
        """``snapshot``'s second half; ``estimated``: the forces of the fingertips in contact
        (gated) already estimated and placed (``_estimate_and_turn``)."""
        n = len(self.names)
        self.raw = raw
        tactile = self.tactile
        nd = np.ndarray
        self._last_q = q
        self._last_palm = p_palm_world
        variance = None
        no_force = False  # f_sensor is our own zeros (no fingertip in contact, or no tare yet)
        f_hand = None
        if gated is not None:
            tared, in_contact, bits, touching = gated
            tare_ready = True
            estimator = tactile.estimator
            if estimated is not None:
                f_sensor = estimated
            elif bits and not estimator.has_variance and q.flags.c_contiguous:
                f_sensor, f_hand, grip = self._estimate_and_turn(estimator, q, tared, touching, bits)
            else:
                f_sensor, variance = tactile.forces(tared, bits, touching)
                no_force = bits == 0
        else:
            try:
                tare_ready = self.collect_tare(raw) if collecting_tare else tactile.tare.ready
                if tare_ready:
                    tared, in_contact, f_sensor, variance = tactile.step(raw)
            except FrameError as exc:
                tare_ready = False
                if fault is None:
                    fault, fault_detail = "sensor_invalid", str(exc)
            if not tare_ready:  # before the baseline, or a frame that failed: no contact, no force
                tare_ready = tactile.tare.ready
                tared = np.zeros_like(raw, dtype=float)
                in_contact = np.zeros(n, dtype=bool)
                f_sensor = np.zeros((n, 3))
                variance = None
                no_force = True
        self.tared = tared
        # Grip = the squeeze: the force across the lift direction (world z). Along z
        # the fingertips also carry the object's weight, which must not count as grip.
        if f_hand is not None:
            pass  # estimated and turned in one go (_estimate_and_turn)
        elif self._compiled and no_force and variance is None:
            # Zero forces (+0.0) turned by the sensor rotations, finite at finite angles, sum
            # to +0.0 in every term the kernel adds (+0.0 + -0.0 is +0.0): all zeros, as
            # sense_forces would compute them.
            f_hand, grip = np.zeros((n, 3)), np.zeros(n)
        elif (
            self._compiled
            and variance is None
            and type(f_sensor) is nd
            and f_sensor.dtype is _FLOAT64
            and f_sensor.shape == (n, 3)
            and f_sensor.flags.c_contiguous
            and q.flags.c_contiguous
        ):
            f_hand, grip = np.empty((n, 3)), np.empty(n)
            if not sense_forces(q, f_sensor, self._geometry, self._layout, f_hand, grip):
                f_hand = None  # a force is not finite: the long way
        # The long way, which also names a non-finite estimate (f_hand and grip are None together).
        if f_hand is None or grip is None:
            f_sensor, variance, fault, fault_detail = self._checked_estimate(f_sensor, variance, fault, fault_detail)
            f_hand, grip = self.fast_kin.sensor_forces(q, f_sensor)
        f_world = f_hand  # the arm translates the hand: hand axes = world axes
        # positional (Snapshot's field order): a third of the keyword call's cost, every tick
        return Snapshot(
            t,
            q,
            p_palm_world,
            tare_ready,
            in_contact,
            f_sensor,
            f_hand,
            f_world,
            grip,
            variance,
            fault,
            fault_detail,
            pac_spread,
        )

    def estimate_contacts(
        self, estimator: ForceEstimator, tared: np.ndarray, touching: np.ndarray, bits: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """The policy's call ``TactilePipeline.forces`` makes for the fingertips in contact
        (``bits``, their tared rows first in ``touching``): ``(its f_sensor rows, their
        fingertips' indices)``."""
        got = self._tips.get(bits)
        if got is None:
            n = len(self.names)
            idx = np.array([i for i in range(n) if bits >> i & 1], dtype=np.intp)
            got = self._tips[bits] = (
                idx,
                self.tactile.fingers if idx.size == n else tuple(self.tactile.fingers[i] for i in idx.tolist()),
            )
        idx, names = got
        k = idx.size
        # the same call TactilePipeline.forces makes: every tared row, or those in contact
        return estimator.estimate(tared if k == len(self.names) else touching[:k], names).f_sensor, idx

    def placed_rows(self, rows: np.ndarray, idx: np.ndarray) -> np.ndarray:
        """``TactilePipeline.forces``' own placing of the policy's rows (which names a bad shape)."""
        n = len(self.names)
        if idx.size == n:
            f_sensor = np.array(rows, dtype=float)
            if f_sensor.shape != (n, 3):
                f_sensor = np.zeros((n, 3))
                f_sensor[:] = rows
        else:
            f_sensor = np.zeros((n, 3))
            f_sensor[idx] = rows
        return f_sensor

    def _estimate_and_turn(
        self, estimator: ForceEstimator, q: np.ndarray, tared: np.ndarray, touching: np.ndarray, bits: int
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """``TactilePipeline.forces`` for a policy without variance and the fingertips in
        contact (``bits``, their tared rows first in ``touching``), then the forces into the
        hand frame, the rows placed and turned in one compiled call (``place_forces``):
        ``(f_sensor, f_hand, grip)``; f_hand and grip are None when a force is not finite
        (or the rows have an odd type or shape), for the long way to name it."""
        n = len(self.names)
        rows, idx = self.estimate_contacts(estimator, tared, touching, bits)
        if (
            type(rows) is np.ndarray
            and rows.dtype is _FLOAT64
            and rows.shape == (idx.size, 3)
            and rows.flags.c_contiguous
        ):
            f_sensor = np.empty((n, 3))
            f_hand, grip = np.empty((n, 3)), np.empty(n)
            if place_forces(rows, bits, q, self._geometry, self._layout, f_sensor, f_hand, grip):
                return f_sensor, f_hand, grip
            return f_sensor, None, None
        return self.placed_rows(rows, idx), None, None

    def _checked_pose(
        self,
        q: np.ndarray,
        p_palm_world: np.ndarray,
        fault: str | None,
        detail: str | None,
    ) -> tuple[np.ndarray, np.ndarray, str | None, str | None]:
        """Joint angles and palm position, each replaced by the last good one (and the
        fault noted, unless one is already) when it is not finite or has the wrong shape."""
        if q.shape != self._last_q.shape or not all_finite(q):
            bad = (
                [j for j, v in zip(self.joint_names, np.ravel(q)) if not np.isfinite(v)]
                if q.shape == self._last_q.shape
                else []
            )
            if fault is None:
                fault, detail = "sensor_invalid", f"joint angles not finite ({', '.join(bad) or f'shape {q.shape}'})"
            q = self._last_q.copy()
        if p_palm_world.shape != (3,) or not all_finite(p_palm_world):
            if fault is None:
                fault, detail = "sensor_invalid", f"arm position not finite ({p_palm_world.tolist()})"
            p_palm_world = self._last_palm.copy()
        return q, p_palm_world, fault, detail

    def _checked_estimate(
        self, f_sensor: np.ndarray, variance: np.ndarray | None, fault: str | None, detail: str | None
    ) -> tuple[np.ndarray, np.ndarray | None, str | None, str | None]:
        """The policy's forces (and variances) with non-finite values replaced by 0, the
        fault noted (unless one is already) naming the fingertips."""
        n = len(self.names)
        f_sensor = np.asarray(f_sensor, dtype=float)
        if not (all_finite(f_sensor) and (variance is None or all_finite(variance))):
            bad_f = ~np.all(np.isfinite(f_sensor), axis=1)
            bad_v = ~np.all(np.isfinite(variance), axis=1) if variance is not None else np.zeros(n, dtype=bool)
            if bad_f.any() or bad_v.any():
                tips_bad = [self.names[i] for i in np.flatnonzero(bad_f | bad_v)]
                what = "force" if bad_f.any() else "variance"
                if fault is None:
                    fault = "estimate_invalid"
                    detail = (
                        f"policy {getattr(self.estimator, 'name', '?')!r} returned a non-finite "
                        f"{what} for fingertip(s) {', '.join(tips_bad)}"
                    )
                f_sensor = np.where(np.isfinite(f_sensor), f_sensor, 0.0)
                if variance is not None:
                    variance = np.where(np.isfinite(variance), variance, 0.0)
        return f_sensor, variance, fault, detail
