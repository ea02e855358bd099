"""PUSH.csv in, FORCES.csv out (DESIGN.md 5.4). Bad rows are reported by line."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from grasp_ctrl.errors import UsageError
from grasp_ctrl.pushing.solver import PushForces
from grasp_ctrl.pushing.simulate import SimulatedPush

PUSH_COLUMNS = ("t", "x", "y", "theta", "contact_x", "contact_y", "in_contact")
FORCE_COLUMNS = ("t", "fx_world", "fy_world", "fx_object", "fy_object", "moving")


def read_push_csv(path: str | Path) -> dict[str, np.ndarray]:
    """Columns of PUSH.csv as float arrays (extra columns ignored)."""
    p = Path(path)
    try:
        fh = p.open(newline="", encoding="utf-8")
    except OSError as exc:
        raise UsageError(f"{p}: cannot read the trajectory ({exc.strerror or exc})") from None
    with fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None:
            raise UsageError(f"{p}: empty file, expected a header with {', '.join(PUSH_COLUMNS)}")
        header = [h.strip() for h in header]
        missing = [c for c in PUSH_COLUMNS if c not in header]
        if missing:
            raise UsageError(f"{p}: line 1: missing column(s) {', '.join(missing)}")
        cols = [header.index(c) for c in PUSH_COLUMNS]
        rows: list[list[float]] = []
        for line_no, row in enumerate(reader, start=2):
            if not row or all(not v.strip() for v in row):
                continue
            try:
                values = [float(row[i]) for i in cols]
            except (ValueError, IndexError):
                raise UsageError(f"{p}: line {line_no}: expected numbers in columns {', '.join(PUSH_COLUMNS)}") from None
            bad = [PUSH_COLUMNS[j] for j, v in enumerate(values) if not math.isfinite(v)]
            if bad:
                raise UsageError(f"{p}: line {line_no}: {bad[0]}: a finite number")
            if values[6] not in (0.0, 1.0):
                raise UsageError(f"{p}: line {line_no}: in_contact: 0 or 1 (got {row[cols[6]]!r})")
            rows.append(values)
    if len(rows) < 2:
        raise UsageError(f"{p}: need at least two samples")
    arr = np.asarray(rows)
    return {c: arr[:, j] for j, c in enumerate(PUSH_COLUMNS)}


def write_push_csv(path: str | Path, push: SimulatedPush) -> None:
    with Path(path).open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(PUSH_COLUMNS)
        for i in range(len(push.t)):
            w.writerow([f"{push.t[i]:.6f}", f"{push.x[i]:.9g}", f"{push.y[i]:.9g}", f"{push.theta[i]:.9g}",
                        f"{push.contact_object[i, 0]:.9g}", f"{push.contact_object[i, 1]:.9g}",
                        int(push.in_contact[i])])


def write_forces_csv(path: str | Path, forces: PushForces) -> None:
    def fmt(v: float) -> str:
        return "nan" if math.isnan(v) else f"{v:.9g}"

    with Path(path).open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(FORCE_COLUMNS)
        for i in range(len(forces.t)):
            w.writerow([f"{forces.t[i]:.6f}", fmt(forces.f_world[i, 0]), fmt(forces.f_world[i, 1]),
                        fmt(forces.f_object[i, 0]), fmt(forces.f_object[i, 1]), int(forces.moving[i])])
