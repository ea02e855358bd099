"""Reader for the real BioTac recordings ``robotic_finger_tidy.csv``.

Columns: trial_id, sample_idx, timestamp, t_rel_s, pdc, e1..e19 (raw counts),
nx, ny, nz (plate normal in a frame fixed to the BioTac mount), label_norm,
in_paper_trial. The recordings hold no pac/tdc/tac, so those channels of the
44-value frames built here are zero (no estimator here reads them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grasp_ctrl.config.sensor_layout import ELECTRODES, FRAME_LEN, PDC
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.csv_rows import Column, read_rows

_ELECTRODE_COLS = [f"e{i}" for i in range(1, 20)]
COUNT_MAX = 4095.0  # a 12-bit BioTac channel
NORMAL_TOLERANCE = 0.01  # the labelled normals are unit vectors to 1e-8
COLUMNS = [
    Column("pdc", 0.0, COUNT_MAX),
    *(Column(c, 0.0, COUNT_MAX) for c in _ELECTRODE_COLS),
    Column("nx", -1.0 - NORMAL_TOLERANCE, 1.0 + NORMAL_TOLERANCE),
    Column("ny", -1.0 - NORMAL_TOLERANCE, 1.0 + NORMAL_TOLERANCE),
    Column("nz", -1.0 - NORMAL_TOLERANCE, 1.0 + NORMAL_TOLERANCE),
    Column("in_paper_trial", 0.0, 1.0),
]


@dataclass(frozen=True)
class Trial:
    trial_id: str
    raw: np.ndarray  # (k, 44) raw counts (pac/tdc/tac zero)
    normals: np.ndarray  # (k, 3) labelled plate normal, mount frame
    in_paper: bool

    def __len__(self) -> int:
        return self.raw.shape[0]


def _unit_normal(values: np.ndarray) -> str | None:
    norm = math.hypot(*values[20:23])
    return None if abs(norm - 1.0) <= NORMAL_TOLERANCE else f"nx, ny, nz: a unit plate normal (got length {norm:.4g})"


def read_trials(path: str | Path, skip_bad_rows: bool = False) -> list[Trial]:
    """All trials in file order; raises UsageError naming the file, line and column of the
    first bad row (a short row, a non-number, NaN, a count outside 0..4095, a normal that
    is not a unit vector), or with ``skip_bad_rows`` leaves such rows out with a warning."""
    path = Path(path)
    rows = read_rows(
        path, COLUMNS, ["trial_id"], skip_bad_rows=skip_bad_rows, what="plate-normal recording", row_check=_unit_normal
    )
    order: dict[str, list[int]] = {}
    for i, (tid,) in enumerate(rows.text):
        order.setdefault(tid, []).append(i)
    trials = []
    for tid, idx in order.items():
        vals = rows.values[idx]
        raw = np.zeros((len(idx), FRAME_LEN))
        raw[:, PDC] = vals[:, 0]
        raw[:, ELECTRODES] = vals[:, 1:20]
        trials.append(Trial(tid, raw, vals[:, 20:23], bool(vals[0, 23])))
    if not trials:
        raise UsageError(f"{path}: no samples")
    return trials
