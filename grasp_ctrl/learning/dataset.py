"""Dataset of labelled tactile samples: one row per sample.

Columns (CSV header or Parquet column names):

- ``trial_id`` (text), ``source`` (``rigid-ft``, ``ball-ft``, ``planar-pushing``), ``t`` (s);
- the 44 signals, either TARED under the channel names ``e1..e19, pdc, pac1..pac22, tdc, tac``
  (value - baseline, counts) or RAW under ``raw_e1 .. raw_tac``; raw signals are tared per
  trial with the mean of the trial's first ``tare_frames`` rows, which must be free of contact;
- ``fx, fy, fz``: force label in N, sensor frame, the force ON the sensor skin (DESIGN.md 4);
- ``projected`` (0/1): only the components parallel to the support plane are trusted
  (planar pushing); then ``r00 .. r22`` (row-major R_world_sensor, the sensor orientation in
  the world, whose z axis is the support-surface normal) are required.

Extra columns are ignored. Bad rows are reported with their line number (CSV) or row number
(Parquet), never silently dropped.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from grasp_ctrl.errors import GraspCtrlError
from grasp_ctrl.tactile.layout import CHANNEL_NAMES, FRAME_LEN

SOURCES = ("rigid-ft", "ball-ft", "planar-pushing")
LABEL_COLUMNS = ("fx", "fy", "fz")
ROTATION_COLUMNS = tuple(f"r{i}{j}" for i in range(3) for j in range(3))
RAW_COLUMNS = tuple(f"raw_{c}" for c in CHANNEL_NAMES)
MAX_REPORTED = 10


class DatasetError(GraspCtrlError):
    exit_status = 2


@dataclass
class Dataset:
    trial_id: np.ndarray        # (n,) str
    source: np.ndarray          # (n,) str
    t: np.ndarray               # (n,) s
    tared: np.ndarray           # (n, 44) counts
    f_sensor: np.ndarray        # (n, 3) N
    projected: np.ndarray       # (n,) bool
    r_world_sensor: np.ndarray  # (n, 3, 3); identity where not projected

    def __len__(self) -> int:
        return len(self.t)

    def subset(self, mask_or_index: np.ndarray) -> "Dataset":
        return Dataset(*(getattr(self, f)[mask_or_index] for f in _FIELDS))

    @staticmethod
    def concat(parts: Sequence["Dataset"]) -> "Dataset":
        return Dataset(*(np.concatenate([getattr(p, f) for p in parts]) for f in _FIELDS))

    def sources(self) -> list[str]:
        return [s for s in SOURCES if np.any(self.source == s)]


_FIELDS = ("trial_id", "source", "t", "tared", "f_sensor", "projected", "r_world_sensor")


class _Problems:
    def __init__(self, path: Path, unit: str) -> None:
        self.path = path
        self.unit = unit
        self.items: list[tuple[int, str]] = []

    def add(self, where: int, msg: str) -> None:
        self.items.append((where, msg))

    def raise_if_any(self) -> None:
        if not self.items:
            return
        shown = "; ".join(f"{self.unit} {w}: {m}" for w, m in self.items[:MAX_REPORTED])
        more = f" (and {len(self.items) - MAX_REPORTED} more)" if len(self.items) > MAX_REPORTED else ""
        raise DatasetError(f"{self.path}: {len(self.items)} bad row(s): {shown}{more}")


def _columns_spec(header: Sequence[str], path: Path) -> tuple[list[str], bool]:
    names = set(header)
    required = ["trial_id", "source", "t", *LABEL_COLUMNS, "projected"]
    missing = [c for c in required if c not in names]
    if missing:
        raise DatasetError(f"{path}: missing column(s) {', '.join(missing)}")
    if all(c in names for c in CHANNEL_NAMES):
        return list(CHANNEL_NAMES), False
    if all(c in names for c in RAW_COLUMNS):
        return list(RAW_COLUMNS), True
    absent = [c for c in CHANNEL_NAMES if c not in names]
    raise DatasetError(f"{path}: missing signal column(s) {', '.join(absent[:5])} (tared e1..tac or raw_e1..raw_tac)")


def _parse_rows(
    records: Iterable[tuple[int, dict[str, object]]], signal_cols: list[str], has_rot: bool, problems: _Problems
) -> dict[str, list]:
    out: dict[str, list] = {f: [] for f in ("trial_id", "source", "t", "z", "f", "proj", "r")}
    for where, rec in records:
        try:
            trial = str(rec["trial_id"]).strip()
            source = str(rec["source"]).strip()
            if not trial:
                raise ValueError("trial_id: empty")
            if source not in SOURCES:
                raise ValueError(f"source: one of {', '.join(SOURCES)} (got {source!r})")
            t = _num(rec, "t")
            z = [_num(rec, c) for c in signal_cols]
            f = [_num(rec, c) for c in LABEL_COLUMNS]
            proj_val = _num(rec, "projected")
            if proj_val not in (0.0, 1.0):
                raise ValueError(f"projected: 0 or 1 (got {rec['projected']!r})")
            proj = proj_val == 1.0
            if proj:
                if not has_rot:
                    raise ValueError("projected label needs the sensor orientation columns r00..r22")
                r = np.array([_num(rec, c) for c in ROTATION_COLUMNS]).reshape(3, 3)
                if np.max(np.abs(r @ r.T - np.eye(3))) > 1e-3 or np.linalg.det(r) < 0:
                    raise ValueError("r00..r22: not a rotation matrix")
            else:
                r = np.eye(3)
            if not np.linalg.norm(f) > 0:
                raise ValueError("fx, fy, fz: a non-zero force label (use force samples only)")
        except ValueError as exc:
            problems.add(where, str(exc))
            continue
        out["trial_id"].append(trial)
        out["source"].append(source)
        out["t"].append(t)
        out["z"].append(z)
        out["f"].append(f)
        out["proj"].append(proj)
        out["r"].append(r)
    return out


def _num(rec: dict[str, object], col: str) -> float:
    value = rec.get(col)
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"{col}: a number (got {value!r})") from None
    if not math.isfinite(v):
        raise ValueError(f"{col}: a finite number (got {value!r})")
    return v


def _build(cols: dict[str, list], raw: bool, tare_frames: int, path: Path) -> Dataset:
    n = len(cols["t"])
    if n == 0:
        raise DatasetError(f"{path}: no samples")
    z = np.asarray(cols["z"], dtype=float).reshape(n, FRAME_LEN)
    trial = np.asarray(cols["trial_id"], dtype=object).astype(str)
    if raw:
        z = tare_per_trial(z, trial, tare_frames)
    return Dataset(
        trial_id=trial,
        source=np.asarray(cols["source"]).astype(str),
        t=np.asarray(cols["t"], dtype=float),
        tared=z,
        f_sensor=np.asarray(cols["f"], dtype=float),
        projected=np.asarray(cols["proj"], dtype=bool),
        r_world_sensor=np.asarray(cols["r"], dtype=float).reshape(n, 3, 3),
    )


def tare_per_trial(raw: np.ndarray, trial_id: np.ndarray, tare_frames: int) -> np.ndarray:
    """value - baseline, the baseline being the mean of each trial's first rows."""
    out = np.asarray(raw, dtype=float).copy()
    for trial in np.unique(trial_id):
        idx = np.flatnonzero(trial_id == trial)
        out[idx] -= out[idx[:tare_frames]].mean(axis=0)
    return out


def read_csv(path: str | Path, tare_frames: int = 10, on_bad: str = "raise") -> tuple[Dataset, list[tuple[int, str]]]:
    """Read a dataset CSV. ``on_bad="raise"`` fails listing the bad lines; ``"skip"``
    leaves them out and returns them as (line, problem) for the caller to report."""
    p = Path(path)
    try:
        fh = p.open(newline="", encoding="utf-8")
    except OSError as exc:
        raise DatasetError(f"{p}: cannot read ({exc.strerror or exc})") from None
    problems = _Problems(p, "line")
    with fh:
        reader = csv.reader(fh)
        header = [h.strip() for h in next(reader, [])]
        if not header:
            raise DatasetError(f"{p}: empty file")
        signal_cols, raw = _columns_spec(header, p)
        has_rot = all(c in header for c in ROTATION_COLUMNS)

        def records() -> Iterable[tuple[int, dict[str, object]]]:
            for line_no, row in enumerate(reader, start=2):
                if not row:
                    continue
                if len(row) != len(header):
                    problems.add(line_no, f"{len(row)} fields, the header has {len(header)}")
                    continue
                yield line_no, dict(zip(header, row))

        cols = _parse_rows(records(), signal_cols, has_rot, problems)
    if on_bad == "raise":
        problems.raise_if_any()
    return _build(cols, raw, tare_frames, p), problems.items


def read_parquet(path: str | Path, tare_frames: int = 10, on_bad: str = "raise") -> tuple[Dataset, list[tuple[int, str]]]:
    """Parquet with the same columns (needs pyarrow); rows are numbered from 1."""
    p = Path(path)
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise DatasetError(f"{p}: reading Parquet needs pyarrow (pip install pyarrow)") from None
    try:
        table = pq.read_table(p)
    except (OSError, ValueError) as exc:
        raise DatasetError(f"{p}: unreadable Parquet ({exc})") from None
    header = list(table.column_names)
    signal_cols, raw = _columns_spec(header, p)
    has_rot = all(c in header for c in ROTATION_COLUMNS)
    data = table.to_pydict()
    problems = _Problems(p, "row")
    records = ((i + 1, {c: data[c][i] for c in header}) for i in range(table.num_rows))
    cols = _parse_rows(records, signal_cols, has_rot, problems)
    if on_bad == "raise":
        problems.raise_if_any()
    return _build(cols, raw, tare_frames, p), problems.items


def read_dataset(path: str | Path, tare_frames: int = 10, on_bad: str = "raise") -> tuple[Dataset, list[tuple[int, str]]]:
    p = Path(path)
    if p.suffix.lower() in (".parquet", ".pq"):
        return read_parquet(p, tare_frames, on_bad)
    return read_csv(p, tare_frames, on_bad)


def read_datasets(paths: Sequence[str | Path], tare_frames: int = 10, on_bad: str = "raise") -> tuple[Dataset, list[str]]:
    parts, notes = [], []
    for path in paths:
        ds, bad = read_dataset(path, tare_frames, on_bad)
        parts.append(ds)
        notes += [f"{path}: line {w}: {m}" for w, m in bad]
    return Dataset.concat(parts), notes


def header() -> list[str]:
    return ["trial_id", "source", "t", *CHANNEL_NAMES, *LABEL_COLUMNS, "projected", *ROTATION_COLUMNS]


def write_csv(path: str | Path, ds: Dataset) -> None:
    with Path(path).open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(header())
        for i in range(len(ds)):
            w.writerow(
                [ds.trial_id[i], ds.source[i], f"{ds.t[i]:.4f}"]
                + [f"{v:.6g}" for v in ds.tared[i]]
                + [f"{v:.6g}" for v in ds.f_sensor[i]]
                + [int(ds.projected[i])]
                + [f"{v:.9g}" for v in ds.r_world_sensor[i].ravel()]
            )
