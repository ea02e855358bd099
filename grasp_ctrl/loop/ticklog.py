"""Per-tick log of a trial as one compressed Parquet file: state, raw-signal
summary (optionally every raw frame whole), tared pdc, contacts, estimated forces
(sensor and world frames), targets, joint angles, goals and currents and, in
simulation, the true forces and object height.

Every tick only copies its arrays into preallocated column buffers (a few
microseconds); the raw-signal summaries are computed for all ticks at once and
the file is written on ``close`` with storage.atomic_writer (a temporary name
unique to the writer, fsynced, then renamed), so a tick log on disk is always
complete (the runner gives the trial a temporary path and renames it onto the
final one, fsyncing the folder, just before it writes the trial's JSON record).
Signals are stored as float32 rounded to 15 mantissa bits (a relative error of
at most 1.5e-5, about the decimals of the CSV logs this replaces; the cleared low
bits compress away), the time as float64, the state as a dictionary-encoded
string, contacts as booleans, whole raw frames (``raw_frames``) as uint16 counts
(null where a tick had no frame). pandas reads it with
``pandas.read_parquet``; ``read_tick_log`` reads it (and older CSV logs) here.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from grasp_ctrl.config.sensor_layout import CHANNEL_NAMES, ELECTRODES, FRAME_LEN, PAC, PDC, TDC
from grasp_ctrl.controller.snapshot import Command, Snapshot
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.storage import atomic_writer
from grasp_ctrl.hardware.base import JointState
from grasp_ctrl.loop.loop_kernels import log_row
from grasp_ctrl.numeric import jit

if TYPE_CHECKING:
    import pyarrow as pa

# Per-fingertip raw-signal summary columns (raw counts, before tare).
RAW_COLUMNS = ("raw_pdc", "raw_tdc", "raw_pac_std", "raw_e_mean")
# A whole raw frame's channels (``raw_frames``): the summary's raw_pdc and raw_tdc are two of them
# already, so these are the other 42, FINGER_raw_e1 .. FINGER_raw_tac (uint16 counts).
FRAME_CHANNELS = tuple((k, f"raw_{c}") for k, c in enumerate(CHANNEL_NAMES) if f"raw_{c}" not in RAW_COLUMNS)
_COUNT_MAX = np.iinfo(np.uint16).max
TICKS_SUFFIX = "_ticks.parquet"
LEGACY_TICKS_SUFFIX = "_ticks.csv"
_COMPRESSION = "zstd"
_CHUNK = 2048  # ticks per buffer growth (20 s at 100 Hz)
MANTISSA_BITS = 15  # rounding error <= 2^-16 = 1.5e-5 relative
# Byte-stream split makes float32 signals compress several times better; the raw frames' counts
# compress best as deltas (a seventh smaller than plain, a little better than byte-stream split).
_ENCODING = {"float": "BYTE_STREAM_SPLIT", "uint16": "DELTA_BINARY_PACKED"}


def rounded_float32(values: np.ndarray, bits: int = MANTISSA_BITS) -> np.ndarray:
    """float32 with the mantissa rounded to ``bits`` bits (NaN and inf unchanged)."""
    with np.errstate(over="ignore"):  # beyond float32's range is inf, kept as such below
        a = np.ascontiguousarray(values, dtype=np.float32)
    drop = 23 - bits
    u = a.view(np.uint32)
    r = ((u + np.uint32(1 << (drop - 1))) & np.uint32((0xFFFFFFFF >> drop) << drop)).view(np.float32)
    return np.where(np.isfinite(a), r, a)


def raw_summary(raw: np.ndarray) -> np.ndarray:
    """(..., n_tips, 44) raw counts -> (..., n_tips, 4): pdc, tdc, spread of the 22 pac
    samples (vibration), mean of the 19 electrodes."""
    return np.stack(
        [raw[..., PDC], raw[..., TDC], raw[..., PAC].std(axis=-1), raw[..., ELECTRODES].mean(axis=-1)], axis=-1
    )


def raw_frame_columns(finger: str) -> list[str]:
    """A fingertip's whole raw frame in a tick log, in the frame's channel order:
    ``FINGER_raw_e1 .. _raw_e19, _raw_pdc, _raw_pac1 .. _raw_pac22, _raw_tdc, _raw_tac``."""
    return [f"{finger}_raw_{c}" for c in CHANNEL_NAMES]


def tick_columns(fingers: list[str], n_joints: int, truth: bool, raw_frames: bool = False) -> list[str]:
    """The log's column names, in file order."""
    cols = ["t", "state", "palm_x_world", "palm_y_world", "palm_z_world", "palm_target_z_world", "grip_target_n"]
    for f in fingers:
        cols += [f"{f}_{c}" for c in RAW_COLUMNS]
        if raw_frames:
            cols += [f"{f}_{c}" for _, c in FRAME_CHANNELS]
        cols += [f"{f}_contact", f"{f}_pdc_tared", f"{f}_grip_n"]
        cols += [f"{f}_f{a}_sensor" for a in "xyz"] + [f"{f}_f{a}_world" for a in "xyz"]
        if truth:
            cols += [f"{f}_true_f{a}_sensor" for a in "xyz"]
    cols += [f"q{j}" for j in range(n_joints)] + [f"q_goal{j}" for j in range(n_joints)]
    cols += [f"current{j}" for j in range(n_joints)]
    if truth:
        cols += ["object_z_world", "table_force_n"]
    return cols


class CurrentTap:
    """A hand backend that keeps the joint currents of its last ``read`` for the tick log:
    ``control_tick`` reads the hand once a tick and returns no currents, and a second read
    would cost a real (or emulated) hand a bus transaction. Everything else is the hand's."""

    def __init__(self, hand: Any) -> None:
        self.hand = hand
        self.current_a: np.ndarray | None = None

    def read(self) -> JointState:
        state = self.hand.read()
        self.current_a = state.current_a
        return state

    def check_health(self) -> None:  # (every tick: not through __getattr__)
        self.hand.check_health()

    def take(self) -> np.ndarray | None:
        """The currents read since the last ``take`` (None when the tick read none)."""
        current, self.current_a = self.current_a, None
        return current

    def __getattr__(self, name: str) -> Any:
        return getattr(self.hand, name)


class TickLog:
    """``raw_frames``: also write every fingertip's whole raw frame (42 more columns per
    fingertip); the frames are kept in memory either way, for the summary."""

    def __init__(self, path: Path, fingers: list[str], n_joints: int, truth: bool, raw_frames: bool = False) -> None:
        self.path = Path(path)
        self.fingers = list(fingers)
        self.truth = truth
        self.raw_frames = raw_frames
        self.columns = tick_columns(self.fingers, n_joints, truth, raw_frames)
        self._closed = False
        self._n = 0
        self._states: list[str] = []
        F = len(self.fingers)
        # One float64 block, a row per tick: each field's values (C order) in its columns, in this order.
        shapes: dict[str, tuple[int, ...]] = {
            "t": (),
            "palm": (3,),
            "palm_target_z": (),
            "grip_target": (),
            "raw": (F, FRAME_LEN),
            "contact": (F,),
            "pdc_tared": (F,),
            "grip": (F,),
            "f_sensor": (F, 3),
            "f_world": (F, 3),
            "q": (n_joints,),
            "q_goal": (n_joints,),
        }
        if truth:
            shapes.update({"true_f": (F, 3), "object_z": (), "table_force": ()})
        self._shapes = shapes
        self._fields: dict[str, tuple[int, int]] = {}  # name -> (first column, width)
        width = 0
        for name, shape in shapes.items():
            size = int(np.prod(shape, dtype=np.int64))
            self._fields[name] = (width, size)
            width += size
        self._block = np.empty((_CHUNK, width))  # every field of a row is written when it is appended
        self._buf = self._views(self._block)
        # Joint currents beside the block, not in it: the compiled row writer (log_row) keeps its
        # layout, and a row whose currents never come stays NaN.
        self._current = np.full((_CHUNK, n_joints), np.nan)
        self._compiled = jit.JIT and truth

    def _views(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        """Each field of ``rows`` (a block's rows) as an (n, *shape) view."""
        return {
            name: rows[:, c0 : c0 + size].reshape(len(rows), *self._shapes[name])
            for name, (c0, size) in self._fields.items()
        }

    def _grow(self) -> None:
        self._block = np.concatenate([self._block, np.empty((_CHUNK, self._block.shape[1]))])
        self._buf = self._views(self._block)
        self._current = np.concatenate([self._current, np.full((_CHUNK, self._current.shape[1]), np.nan)])

    def set_current(self, current_a: np.ndarray | None) -> None:
        """The joint currents (A, the hand file's joint order) of the row appended last, as the
        hand backend reported them in that tick. None, or a vector of another length, leaves
        them NaN: the log is no place to fail a trial."""
        if current_a is None or self._n == 0:
            return
        a = np.asarray(current_a, dtype=float)
        if a.shape == self._current.shape[1:]:
            self._current[self._n - 1] = a

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
        current_a: np.ndarray | None = None,
    ) -> None:
        """One tick's row; ``current_a``: the joint currents the hand reported (``set_current``)."""
        i = self._n
        if i == len(self._block):
            self._grow()
        nd = np.ndarray
        if (
            self._compiled
            and type(raw) is nd
            and type(true_f_sensor) is nd
            and type(tared) is nd
            and type(snap.p_palm_world) is nd
            and type(cmd.p_palm_world) is nd
            and type(snap.in_contact) is nd
            and type(snap.grip_n) is nd
            and type(snap.f_sensor) is nd
            and type(snap.f_world) is nd
            and type(snap.q) is nd
            and type(cmd.q_goal) is nd
            and log_row(
                self._block,
                i,
                snap.t,
                snap.p_palm_world,
                cmd.p_palm_world,
                grip_target_n,
                raw,
                snap.in_contact,
                tared,
                snap.grip_n,
                snap.f_sensor,
                snap.f_world,
                snap.q,
                cmd.q_goal,
                true_f_sensor,
                object_z,
                table_force,
            )
        ):
            self._states.append(state)
            self._n = i + 1
            self.set_current(current_a)
            return
        b = self._buf
        b["t"][i] = snap.t
        b["palm"][i] = snap.p_palm_world
        b["palm_target_z"][i] = cmd.p_palm_world[2]
        b["grip_target"][i] = grip_target_n
        b["raw"][i] = np.nan if raw is None else raw
        b["contact"][i] = snap.in_contact
        b["pdc_tared"][i] = tared[:, PDC]
        b["grip"][i] = snap.grip_n
        b["f_sensor"][i] = snap.f_sensor
        b["f_world"][i] = snap.f_world
        b["q"][i] = snap.q
        b["q_goal"][i] = cmd.q_goal
        if self.truth:
            assert true_f_sensor is not None
            b["true_f"][i] = true_f_sensor
            b["object_z"][i] = object_z
            b["table_force"][i] = table_force
        self._states.append(state)
        self._n = i + 1
        self.set_current(current_a)

    def _table(self) -> pa.Table:
        import pyarrow as pa

        n = self._n
        b = self._views(self._block[:n])
        summary = raw_summary(b["raw"])
        # Every float32 column in file order, rounded in one pass over a (columns, ticks) block.
        f32_names: list[str] = ["palm_x_world", "palm_y_world", "palm_z_world", "palm_target_z_world", "grip_target_n"]
        f32_values: list[np.ndarray] = [
            b["palm"][:, 0],
            b["palm"][:, 1],
            b["palm"][:, 2],
            b["palm_target_z"],
            b["grip_target"],
        ]
        for i, f in enumerate(self.fingers):
            for k, c in enumerate(RAW_COLUMNS):
                f32_names.append(f"{f}_{c}")
                f32_values.append(summary[:, i, k])
            f32_names += [f"{f}_pdc_tared", f"{f}_grip_n"]
            f32_values += [b["pdc_tared"][:, i], b["grip"][:, i]]
            for key, label in (("f_sensor", "_f{}_sensor"), ("f_world", "_f{}_world")) + (
                (("true_f", "_true_f{}_sensor"),) if self.truth else ()
            ):
                for a, axis in enumerate("xyz"):
                    f32_names.append(f + label.format(axis))
                    f32_values.append(b[key][:, i, a])
        for key, label in (("q", "q{}"), ("q_goal", "q_goal{}")):
            for j in range(b[key].shape[1]):
                f32_names.append(label.format(j))
                f32_values.append(b[key][:, j])
        current = self._current[:n]
        for j in range(current.shape[1]):
            f32_names.append(f"current{j}")
            f32_values.append(current[:, j])
        if self.truth:
            f32_names += ["object_z_world", "table_force_n"]
            f32_values += [b["object_z"], b["table_force"]]
        stacked = np.empty((len(f32_values), n))
        for k, values in enumerate(f32_values):
            stacked[k] = values
        rounded = rounded_float32(stacked)
        f32 = dict(zip(f32_names, rounded))
        frames = self._frame_columns(b["raw"]) if self.raw_frames else {}
        data: dict[str, pa.Array] = {}
        for name in self.columns:
            if name == "t":
                data[name] = pa.array(b["t"])
            elif name == "state":
                data[name] = pa.array(self._states, type=pa.string()).dictionary_encode()
            elif name.endswith("_contact"):
                data[name] = pa.array(b["contact"][:, self.fingers.index(name[: -len("_contact")])] > 0.5)
            elif name in frames:
                data[name] = frames.pop(name)
            elif name.startswith("current"):
                # null where the hand reported no current (readers see NaN): a missing value, as in the frames
                values = f32.pop(name)
                gone = np.isnan(values)
                data[name] = pa.array(values, mask=gone if gone.any() else None)
            else:
                data[name] = pa.array(f32.pop(name))
        assert not f32 and not frames, sorted(f32) + sorted(frames)  # every column has its place in the file
        return pa.table(data)

    def _frame_columns(self, raw: np.ndarray):  # -> dict[str, pyarrow.Array]
        """The whole frames' channels (``FRAME_CHANNELS``) of (ticks, fingers, 44) ``raw`` as
        uint16 counts, null where a tick had no frame (NaN). A frame holds integer counts
        (12-bit on the BioTac), so the rounding and the clip change nothing on a real one."""
        import pyarrow as pa

        missing = ~np.isfinite(raw)
        counts = np.clip(np.rint(np.where(missing, 0.0, raw)), 0, _COUNT_MAX).astype(np.uint16)
        out = {}
        for i, f in enumerate(self.fingers):
            for k, c in FRAME_CHANNELS:
                gone = missing[:, i, k]
                out[f"{f}_{c}"] = pa.array(counts[:, i, k], mask=gone if gone.any() else None)
        return out

    def close(self) -> None:
        """Write the file (temporary name, fsync, rename); once only."""
        if self._closed:
            return
        self._closed = True
        import pyarrow.parquet as pq

        table = self._table()
        encoding = {c: _ENCODING.get(str(f.type)) for c, f in zip(table.column_names, table.schema)}
        # Unique temporary name, fsync, rename. The folder is not fsynced here: the trial runner
        # writes the log under a temporary name of its own and fsyncs the folder when it moves
        # the log onto its final name (commit_temp), so a second folder fsync per trial (a few
        # milliseconds on this project's machine) would buy nothing.
        with atomic_writer(self.path, "wb", sync_dir=False) as fh:
            # (no column statistics: nothing reads them, and they cost a tenth of the write)
            pq.write_table(
                table,
                fh,
                compression=_COMPRESSION,
                use_dictionary=["state"],
                write_statistics=False,
                column_encoding={c: e for c, e in encoding.items() if e},
            )


def read_tick_log(path: Path) -> tuple[list[str], dict[str, np.ndarray]]:
    """(column order, column -> values) of a tick log: Parquet, or the CSV of older runs
    (a CSV row cut short by a crash ends the log). ``state`` is an array of str,
    other columns float (contacts 0/1, missing values NaN). Every reader (plot, replays,
    bags) relies on what :func:`check_tick_log` guarantees; a foreign or damaged file is a
    one-line UsageError naming the file and the column."""
    path = Path(path)
    if path.suffix == ".csv":
        header, cols = _read_csv(path)
    else:
        header, cols = _read_parquet(path)
    check_tick_log(path, header, cols)
    return header, cols


def _read_parquet(path: Path) -> tuple[list[str], dict[str, np.ndarray]]:
    try:
        import pyarrow.parquet as pq

        table = pq.read_table(path)
    except OSError as exc:
        raise UsageError(f"{path}: cannot read ({_first_line(exc)})") from None
    except Exception as exc:  # pyarrow's ArrowInvalid: not a Parquet file, or one cut short
        raise UsageError(f"{path}: not a tick log: not a whole Parquet file ({_first_line(exc)})") from None
    header = table.column_names
    if len(set(header)) != len(header):
        raise UsageError(f"{path}: not a tick log: a column name appears twice")
    cols = {name: _column_values(path, name, table.column(name)) for name in header}
    return header, cols


def _first_line(exc: Exception) -> str:
    """An exception's message on one short line, without the path pyarrow repeats."""
    text = re.sub(r"^Could not open Parquet input source '[^']*': ", "", str(exc).strip())
    line = text.splitlines()[0] if text else type(exc).__name__
    return line if len(line) <= 160 else line[:157] + "..."


def _column_values(path: Path, name: str, column: pa.ChunkedArray) -> np.ndarray:
    """A Parquet column as the readers take it: ``state`` as str, any other as float (null: NaN)."""
    import pyarrow as pa

    kind = column.type.value_type if pa.types.is_dictionary(column.type) else column.type
    if name == "state":
        if not (pa.types.is_string(kind) or pa.types.is_large_string(kind)):
            raise UsageError(f"{path}: column 'state' holds {kind}, not the controller's state names")
        return np.asarray(column.to_pylist(), dtype=object)
    if not (pa.types.is_integer(kind) or pa.types.is_floating(kind) or pa.types.is_boolean(kind)):
        raise UsageError(f"{path}: column {name!r} holds {kind}, not numbers; not a tick log")
    return np.asarray(column.cast(pa.float64()).to_numpy(), dtype=float)


def required_columns(header: list[str]) -> list[str]:
    """The columns every tick log holds and its readers rely on, for the fingertips and joints
    ``header`` names: time, state, palm position, each fingertip's estimated force in both
    frames, each joint's angle and goal. Other columns (currents, truth, raw signals) are
    optional: a log from before them, or from the real hand, has none."""
    fingers = [c[: -len("_fx_sensor")] for c in header if c.endswith("_fx_sensor") and "_true_" not in c]
    n_joints = 1 + max((int(c[1:]) for c in header if c.startswith("q") and c[1:].isdigit()), default=-1)
    need = ["t", "state", "palm_x_world", "palm_y_world", "palm_z_world"]
    need += [f"{f}_f{a}_{frame}" for f in fingers for frame in ("sensor", "world") for a in "xyz"]
    need += [f"q{j}" for j in range(max(n_joints, 1))] + [f"q_goal{j}" for j in range(max(n_joints, 1))]
    return need


def check_tick_log(path: Path, header: list[str], cols: dict[str, np.ndarray]) -> None:
    """A one-line UsageError naming ``path`` and the column when the log lacks a column its
    readers need, has no rows, or holds a NaN, an infinity or an empty state where the trial
    wrote none (the tick replaces a non-finite pose or estimate before logging it)."""
    if "t" not in cols or "state" not in cols:
        raise UsageError(f"{path}: not a tick log (no 't' and 'state' columns)")
    if not len(cols["t"]):
        raise UsageError(f"{path}: empty tick log")
    need = required_columns(header)
    if not any(c.endswith("_fx_sensor") for c in need):
        raise UsageError(f"{path}: not a tick log: no fingertip force column (FINGER_fx_sensor)")
    missing = [c for c in need if c not in cols]
    if missing:
        more = f" (and {len(missing) - 1} more)" if len(missing) > 1 else ""
        raise UsageError(f"{path}: not a whole tick log: no column {missing[0]!r}{more}")
    states = cols["state"]
    empty = [i for i, s in enumerate(states) if not isinstance(s, str) or not s]
    if empty:
        raise UsageError(f"{path}: column 'state' is empty at row {empty[0]}")
    for name in (c for c in need if c != "state"):
        bad = np.flatnonzero(~np.isfinite(cols[name]))
        if len(bad):
            k = int(bad[0])
            raise UsageError(f"{path}: column {name!r} is {_shown(cols[name][k])} at row {k} (a damaged tick log)")


def _shown(value: float) -> str:
    return "NaN (or empty)" if np.isnan(value) else "infinite"


def _read_csv(path: Path) -> tuple[list[str], dict[str, np.ndarray]]:
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh)
            header = next(reader, None)
            if not header:
                raise UsageError(f"{path}: empty tick log")
            rows = []
            for row in reader:
                if len(row) != len(header):
                    break  # a row cut short by a crash: keep what came before
                rows.append(row)
    except OSError as exc:
        raise UsageError(f"{path}: cannot read ({exc.strerror})") from None
    cols: dict[str, np.ndarray] = {}
    for k, name in enumerate(header):
        values = [r[k] for r in rows]
        cols[name] = np.array(values, dtype=object) if name == "state" else np.array([_num(v) for v in values])
    return header, cols


def _num(v: str) -> float:
    try:
        return float(v)
    except ValueError:
        return float("nan")
