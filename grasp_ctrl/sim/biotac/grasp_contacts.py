"""Where and how the hand's grasps press its fingertips: contacts recorded in MuJoCo.

The learned policies are fitted on simulated presses of the BioTac model. Drawn by
hand (``sim/biotac/presses.py``, ``learning/synthetic.py``) they miss where a grasp of the
LEAP Hand actually loads a fingertip: the proximal end of the pad on a box's rim,
the tip on the mustard bottle's cap with as much shear as normal force. The recorder
(``trials/episode/contact_recorder.py``) runs trials in the reference world with true
forces (the oracle) and keeps, every few control periods, what each fingertip touching
the object gave the sensor model: the contact point and the skin's normal there (sensor
frame) and the force on the skin; this module holds them and their file. Training code then presses freshly drawn simulated sensors at those contacts
(``presses.contact_presses``, the ball-ft source of ``learning/synthetic.py``).

The recording seeds should not be the seeds results are reported on: the default
base seed, 1000, is used by no documented run.

CSV (``csv_text`` / ``read_csv``): one row per contact, SI units, sensor frame::

    object,finger,t_s,p_x_m,p_y_m,p_z_m,n_x,n_y,n_z,f_x_n,f_y_n,f_z_n
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: Base seed of the recording trials (each trial's seed derives from it, the object and the index).
DEFAULT_SEED = 1000
#: Keep every this many control periods (at 100 Hz: 30 ms apart).
DEFAULT_EVERY = 3
#: Forces below this are contact noise, not presses (N).
MIN_FORCE_N = 0.05

TEXT_COLUMNS = ("object", "finger")
NUMERIC_COLUMNS = ("t_s", "p_x_m", "p_y_m", "p_z_m", "n_x", "n_y", "n_z", "f_x_n", "f_y_n", "f_z_n")
#: A fingertip contact lies within a few centimetres of the sensor origin; normals are unit
#: vectors; a fingertip force beyond 100 N is not a grasp's.
MAX_POINT_M = 0.05
MAX_FORCE_N = 100.0


@dataclass
class GraspContacts:
    """Recorded fingertip contacts (n rows)."""

    object: np.ndarray  # (n,) str
    finger: np.ndarray  # (n,) str
    t_s: np.ndarray  # (n,) s since the trial's start
    p_sensor: np.ndarray  # (n, 3) m, the contact point on the skin
    n_sensor: np.ndarray  # (n, 3) the skin's outward normal there
    f_sensor: np.ndarray  # (n, 3) N, force ON the skin

    def __len__(self) -> int:
        return len(self.t_s)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """Indices of ``n`` contacts drawn uniformly (with replacement)."""
        if not len(self):
            raise ValueError("no grasp contacts to draw from")
        return rng.integers(0, len(self), n)

    def summary(self) -> str:
        objects = ", ".join(f"{o} {int((self.object == o).sum())}" for o in dict.fromkeys(self.object.tolist()))
        return f"{len(self)} contacts ({objects})"


def csv_text(gc: GraspContacts) -> str:
    """The CSV file's text (``repr`` floats: a read gives the same numbers back)."""
    lines = [",".join(TEXT_COLUMNS + NUMERIC_COLUMNS)]
    for i in range(len(gc)):
        nums = [gc.t_s[i], *gc.p_sensor[i], *gc.n_sensor[i], *gc.f_sensor[i]]
        lines.append(",".join([str(gc.object[i]), str(gc.finger[i]), *(repr(float(v)) for v in nums)]))
    return "\n".join(lines) + "\n"


def _row_check(values: np.ndarray) -> str | None:
    normal = values[4:7]
    if not 0.9 <= math.sqrt(float(normal @ normal)) <= 1.1:
        return "n_x, n_y, n_z: a unit normal"
    return None


def load_contacts(path: str | Path | None, skip_bad_rows: bool = False) -> GraspContacts | None:
    """``read_csv(path)``, or None where no file is given (an optional ``--grasp-contacts``)."""
    return read_csv(path, skip_bad_rows) if path else None


def read_csv(path: str | Path, skip_bad_rows: bool = False) -> GraspContacts:
    """A file of ``csv_text`` (the ``grasp-contacts`` command); a bad row is reported by its line."""
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.files.csv_rows import Column, read_rows

    p = Path(path)
    numeric = [Column("t_s", 0.0, 1e6)]
    numeric += [Column(c, -MAX_POINT_M, MAX_POINT_M) for c in ("p_x_m", "p_y_m", "p_z_m")]
    numeric += [Column(c, -1.1, 1.1) for c in ("n_x", "n_y", "n_z")]
    numeric += [Column(c, -MAX_FORCE_N, MAX_FORCE_N) for c in ("f_x_n", "f_y_n", "f_z_n")]
    rows = read_rows(
        p, numeric, TEXT_COLUMNS, skip_bad_rows=skip_bad_rows, what="grasp-contacts file", row_check=_row_check
    )
    if not len(rows.values):
        raise UsageError(f"{p}: no contacts")
    v = rows.values
    text = np.array(rows.text, dtype=object).reshape(len(v), 2)
    return GraspContacts(text[:, 0], text[:, 1], v[:, 0], v[:, 1:4], v[:, 4:7], v[:, 7:10])
