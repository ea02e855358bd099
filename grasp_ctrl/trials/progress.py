"""Progress lines for a series of trials: count, outcome, time, ETA, running tally."""

from __future__ import annotations

import sys
import time
from collections import defaultdict
from typing import Any, Callable, TextIO


def format_duration(seconds: float) -> str:
    s = int(round(max(seconds, 0.0)))
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{(s % 3600) // 60:02d}m"


class Progress:
    """One line per finished trial on ``stream`` (stderr by default)."""

    def __init__(
        self,
        total: int,
        stream: TextIO | None = None,
        enabled: bool = True,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.total = total
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.clock = clock
        self.done = 0
        self._ran = 0
        self._t0 = clock()
        self._tally: dict[str, list[int]] = defaultdict(lambda: [0, 0])  # policy -> [successes, trials]

    def _say(self, line: str) -> None:
        if self.enabled:
            print(line, file=self.stream, flush=True)

    def resumed(self, records: list[dict[str, Any]]) -> None:
        """Trials already on disk from an earlier, interrupted session."""
        for rec in records:
            self._count(rec)
        self.done = len(records)
        if records:
            self._say(f"resuming: {self.done} of {self.total} trials already recorded")

    def _count(self, rec: dict[str, Any]) -> None:
        t = self._tally[rec["policy"]]
        t[0] += bool(rec["success"])
        t[1] += 1

    def trial_done(self, rec: dict[str, Any]) -> None:
        self._count(rec)
        self.done += 1
        self._ran += 1
        elapsed = self.clock() - self._t0
        left = self.total - self.done
        eta = f", eta {format_duration(elapsed / self._ran * left)}" if left else ""
        mark = "ok" if rec["success"] else f"FAIL {rec['reason']}"
        s, n = self._tally[rec["policy"]]
        wall = rec.get("wall_duration_s")
        took = f"{wall:.1f}s" if isinstance(wall, (int, float)) else "?"
        self._say(
            f"[{self.done}/{self.total}] {rec['policy']} {rec['object']} #{rec['trial']}: {mark} "
            f"({took}{eta}; {rec['policy']} {s}/{n} so far)"
        )
