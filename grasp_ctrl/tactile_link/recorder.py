"""CSV recording of every valid tactile frame (``sensors --record``).

Columns: ``t_recv, finger, seq, e1..e19, pdc, pac1..pac22, tdc, tac``; ``finger`` is
the sensor id of the frame (the protocol's finger number), values are raw counts.
Rows are flushed after every batch so a crash or Ctrl-C loses nothing written.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable
from pathlib import Path

from grasp_ctrl.config.sensor_layout import CHANNEL_NAMES
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import open_output
from grasp_ctrl.hardware.base import TactileFrame

HEADER: tuple[str, ...] = ("t_recv", "finger", "seq") + CHANNEL_NAMES


class FrameRecorder:
    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        try:
            # a stream (-, /dev/stdout, a FIFO) is written as such; a symlink is replaced (safe_write)
            self._fh = io.TextIOWrapper(open_output(self.path, "--record"), newline="", encoding="utf-8")
        except OSError as exc:
            raise UsageError(f"--record {self.path}: cannot write ({exc.strerror})") from None
        self._writer = csv.writer(self._fh)
        self._writer.writerow(HEADER)
        self._fh.flush()
        self.rows = 0

    def write(self, frames: Iterable[TactileFrame]) -> int:
        n = 0
        for f in frames:
            self._writer.writerow([f"{f.t_recv:.6f}", f.sensor_id, f.seq, *(int(v) for v in f.values)])
            n += 1
        if n:
            self._fh.flush()
            self.rows += n
        return n

    def close(self) -> None:
        if not self._fh.closed:
            self._fh.flush()
            self._fh.close()

    def __enter__(self) -> FrameRecorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
