"""Reader for the real BioTac recordings ``robotic_finger_tidy.csv``.

Columns: trial_id, sample_idx, timestamp, t_rel_s, pdc, e1..e19 (raw counts),
nx, ny, nz (plate normal in a frame fixed to the BioTac mount), label_norm,
in_paper_trial. The recordings hold no pac/tdc/tac, so those channels of the
44-value frames built here are zero (no estimator here reads them).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grasp_ctrl.errors import UsageError
from grasp_ctrl.tactile.layout import ELECTRODES, FRAME_LEN, PDC

_ELECTRODE_COLS = [f"e{i}" for i in range(1, 20)]
_REQUIRED = ["trial_id", "pdc", *_ELECTRODE_COLS, "nx", "ny", "nz", "in_paper_trial"]


@dataclass(frozen=True)
class Trial:
    trial_id: str
    raw: np.ndarray          # (k, 44) raw counts (pac/tdc/tac zero)
    normals: np.ndarray      # (k, 3) labelled plate normal, mount frame
    in_paper: bool

    def __len__(self) -> int:
        return self.raw.shape[0]


def read_trials(path: str | Path) -> list[Trial]:
    """All trials in file order; raises UsageError naming the file on bad input."""
    path = Path(path)
    try:
        fh = path.open(newline="", encoding="utf-8")
    except OSError as exc:
        raise UsageError(f"{path}: cannot read ({exc.strerror or exc})") from None
    with fh:
        reader = csv.DictReader(fh)
        missing = [c for c in _REQUIRED if c not in (reader.fieldnames or [])]
        if missing:
            raise UsageError(f"{path}: missing column(s) {', '.join(missing)}")
        rows: dict[str, list[dict[str, str]]] = {}
        for row in reader:
            rows.setdefault(row["trial_id"], []).append(row)
    trials = []
    for tid, rs in rows.items():
        try:
            vals = np.array([[float(r[c]) for c in ["pdc", *_ELECTRODE_COLS, "nx", "ny", "nz", "in_paper_trial"]]
                             for r in rs])
        except ValueError as exc:
            raise UsageError(f"{path}: trial {tid}: non-numeric value ({exc})") from None
        raw = np.zeros((len(rs), FRAME_LEN))
        raw[:, PDC] = vals[:, 0]
        raw[:, ELECTRODES] = vals[:, 1:20]
        trials.append(Trial(tid, raw, vals[:, 20:23], bool(vals[0, 23])))
    if not trials:
        raise UsageError(f"{path}: no samples")
    return trials
