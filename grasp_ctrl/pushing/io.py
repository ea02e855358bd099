"""PUSH.csv in, FORCES.csv out (docs/design.md 5.4). Bad rows are reported by line."""

from __future__ import annotations

import contextlib
import csv
import io
import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.csv_rows import Column, read_rows
from grasp_ctrl.files.safe_write import write_output
from grasp_ctrl.pushing.simulate import SimulatedPush
from grasp_ctrl.pushing.solver import PushForces

PUSH_COLUMNS = ("t", "x", "y", "theta", "contact_x", "contact_y", "in_contact")
FORCE_COLUMNS = ("t", "fx_world", "fy_world", "fx_object", "fy_object", "moving")


PUSH_RANGES = {
    "t": 1e7,
    "x": 100.0,
    "y": 100.0,
    "theta": 1e4,
    "contact_x": 100.0,
    "contact_y": 100.0,
    "in_contact": 1.0,
}  # |value| at most: s, m, rad (unwrapped), m


def _contact_flag(values: np.ndarray) -> str | None:
    return None if values[6] in (0.0, 1.0) else f"in_contact: 0 or 1 (got {values[6]:g})"


def read_push_csv(path: str | Path, skip_bad_rows: bool = False) -> dict[str, np.ndarray]:
    """Columns of PUSH.csv as float arrays (extra columns ignored). A bad row (short, not
    numbers, NaN, out of range, binary junk) is named by line, or left out with ``skip_bad_rows``."""
    p = Path(path)
    cols = [Column(c, -PUSH_RANGES[c], PUSH_RANGES[c]) for c in PUSH_COLUMNS]
    rows = read_rows(p, cols, skip_bad_rows=skip_bad_rows, what="trajectory", row_check=_contact_flag)
    if len(rows.values) < 2:
        raise UsageError(f"{p}: need at least two samples")
    t = rows.values[:, 0]
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        raise UsageError(
            f"{p}: line {rows.lines[back[0] + 1]}: t: increasing times (got {t[back[0] + 1]:g} after {t[back[0]]:g})"
        )
    return {c: rows.values[:, j] for j, c in enumerate(PUSH_COLUMNS)}


@contextlib.contextmanager
def _text_output(path: str | Path) -> Iterator[io.StringIO]:
    """Collect the text, then write it as a new file (a symlink there is replaced, not followed)."""
    buf = io.StringIO(newline="")
    yield buf
    write_output(path, buf.getvalue())


def write_push_csv(path: str | Path, push: SimulatedPush) -> None:
    with _text_output(path) as fh:
        w = csv.writer(fh)
        w.writerow(PUSH_COLUMNS)
        for i in range(len(push.t)):
            w.writerow(
                [
                    f"{push.t[i]:.6f}",
                    f"{push.x[i]:.9g}",
                    f"{push.y[i]:.9g}",
                    f"{push.theta[i]:.9g}",
                    f"{push.contact_object[i, 0]:.9g}",
                    f"{push.contact_object[i, 1]:.9g}",
                    int(push.in_contact[i]),
                ]
            )


def write_forces_csv(path: str | Path, forces: PushForces) -> None:
    def fmt(v: float) -> str:
        return "nan" if math.isnan(v) else f"{v:.9g}"

    with _text_output(path) as fh:
        w = csv.writer(fh)
        w.writerow(FORCE_COLUMNS)
        for i in range(len(forces.t)):
            w.writerow(
                [
                    f"{forces.t[i]:.6f}",
                    fmt(forces.f_world[i, 0]),
                    fmt(forces.f_world[i, 1]),
                    fmt(forces.f_object[i, 0]),
                    fmt(forces.f_object[i, 1]),
                    int(forces.moving[i]),
                ]
            )
