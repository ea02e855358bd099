"""The tactile recording of ``sensors --record``, read and written for the bags.

Columns (``tactile_link/recorder.py``): ``t_recv, finger, seq, e1..e19, pdc, pac1..pac22,
tdc, tac``; one row per frame, raw counts. A recording made from a bag with force labels
(``import-bag --wrench``) has these columns after them (``LABEL_COLUMNS``):

- ``trial_id``: the bag's name (one trial per bag);
- ``fx, fy, fz``: the wrench topic's force at the frame's time, N, in that topic's frame;
- ``nx, ny, nz``: its direction, a unit vector (rows below the force threshold hold the
  direction of the nearest row above it: the readers want a unit vector on every row, and
  gate contact on pdc);
- ``in_paper_trial``: 1 (every trial is chosen by ``evaluate-direction --trials paper``).

With them the file is also a plate-normal recording (``evaluation/robotic_finger.py``):
``evaluate-direction`` reads it, ``calibrate`` fits a direction-only correction on it, and
``sensors --emulate --emulate-from`` replays its pdc and electrodes in any case.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from decimal import Decimal, InvalidOperation
from pathlib import Path

import numpy as np

from grasp_ctrl.config.sensor_layout import BIOTAC, CHANNEL_NAMES
from grasp_ctrl.errors import UsageError
from grasp_ctrl.hardware.base import TactileFrame
from grasp_ctrl.tactile_link.recorder import HEADER

LABEL_COLUMNS = ("trial_id", "fx", "fy", "fz", "nx", "ny", "nz", "in_paper_trial")
MAX_FINGER = 65535  # bt_position is a uint16
MAX_SEQ = 65535  # the protocol's sequence number is a uint16


@dataclass
class Labels:
    trial_id: np.ndarray  # (n,) str
    f_wrench: np.ndarray  # (n, 3) N, the wrench topic's frame
    n_wrench: np.ndarray  # (n, 3) unit direction, the wrench topic's frame


@dataclass
class Recording:
    t_ns: np.ndarray  # (n,) int64, receive time in ns
    finger: np.ndarray  # (n,) int, the frame's sensor id
    seq: np.ndarray  # (n,) int
    values: np.ndarray  # (n, 44) int64 raw counts, BioTac order
    labels: Labels | None = None

    def __len__(self) -> int:
        return len(self.t_ns)

    def frames(self) -> list[TactileFrame]:
        return [
            TactileFrame(int(self.finger[i]), int(self.seq[i]), seconds(int(self.t_ns[i])), self.values[i])
            for i in range(len(self))
        ]

    def subset(self, mask: np.ndarray) -> Recording:
        labels = None
        if self.labels is not None:
            labels = Labels(self.labels.trial_id[mask], self.labels.f_wrench[mask], self.labels.n_wrench[mask])
        return Recording(self.t_ns[mask], self.finger[mask], self.seq[mask], self.values[mask], labels)


def seconds(t_ns: int) -> float:
    """ns -> s, correctly rounded (an epoch time in ns is beyond a float's integers)."""
    return t_ns / 10**9


def nanoseconds(text: str) -> int:
    """A time written in seconds -> ns, exactly as written (no float in between)."""
    try:
        return int((Decimal(text.strip()) * 10**9).to_integral_value())
    except (InvalidOperation, ValueError):
        raise ValueError(f"t_recv: a time in seconds (got {text!r})") from None


def is_recording(path: Path) -> bool:
    """True when ``path`` starts with the recorder's header."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            head = next(csv.reader(fh), [])
    except (OSError, UnicodeDecodeError, csv.Error):
        return False
    return tuple(h.strip() for h in head[: len(HEADER)]) == HEADER


def read_recording(path: str | Path, skip_bad_rows: bool = False) -> Recording:
    """A ``sensors --record`` file (label columns, where present, are not read: the bag
    carries frames only). A bad row is one line naming it (``csv_rows``)."""
    from grasp_ctrl.files.csv_rows import Column, read_rows

    hi = float(BIOTAC.count_max)
    numeric = [Column("t_recv"), Column("finger", 0, MAX_FINGER), Column("seq", 0, MAX_SEQ)]
    numeric += [Column(c, 0, hi) for c in CHANNEL_NAMES]
    rows = read_rows(path, numeric, ["t_recv"], skip_bad_rows=skip_bad_rows, what="tactile recording")
    if not len(rows.values):
        raise UsageError(f"{path}: a tactile recording with no frames")
    v = rows.values
    if not np.all(v[:, 1:] == np.round(v[:, 1:])):
        bad = int(np.flatnonzero(np.any(v[:, 1:] != np.round(v[:, 1:]), axis=1))[0])
        raise UsageError(f"{path}: line {rows.lines[bad]}: finger, seq and the counts are whole numbers")
    t_ns = np.array([nanoseconds(text) for (text,) in rows.text], dtype=np.int64)
    ints = v[:, 1:].astype(np.int64)
    return Recording(t_ns, ints[:, 0], ints[:, 1], ints[:, 2:])


def _cells(frame_t_ns: int, finger: int, seq: int, values: np.ndarray) -> list[object]:
    # the recorder's own formatting (FrameRecorder.write), so a recording from a bag reads the same
    return [f"{seconds(frame_t_ns):.6f}", finger, seq, *(int(v) for v in values)]


def write_recording(path: str | Path, rec: Recording) -> Path:
    """``rec`` as a recording file (a stream gets the bytes; a file is replaced whole)."""
    from grasp_ctrl.files.safe_write import output_file

    with output_file(path) as tmp, tmp.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(HEADER + (LABEL_COLUMNS if rec.labels is not None else ()))
        for i in range(len(rec)):
            row = _cells(int(rec.t_ns[i]), int(rec.finger[i]), int(rec.seq[i]), rec.values[i])
            if rec.labels is not None:
                lab = rec.labels
                row += [lab.trial_id[i], *(repr(float(x)) for x in lab.f_wrench[i])]
                row += [*(repr(float(x)) for x in lab.n_wrench[i]), 1]
            w.writerow(row)
    return Path(path)
