"""Per-tick CSV log of a trial: state, forces, contacts, targets, joints."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import IO

import numpy as np

from grasp_ctrl.controller.snapshot import Command, Snapshot
from grasp_ctrl.tactile.layout import PDC


class TickLog:
    def __init__(self, path: Path, fingers: list[str], n_joints: int, truth: bool) -> None:
        self.fingers = fingers
        self.truth = truth
        self._fh: IO[str] = path.open("w", newline="", encoding="utf-8")
        self._w = csv.writer(self._fh)
        cols = ["t", "state", "palm_x_world", "palm_y_world", "palm_z_world", "palm_target_z_world"]
        for f in fingers:
            cols += [f"{f}_contact", f"{f}_pdc_tared", f"{f}_grip_n"]
            cols += [f"{f}_f{a}_sensor" for a in "xyz"] + [f"{f}_f{a}_world" for a in "xyz"]
            if truth:
                cols += [f"{f}_true_f{a}_sensor" for a in "xyz"]
        cols += [f"q{j}" for j in range(n_joints)] + [f"q_goal{j}" for j in range(n_joints)]
        if truth:
            cols += ["object_z_world", "table_force_n"]
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
    ) -> None:
        row: list[object] = [f"{snap.t:.3f}", state]
        row += [f"{v:.5f}" for v in snap.p_palm_world] + [f"{cmd.p_palm_world[2]:.5f}"]
        for i in range(len(self.fingers)):
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
        self._fh.flush()
        self._fh.close()
