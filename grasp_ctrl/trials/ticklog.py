"""Per-tick CSV log of a trial: state, raw-signal summary, tared pdc, contacts,
estimated forces (sensor and world frames), targets, joint state.

Rows are buffered by the csv module and flushed and fsynced on ``close`` (the
runner closes the log before it writes the trial's JSON record, so a record on
disk always has a complete tick log beside it).
"""

from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import IO

import numpy as np

from grasp_ctrl.controller.snapshot import Command, Snapshot
from grasp_ctrl.tactile.layout import ELECTRODES, PAC, PDC, TDC

# Per-fingertip raw-signal summary columns (raw counts, before tare).
RAW_COLUMNS = ("raw_pdc", "raw_tdc", "raw_pac_std", "raw_e_mean")


def raw_summary(raw: np.ndarray) -> np.ndarray:
    """(n_tips, 44) raw counts -> (n_tips, 4): pdc, tdc, spread of the 22 pac samples
    (vibration), mean of the 19 electrodes."""
    return np.column_stack([raw[:, PDC], raw[:, TDC], raw[:, PAC].std(axis=1), raw[:, ELECTRODES].mean(axis=1)])


class TickLog:
    def __init__(self, path: Path, fingers: list[str], n_joints: int, truth: bool) -> None:
        self.fingers = fingers
        self.truth = truth
        self._fh: IO[str] = path.open("w", newline="", encoding="utf-8")
        self._w = csv.writer(self._fh)
        cols = ["t", "state", "palm_x_world", "palm_y_world", "palm_z_world", "palm_target_z_world", "grip_target_n"]
        for f in fingers:
            cols += [f"{f}_{c}" for c in RAW_COLUMNS]
            cols += [f"{f}_contact", f"{f}_pdc_tared", f"{f}_grip_n"]
            cols += [f"{f}_f{a}_sensor" for a in "xyz"] + [f"{f}_f{a}_world" for a in "xyz"]
            if truth:
                cols += [f"{f}_true_f{a}_sensor" for a in "xyz"]
        cols += [f"q{j}" for j in range(n_joints)] + [f"q_goal{j}" for j in range(n_joints)]
        if truth:
            cols += ["object_z_world", "table_force_n"]
        self.columns = cols
        self._w.writerow(cols)

    def append(
        self,
        state: str,
        snap: Snapshot,
        cmd: Command,
        tared: np.ndarray,
        true_f_sensor: np.ndarray | None = None,
        object_z: float = float("nan"),
        table_force: float = float("nan"),
        raw: np.ndarray | None = None,
        grip_target_n: float = float("nan"),
    ) -> None:
        row: list[object] = [f"{snap.t:.3f}", state]
        row += [f"{v:.5f}" for v in snap.p_palm_world] + [f"{cmd.p_palm_world[2]:.5f}", f"{grip_target_n:.3f}"]
        summary = raw_summary(raw) if raw is not None else np.full((len(self.fingers), len(RAW_COLUMNS)), np.nan)
        for i in range(len(self.fingers)):
            row += [f"{v:.1f}" for v in summary[i]]
            row += [int(snap.in_contact[i]), f"{tared[i, PDC]:.1f}", f"{snap.grip_n[i]:.4f}"]
            row += [f"{v:.4f}" for v in snap.f_sensor[i]] + [f"{v:.4f}" for v in snap.f_world[i]]
            if self.truth:
                assert true_f_sensor is not None
                row += [f"{v:.4f}" for v in true_f_sensor[i]]
        row += [f"{v:.5f}" for v in snap.q] + [f"{v:.5f}" for v in cmd.q_goal]
        if self.truth:
            row += [f"{object_z:.5f}", f"{table_force:.4f}"]
        self._w.writerow(row)

    def close(self) -> None:
        if self._fh.closed:
            return
        self._fh.flush()
        os.fsync(self._fh.fileno())
        self._fh.close()
